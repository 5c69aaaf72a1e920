#include "bench/find_bench.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "cloud/cloud_io.hpp"
#include "fitting/uncertainty.hpp"
#include "pipeline/error.hpp"
#include "pipeline/print.hpp"
#include "scene/finder.hpp"
#include "sim/scan.hpp"

namespace hedgefit::bench {

using pipeline::Print;

const pipeline::OptionTable<FindBenchOptions>& FindBenchOptions::Table() {
  using O = FindBenchOptions;
  static const auto table = pipeline::OptionTable<O>()
                                .Add("sensors", &O::sensors, "comma-separated: lidar16, lidar32, terrestrial, photogrammetry")
                                .Add("gardens", &O::gardens, "gardens per sensor (seeds 1..N)", "gardens").Range(1, 1000)
                                .Add("height", &O::height_mm, "the LiDAR's and the tripod's height above the lawn", "mm")
                                .Range(200, 5000)
                                .Add("dir", &O::dir, "also write each scan (PLY, metres) and its truth here");
  return table;
}

namespace {

std::vector<std::string> Split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) if (!item.empty()) out.push_back(item);
  return out;
}

FindBenchRow Score(const sim::ScanScene& scene, const scene::FindResult& r) {
  FindBenchRow row;
  row.objects = r.objects.size();
  std::vector<bool> used(r.objects.size(), false);
  for (const auto& t : scene.balls) {
    FindBenchBall b;
    b.true_radius_mm = t.radius_mm;
    double best = 0.5 * t.radius_mm;
    int pick = -1;
    for (std::size_t k = 0; k < r.objects.size(); ++k) {
      const auto& o = r.objects[k];
      if (!o.fit.converged) continue;
      const double d = (o.fit.sphere.center_mm - t.center_mm).norm();
      if (d < best) best = d, pick = int(k);
    }
    if (pick >= 0) {
      const auto& o = r.objects[std::size_t(pick)];
      used[std::size_t(pick)] = true;
      b.found = o.ball;
      b.verdict = o.verdict;
      b.radius_mm = o.fit.sphere.radius_mm;
      b.surface_radius_mm = o.fit.Extra("surface_radius_mm").value_or(o.fit.sphere.radius_mm);
      b.center_error_mm = best;
      b.ground_error_mm = o.ground_mm - scene.ground.Height(o.fit.sphere.center_mm.x(), o.fit.sphere.center_mm.y()) +
                          (scene.ground.Height(o.fit.sphere.center_mm.x(), o.fit.sphere.center_mm.y()) -
                           scene.ground.Height(t.center_mm.x(), t.center_mm.y()));
      b.points = o.indices.size();
      if (const auto se = fitting::TotalStdError(o.fit)) b.ci95_radius_mm = 1.96 * (*se)[3];
    }
    row.balls.push_back(b);
  }
  for (std::size_t k = 0; k < r.objects.size(); ++k) {
    const auto& o = r.objects[k];
    if (!o.topiary || used[k]) continue;  // every clipped shape counts: balls, and topiary found by height
    std::string what = "nothing";
    double best = 1e300;
    for (const auto& other : scene.others) {
      const double d = (other.center_mm.head<2>() - o.fit.sphere.center_mm.head<2>()).norm();
      if (d < best && d < 3000) best = d, what = other.kind;
    }
    row.false_balls.push_back(what);
  }
  return row;
}

}  // namespace

