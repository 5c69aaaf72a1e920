#include "scene/find_report.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

#include "cloud/cloud_io.hpp"
#include "cloud/describe.hpp"
#include "fitting/fit_fields.hpp"
#include "fitting/uncertainty.hpp"
#include "pipeline/print.hpp"

namespace hedgefit::scene {

FindReport FindInCloudFile(const std::string& file, double scale, const FindOptions& options, cloud::PointCloud* cloud,
                           const std::vector<Eigen::Vector3d>& viewpoints) {
  FindReport rep;
  cloud::CloudFileHeader header;
  cloud::PointCloud c = cloud::ReadCloud(file, {}, &header);
  if (scale > 0) {
    rep.scale = scale, rep.scale_source = pipeline::Format("scale %g given", scale);
  } else {
    const double extent = cloud::LargestExtent(c), spacing = cloud::MedianSpacing(c);
    rep.scale = cloud::GuessUnits(extent, spacing) == "m" ? 1000.0 : 1.0;
    rep.scale_source = rep.scale == 1000.0
                           ? pipeline::Format("metres, guessed from its span %.3g and spacing %.3g; --scale overrides", extent, spacing)
                           : "mm, guessed; --scale overrides";
  }
  if (rep.scale != 1.0) {
    for (auto& p : c.points_mm) p *= float(rep.scale);
    c.offset *= rep.scale;
  }
  rep.offset_mm = c.offset;
  FindOptions o = options;
  std::vector<Eigen::Vector3d> at = viewpoints;
  if (at.empty() && header.viewpoint) at.push_back(*header.viewpoint);
  rep.viewpoint_source = !viewpoints.empty() ? "given" : (at.empty() ? "" : "the PCD's VIEWPOINT");
  for (const auto& v : at) o.viewpoints_mm.push_back(v * rep.scale - c.offset);
  // A spinning LiDAR's scan in its own frame stood at its origin.
  if (at.empty()) {
    if (const int rings = cloud::ScannerRings(c); rings > 0) {
      o.viewpoints_mm.push_back(-c.offset);
      rep.viewpoint_source = pipeline::Format("the origin: a spinning scanner's %d rings about it", rings);
    }
  }
  rep.result = FindHedges(c, o);
  rep.result.file = file;
  if (cloud) *cloud = std::move(c);
  return rep;
}

namespace {

using json = nlohmann::json;
using pipeline::Print;

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

json FitJson(const fitting::SphereFitResult& f, const Eigen::Vector3d& offset) {
  json j = {{"center_mm", nullptr}, {"radius_mm", nullptr}, {"rms_mm", nullptr}, {"std_error_mm", nullptr}};
  for (const auto& [key, value] : fitting::FitFields(f)) j[key] = std::visit([](const auto& v) { return json(v); }, value);
  if (f.converged) j["center_mm"] = Vec(f.sphere.center_mm + offset);
  return j;
}

// A height in the scene's frame (along up) in the file's frame: the shift's part along up.
double UpShift(const FindResult& r, const Eigen::Vector3d& offset) { return (r.scene_from_cloud * offset).z(); }

// The centroid of an object's points, in the cloud's frame (for an object no sphere fits).
Eigen::Vector3d Centroid(const FindResult& r, const FoundObject& o) {
  // Half-way up from the ground; with no ground under it, half-way up its own points.
  const double z = std::isfinite(o.ground_mm) && std::isfinite(o.height_mm) ? o.ground_mm + o.height_mm / 2 : o.middle_mm;
  const Eigen::Vector3d top(o.top_center_mm.x(), o.top_center_mm.y(), z);
  return r.scene_from_cloud.transpose() * top;
}

json ObjectJson(const FindResult& r, const FoundObject& o, const Eigen::Vector3d& offset) {
  json h;
  h["id"] = o.id;
  h["verdict"] = o.verdict;
  h["ball"] = o.ball;
  const bool sphere = o.fit.converged;
  h["center_mm"] = Vec((sphere ? o.fit.sphere.center_mm : Centroid(r, o)) + offset);
  h["radius_mm"] = sphere ? json(o.fit.sphere.radius_mm) : json(nullptr);
  const auto surface = o.fit.Extra("surface_radius_mm");
  h["surface_radius_mm"] = surface ? json(*surface) : (o.geometric && o.geometric->converged ? json(o.geometric->sphere.radius_mm) : json(nullptr));
  if (const auto depth = o.fit.Extra("leaf_depth_mm")) h["leaf_depth_mm"] = *depth;
  // How the envelope laid the leaves: along the guessed view or radially (a cloud that does not
  // say where it was seen from; the likelier of the two).
  if (const auto radial = o.fit.Extra("leaves_radial")) h["leaves"] = *radial > 0.5 ? "radial" : "along_view";
  const auto total = fitting::TotalStdError(o.fit);
  h["ci95_mm"] = total ? json::array({1.96 * (*total)[0], 1.96 * (*total)[1], 1.96 * (*total)[2], 1.96 * (*total)[3]})
                       : json(nullptr);
  h["points"] = o.indices.size();
  h["seen_share"] = o.seen_share;
  auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  h["ground_mm"] = number(o.ground_mm + UpShift(r, offset));
  h["height_mm"] = number(o.height_mm);
  h["center_height_radii"] = sphere ? number(o.base_height_mm) : json(nullptr);
  h["lumpiness"] = o.lumpiness;
  h["crowding"] = o.crowding;
  if (std::isfinite(o.seen_through)) h["seen_through"] = o.seen_through;
  h["axis_ratio"] = o.axis_ratio;
  h["topiary"] = o.topiary;
  h["undecided"] = o.undecided;
  if (o.shape) {
    const TopiaryShape& s = *o.shape;
    h["shape"] = {{"shape", s.shape},
                  {"form", s.form},
                  {"center_mm", Vec(r.scene_from_cloud.transpose() * s.center_mm + offset)},
                  {"axes_mm", Vec(s.axes_mm)},
                  {"heading_deg", s.heading_deg},
                  {"center_ci95_mm", Vec(s.center_ci95_mm)},
                  {"axes_ci95_mm", Vec(s.axes_ci95_mm)},
                  {"footprint_mm", json::array({s.footprint_mm.x(), s.footprint_mm.y()})},
                  {"top_mm", s.top_mm},
                  {"roughness_mm", s.roughness_mm},
                  {"envelope_offset_mm", s.envelope_offset_mm},
                  {"bic", {{"ball", s.bic_ball}, {"spheroid", s.bic_spheroid}, {"ellipsoid", s.bic_ellipsoid},
                           // a prism is fitted to all points only where it lies clearly closer than the quadric
                           {"cylinder", s.bic_cylinder != 0 ? json(s.bic_cylinder) : json(nullptr)},
                           {"cuboid", s.bic_cuboid != 0 ? json(s.bic_cuboid) : json(nullptr)},
                           {"cone", s.bic_cone != 0 ? json(s.bic_cone) : json(nullptr)}}},
                  {"walls_seen", {{"cylinder", s.bic_cylinder != 0 ? json(s.walls_cylinder) : json(nullptr)},
                                  {"cuboid", s.bic_cuboid != 0 ? json(s.walls_cuboid) : json(nullptr)},
                                  {"cone", s.bic_cone != 0 ? json(s.walls_cone) : json(nullptr)}}},
                  {"covered", o.covered},
                  {"covered_lower", o.covered_lower},
                  {"roughness_noise", o.roughness},
                  {"density", o.density},
                  {"elongation", o.elongation}};
  }
  if (!o.topiary) h["not_a_ball"] = o.reason.empty() ? o.verdict : o.reason;
  if (sphere) h["fit"] = FitJson(o.fit, offset);
  if (o.geometric && o.geometric->converged && o.fit.method != "geometric") h["geometric"] = FitJson(*o.geometric, offset);
  return h;
}

}  // namespace

void WriteFindJson(std::ostream& out, const std::vector<FindReport>& reports) {
  json doc;
  doc["clouds"] = json::array();
  for (const auto& rep : reports) {
    const FindResult& r = rep.result;
    json c;
    c["file"] = r.file;
    c["points"] = r.points;
    c["scale"] = rep.scale;
    c["scale_source"] = rep.scale_source;
    c["offset_mm"] = Vec(rep.offset_mm);  // the global shift the reader applied; positions here include it
    c["up"] = Vec(r.up);
    c["up_source"] = r.up_source;
    c["spacing_mm"] = r.spacing_mm;
    c["viewpoints"] = r.viewpoints;
    c["viewpoint_source"] = rep.viewpoint_source;
    c["ground"] = {{"points", r.ground_points}, {"noise_mm", r.ground.noise_mm}, {"cell_mm", r.ground.cell_mm}};
    c["object_points"] = r.object_points;
    c["balls"] = r.Balls();
    c["topiary"] = r.Topiary();
    c["warnings"] = r.warnings;
    c["hedges"] = json::array();
    for (const auto& o : r.objects) c["hedges"].push_back(ObjectJson(r, o, rep.offset_mm));
    c["timings_ms"] = json::object();
    for (const auto& [step, ms] : r.timings_ms) c["timings_ms"][step] = ms;
    doc["clouds"].push_back(c);
  }
  out << doc.dump(2) << "\n";
}

void WriteFindCsv(std::ostream& out, const std::vector<FindReport>& reports) {
  out << "cloud,id,verdict,ball,cx_mm,cy_mm,cz_mm,r_mm,surface_r_mm,ci95_cx_mm,ci95_cy_mm,ci95_cz_mm,ci95_r_mm,points,"
         "seen_share,ground_mm,height_mm,lumpiness,axis_ratio,method,topiary,axis_a_mm,axis_b_mm,axis_c_mm,heading_deg,reason\n";
  for (const auto& rep : reports) {
    for (const auto& o : rep.result.objects) {
      Print(out, "%s,%d,%s,%d,", rep.result.file.c_str(), o.id, o.verdict.c_str(), o.ball ? 1 : 0);
      const Eigen::Vector3d c = (o.fit.converged ? o.fit.sphere.center_mm : Centroid(rep.result, o)) + rep.offset_mm;
      Print(out, "%.2f,%.2f,%.2f,", c.x(), c.y(), c.z());
      if (o.fit.converged) {
        Print(out, "%.2f,", o.fit.sphere.radius_mm);
      } else {
        out << ",";
      }
      const auto surface = o.fit.Extra("surface_radius_mm");
      if (surface) Print(out, "%.2f,", *surface); else out << ",";
      const auto total = fitting::TotalStdError(o.fit);
      if (total) {
        Print(out, "%.2f,%.2f,%.2f,%.2f,", 1.96 * (*total)[0], 1.96 * (*total)[1], 1.96 * (*total)[2], 1.96 * (*total)[3]);
      } else {
        out << ",,,,";
      }
      std::string reason = o.reason;
      for (char& ch : reason) if (ch == '"') ch = '\'';
      Print(out, "%zu,%.3f,", o.indices.size(), o.seen_share);
      for (double v : {o.ground_mm + UpShift(rep.result, rep.offset_mm), o.height_mm}) {
        if (std::isfinite(v)) Print(out, "%.1f,", v); else out << ",";
      }
      Print(out, "%.4f,%.3f,%s,%d,", o.lumpiness, o.axis_ratio, o.fit.converged ? o.fit.method.c_str() : "", o.topiary ? 1 : 0);
      if (o.shape && o.topiary) {
        Print(out, "%.1f,%.1f,%.1f,%.1f,", o.shape->axes_mm.x(), o.shape->axes_mm.y(), o.shape->axes_mm.z(), o.shape->heading_deg);
      } else {
        out << ",,,,";
      }
      Print(out, "\"%s\"\n", reason.c_str());
    }
  }
}

namespace {
// The ball search's ellipsoids are clipped shapes too; they are not "by height".
std::size_t TopiaryFromBallSearch(const FindResult& r) {
  return std::size_t(std::count_if(r.objects.begin(), r.objects.end(), [](const FoundObject& o) { return o.topiary && !o.ball && !o.shape; }));
}
}  // namespace

void WriteFindTable(std::ostream& out, const std::vector<FindReport>& reports) {
  for (const auto& rep : reports) {
    const FindResult& r = rep.result;
    Print(out, "%s: %zu points (%s), up %s, spacing %.1f mm; ground %zu points (noise %.1f mm); %zu ball%s, %zu "
          "topiary by height, of %zu object%s\n",
          r.file.c_str(), r.points, rep.scale_source.c_str(), r.up_source.c_str(), r.spacing_mm, r.ground_points,
          r.ground.noise_mm, r.Balls(), r.Balls() == 1 ? "" : "s", r.Topiary() - r.Balls() - TopiaryFromBallSearch(r), r.objects.size(), r.objects.size() == 1 ? "" : "s");
    if (r.viewpoints > 0) {
      Print(out, "  topiary judged over the part of each top facing the %zu viewpoint%s (%s)\n", r.viewpoints,
            r.viewpoints == 1 ? "" : "s", rep.viewpoint_source.empty() ? "given" : rep.viewpoint_source.c_str());
    }
    if (!rep.offset_mm.isZero()) {
      Print(out, "  its coordinates were shifted by (%.0f, %.0f, %.0f) mm on reading, for single precision; the "
                 "positions below are in the file's frame\n",
            0.0 - rep.offset_mm.x() + 0.0, 0.0 - rep.offset_mm.y() + 0.0, 0.0 - rep.offset_mm.z() + 0.0);
    }
    for (const auto& w : r.warnings) Print(out, "  warning: %s\n", w.c_str());
    if (r.objects.empty()) continue;
    out << "  id  verdict      centre x, y, z (mm)               radius   95 % (r)  leaf r    points  seen  ground   height  lumpy\n";
    for (const auto& o : r.objects) {
      Print(out, "  %-3d %-11s ", o.id, o.verdict.c_str());
      if (o.fit.converged) {
        const Eigen::Vector3d c = o.fit.sphere.center_mm + rep.offset_mm;
        const auto total = fitting::TotalStdError(o.fit);
        const auto surface = o.fit.Extra("surface_radius_mm");
        Print(out, "%9.1f %9.1f %9.1f  %8.1f  %7s  %7s", c.x(), c.y(), c.z(), o.fit.sphere.radius_mm,
              total ? pipeline::Format("+-%.1f", 1.96 * (*total)[3]).c_str() : "",
              surface ? pipeline::Format("%.1f", *surface).c_str() : "");
      } else {
        const Eigen::Vector3d c = Centroid(r, o) + rep.offset_mm;
        Print(out, "%9.1f %9.1f %9.1f  %8s  %7s  %7s", c.x(), c.y(), c.z(), "-", "", "");
      }
      auto mm = [](double v) { return std::isfinite(v) ? pipeline::Format("%7.0f", v) : std::string("      -"); };
      const double ground = o.ground_mm + UpShift(r, rep.offset_mm);
      if (o.shape && o.topiary) {
        // A shape found by height is judged on its footprint, not on a sphere's patches.
        Print(out, "  %8zu     -  %s  %s      -\n", o.indices.size(), mm(ground).c_str(), mm(o.height_mm).c_str());
      } else {
        Print(out, "  %8zu  %3.0f%%  %s  %s  %5.3f\n", o.indices.size(), 100 * o.seen_share, mm(ground).c_str(),
              mm(o.height_mm).c_str(), o.lumpiness);
      }
      if (o.shape && o.topiary) {
        const TopiaryShape& s = *o.shape;
        Print(out, "      ^ %s%s%s: semi-axes %.0f x %.0f x %.0f mm (+-%.0f, %.0f, %.0f), heading %.0f deg, covered %.0f %%, "
                   "roughness %.1f x noise\n",
              s.form.c_str(), s.form.empty() ? "" : " ", s.shape.c_str(), s.axes_mm.x(), s.axes_mm.y(), s.axes_mm.z(),
              s.axes_ci95_mm.x(), s.axes_ci95_mm.y(), s.axes_ci95_mm.z(), s.heading_deg, 100 * o.covered, o.roughness);
      } else if (!o.reason.empty()) {
        Print(out, "      ^ %s\n", o.reason.c_str());
      }
    }
  }
}

}  // namespace hedgefit::scene
