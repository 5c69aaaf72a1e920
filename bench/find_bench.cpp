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
                                .Add("sensors", &O::sensors, "comma-separated: lidar16, lidar32, terrestrial, photogrammetry, aerial")
                                .Add("gardens", &O::gardens, "gardens per sensor (seeds first_seed..)", "gardens").Range(0, 1000)
                                .Add("beds", &O::beds, "topiary beds per bed sensor (seeds first_seed..)", "beds").Range(0, 1000)
                                .Add("bed_sensors", &O::bed_sensors, "comma-separated sensors for the beds: aerial (from above only), photogrammetry, ...")
                                .Add("first_seed", &O::first_seed, "the first seed: 1-3 chose the defaults; 101 and on are held back", "")
                                .Range(1, 1000000)
                                .Add("height", &O::height_mm, "the LiDAR's and the tripod's height above the lawn", "mm")
                                .Range(200, 5000)
                                .Add("dir", &O::dir, "also write each scan (PLY, metres) and its truth here")
                                .Add("viewpoints", &O::viewpoints,
                                     "tell find where the sensor stood (each scan's stations; written beside it with --dir, .viewpoints.xyz)");
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
  // Each truth topiary: the nearest clipped shape in the top view within half its narrower
  // semi-axis.
  for (const auto& t : scene.topiary) {
    FindBenchTopiary e;
    e.true_axes_mm = t.axes_mm;
    int pick = -1;
    double best = 0.5 * t.axes_mm.y();
    for (std::size_t k = 0; k < r.objects.size(); ++k) {
      const auto& o = r.objects[k];
      if (!o.topiary || used[k] || !o.fit.converged) continue;
      const Eigen::Vector3d c = o.shape ? o.shape->center_mm : o.fit.sphere.center_mm;
      const double d = (c.head<2>() - t.center_mm.head<2>()).norm();
      if (d < best) best = d, pick = int(k);
    }
    if (pick >= 0) {
      const auto& o = r.objects[std::size_t(pick)];
      used[std::size_t(pick)] = true;
      e.found = true;
      e.shape = o.verdict;
      e.axes_mm = o.shape ? o.shape->axes_mm : Eigen::Vector3d::Constant(o.fit.sphere.radius_mm);
      if (o.shape) {
        e.axes_ci95_mm = o.shape->axes_ci95_mm;
      } else if (const auto se = fitting::TotalStdError(o.fit)) {
        e.axes_ci95_mm.setConstant(1.96 * (*se)[3]);
      }
      const Eigen::Vector3d c = o.shape ? o.shape->center_mm : o.fit.sphere.center_mm;
      e.center_error_mm = (c - t.center_mm).norm();
      e.points = o.indices.size();
    }
    row.topiary.push_back(e);
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
  struct Job {
    std::string sensor, scene;
  };
  std::vector<Job> jobs;
  for (const std::string& name : Split(o.sensors)) jobs.push_back({name, "garden"});
  for (const std::string& name : Split(o.bed_sensors)) jobs.push_back({name, "bed"});
  for (const Job& job : jobs) {
    const std::string& name = job.sensor;
    const sim::Sensor sensor = sim::ParseSensor(name);
    const int count = job.scene == "bed" ? o.beds : o.gardens;
    for (int seed = o.first_seed; seed < o.first_seed + count; ++seed) {
      const sim::ScanScene scene =
          job.scene == "bed" ? sim::RandomTopiaryBed(std::uint64_t(seed)) : sim::RandomScanGarden(std::uint64_t(seed));
      sim::ScanOptions so;
      so.sensor = sensor;
      so.height_mm = o.height_mm;
      so.seed = std::uint64_t(seed);
      so.noise_mm = sensor == sim::Sensor::kTerrestrial ? 3
                    : (sensor == sim::Sensor::kPhotogrammetry || sensor == sim::Sensor::kAerial ? 5 : 10);
      const cloud::PointCloud cloud = sim::ScanGarden(scene, so);
      scene::FindOptions fo;
      if (o.viewpoints) fo.viewpoints_mm = sim::ScanStations(scene, so);
      if (!o.dir.empty()) {
        const std::string stem = o.dir + "/" + name + "_" + job.scene + std::to_string(seed);
        cloud::PointCloud metres = cloud;
        for (auto& p : metres.points_mm) p /= 1000.f;
        cloud::WriteCloud(stem + ".ply", metres);
        sim::WriteScanTruth(stem + ".truth.json", scene);
        if (o.viewpoints) {
          std::string text;
          for (const auto& v : fo.viewpoints_mm) text += pipeline::Format("%.4f %.4f %.4f\n", v.x() / 1000, v.y() / 1000, v.z() / 1000);
          cloud::WriteTextFileAtomic(stem + ".viewpoints.xyz", text);
        }
      }
      const auto t0 = std::chrono::steady_clock::now();
      const scene::FindResult found = scene::FindHedges(cloud, fo);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      FindBenchRow row = Score(scene, found);
      row.sensor = name;
      row.scene = job.scene;
      row.seed = std::uint64_t(seed);
      row.points = cloud.size();
      row.ms = ms;
      result.rows.push_back(std::move(row));
    }
  }
  return result;
}