FindBenchResult RunFindBench(const FindBenchOptions& o) {
  FindBenchResult result;
  if (!o.dir.empty()) std::filesystem::create_directories(o.dir);
  for (const std::string& name : Split(o.sensors)) {
    const sim::Sensor sensor = sim::ParseSensor(name);
    for (int seed = 1; seed <= o.gardens; ++seed) {
      const sim::ScanScene scene = sim::RandomScanGarden(std::uint64_t(seed));
      sim::ScanOptions so;
      so.sensor = sensor;
      so.height_mm = o.height_mm;
      so.seed = std::uint64_t(seed);
      so.noise_mm = sensor == sim::Sensor::kTerrestrial ? 3 : (sensor == sim::Sensor::kPhotogrammetry ? 5 : 10);
      const cloud::PointCloud cloud = sim::ScanGarden(scene, so);
      if (!o.dir.empty()) {
        const std::string stem = o.dir + "/" + name + "_garden" + std::to_string(seed);
        cloud::PointCloud metres = cloud;
        for (auto& p : metres.points_mm) p /= 1000.f;
        cloud::WriteCloud(stem + ".ply", metres);
        sim::WriteScanTruth(stem + ".truth.json", scene);
      }
      const auto t0 = std::chrono::steady_clock::now();
      const scene::FindResult found = scene::FindHedges(cloud);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      FindBenchRow row = Score(scene, found);
      row.sensor = name;
      row.seed = std::uint64_t(seed);
      row.points = cloud.size();
      row.ms = ms;
      result.rows.push_back(std::move(row));
    }
  }
  return result;
}

void PrintFindBench(const FindBenchResult& result) {
  std::cout << "sensor          garden  points    balls found  false (what)        |dr| mean/max %  dc max %  |dg| max mm  time s\n";
  for (const auto& row : result.rows) {
    std::size_t found = 0;
    double dr_sum = 0, dr_max = 0, dc_max = 0, dg_max = 0;
    for (const auto& b : row.balls) {
      if (!b.found) continue;
      ++found;
      const double dr = 100 * std::abs(b.radius_mm - b.true_radius_mm) / b.true_radius_mm;
      dr_sum += dr, dr_max = std::max(dr_max, dr);
      dc_max = std::max(dc_max, 100 * b.center_error_mm / b.true_radius_mm);
      dg_max = std::max(dg_max, std::abs(b.ground_error_mm));
    }
    std::string what;
    for (const auto& f : row.false_balls) what += (what.empty() ? "" : ",") + f;
    Print(std::cout, "%-15s %6llu  %8zu  %zu / %zu        %zu %-14s  %5.2f / %5.2f    %6.2f    %6.1f      %6.2f\n",
          row.sensor.c_str(), static_cast<unsigned long long>(row.seed), row.points, found, row.balls.size(),
          row.false_balls.size(), what.empty() ? "" : ("(" + what + ")").c_str(), found ? dr_sum / double(found) : 0.0,
          dr_max, dc_max, dg_max, row.ms / 1000);
    for (const auto& b : row.balls) {
      Print(std::cout, "    r %6.0f: %-10s r %7.1f  leaf r %7.1f  +-%5.1f  dc %6.1f  dg %6.1f  %zu points\n", b.true_radius_mm,
            b.found ? b.verdict.c_str() : (b.verdict.empty() ? "missed" : b.verdict.c_str()), b.radius_mm,
            b.surface_radius_mm, b.ci95_radius_mm, b.center_error_mm, b.ground_error_mm, b.points);
    }
  }
}

std::string FindBenchJson(const FindBenchResult& result) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& row : result.rows) {
    nlohmann::json r = {{"sensor", row.sensor}, {"seed", row.seed}, {"points", row.points}, {"objects", row.objects},
                        {"seconds", row.ms / 1000}, {"false_balls", row.false_balls}};
    r["balls"] = nlohmann::json::array();
    for (const auto& b : row.balls) {
      r["balls"].push_back({{"true_radius_mm", b.true_radius_mm}, {"found", b.found}, {"verdict", b.verdict},
                            {"radius_mm", b.radius_mm}, {"surface_radius_mm", b.surface_radius_mm},
                            {"center_error_mm", b.center_error_mm}, {"ground_error_mm", b.ground_error_mm},
                            {"ci95_radius_mm", b.ci95_radius_mm}, {"points", b.points}});
    }
    j.push_back(r);
  }
  return j.dump(2) + "\n";
}

}  // namespace hedgefit::bench