namespace {

// The beds: topiary found, false, and each axis' error over its true length.
void PrintBeds(const FindBenchResult& result) {
  bool header = false;
  for (const auto& row : result.rows) {
    if (row.scene != "bed") continue;
    if (!header) {
      std::cout << "\nsensor          bed     points    topiary found  false (what)        |da| mean/max %  held  dc max mm  time s\n";
      header = true;
    }
    std::size_t found = 0, axes = 0, held = 0;
    double da_sum = 0, da_max = 0, dc_max = 0;
    for (const auto& t : row.topiary) {
      if (!t.found) continue;
      ++found;
      for (int k = 0; k < 3; ++k) {
        const double da = 100 * std::abs(t.axes_mm[k] - t.true_axes_mm[k]) / t.true_axes_mm[k];
        da_sum += da, da_max = std::max(da_max, da), ++axes;
        held += std::abs(t.axes_mm[k] - t.true_axes_mm[k]) <= t.axes_ci95_mm[k];
      }
      dc_max = std::max(dc_max, t.center_error_mm);
    }
    std::string what;
    for (const auto& f : row.false_balls) what += (what.empty() ? "" : ",") + f;
    Print(std::cout, "%-15s %6llu  %8zu  %zu / %zu          %zu %-14s  %5.2f / %5.2f  %2zu/%-2zu  %7.1f    %6.2f\n",
          row.sensor.c_str(), static_cast<unsigned long long>(row.seed), row.points, found, row.topiary.size(),
          row.false_balls.size(), what.empty() ? "" : ("(" + what + ")").c_str(), axes ? da_sum / double(axes) : 0.0, da_max,
          held, axes, dc_max, row.ms / 1000);
    for (const auto& t : row.topiary) {
      Print(std::cout, "    axes %4.0f x %4.0f x %4.0f: %-10s %6.1f x %6.1f x %6.1f  +- %4.1f %4.1f %4.1f  dc %6.1f  %zu points\n",
            t.true_axes_mm.x(), t.true_axes_mm.y(), t.true_axes_mm.z(), t.found ? t.shape.c_str() : "missed", t.axes_mm.x(),
            t.axes_mm.y(), t.axes_mm.z(), t.axes_ci95_mm.x(), t.axes_ci95_mm.y(), t.axes_ci95_mm.z(), t.center_error_mm,
            t.points);
    }
  }
}

}  // namespace

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
    if (row.scene == "bed") continue;
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
  PrintBeds(result);
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
    r["scene"] = row.scene;
    r["topiary"] = nlohmann::json::array();
    for (const auto& t : row.topiary) {
      r["topiary"].push_back({{"true_axes_mm", {t.true_axes_mm.x(), t.true_axes_mm.y(), t.true_axes_mm.z()}},
                              {"found", t.found}, {"shape", t.shape},
                              {"axes_mm", {t.axes_mm.x(), t.axes_mm.y(), t.axes_mm.z()}},
                              {"axes_ci95_mm", {t.axes_ci95_mm.x(), t.axes_ci95_mm.y(), t.axes_ci95_mm.z()}},
                              {"center_error_mm", t.center_error_mm}, {"points", t.points}});
    }
    j.push_back(r);
  }
  return j.dump(2) + "\n";
}

}  // namespace hedgefit::bench
