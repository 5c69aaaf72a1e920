#include "cloud/outline_io.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::cloud {

namespace {

using json = nlohmann::json;
constexpr const char* kFormat = "hedgefit-outline";
constexpr int kVersion = 1;

}  // namespace

std::string OutlineSidecarPath(const std::string& cloud_path) { return cloud_path + ".outline.json"; }

void WriteOutlines(const std::string& path, const HedgeOutlines& outlines, std::size_t cloud_points) {
  json hedges = json::array();
  for (const auto& [id, rays] : outlines) {
    json r = json::array();
    for (const TangentRay& t : rays) {
      r.push_back({t.origin_mm.x(), t.origin_mm.y(), t.origin_mm.z(), t.direction.x(), t.direction.y(),
                   t.direction.z(), t.focal_px, t.view});
    }
    hedges.push_back({{"hedge_id", id}, {"rays", r}});
  }
  const json j = {{"format", kFormat},
                  {"version", kVersion},
                  {"frame", "the cloud's (the unrectified left camera), mm"},
                  {"cloud_points", cloud_points},
                  {"ray", {"origin x", "origin y", "origin z", "direction x", "direction y", "direction z", "focal px",
                           "view (0 left, 1 right)"}},
                  {"hedges", hedges}};
  WriteTextFileAtomic(path, j.dump() + "\n");
}

OutlineFile ReadOutlines(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the outline file; check the path");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(path + ": not an outline file (" + std::string(e.what()) + "); remove it or write it again with hedgefit convert");
  }
  auto bad = [&](const std::string& why) {
    return InputError(path + ": " + why + "; remove it or write it again with hedgefit convert");
  };
  if (!j.is_object() || j.value("format", "") != kFormat) throw bad("not a hedgefit outline file");
  if (j.value("version", 0) != kVersion) throw bad("an outline file of another version");
  if (!j.contains("hedges") || !j["hedges"].is_array()) throw bad("no \"hedges\" array");
  if (!j.contains("cloud_points") || !j["cloud_points"].is_number_unsigned()) throw bad("no \"cloud_points\" count");
  OutlineFile file;
  file.cloud_points = j["cloud_points"].get<std::size_t>();
  HedgeOutlines& out = file.outlines;
  for (const auto& h : j["hedges"]) {
    if (!h.is_object() || !h.contains("hedge_id") || !h["hedge_id"].is_number_integer() || !h.contains("rays") ||
        !h["rays"].is_array()) {
      throw bad("a hedge without an integer \"hedge_id\" and a \"rays\" array");
    }
    std::vector<TangentRay>& rays = out[h["hedge_id"].get<int>()];
    for (const auto& r : h["rays"]) {
      if (!r.is_array() || r.size() != 8) throw bad("a ray that is not 8 numbers");
      for (const auto& v : r) {
        if (!v.is_number()) throw bad("a ray that is not 8 numbers");
      }
      TangentRay t;
      t.origin_mm = Eigen::Vector3d(r[0].get<double>(), r[1].get<double>(), r[2].get<double>());
      t.direction = Eigen::Vector3d(r[3].get<double>(), r[4].get<double>(), r[5].get<double>());
      t.focal_px = r[6].get<double>();
      t.view = r[7].get<int>();
      if (!t.origin_mm.allFinite() || !t.direction.allFinite() || !(std::abs(t.direction.norm() - 1) < 1e-6) ||
          !(t.focal_px > 0) || (t.view != 0 && t.view != 1)) {
        throw bad("a ray with a non-unit direction, a focal length not above 0 or a view other than 0 or 1");
      }
      rays.push_back(t);
    }
  }
  return file;
}

std::optional<HedgeOutlines> ReadOutlineSidecar(const std::string& cloud_path, std::size_t cloud_points) {
  const std::string path = OutlineSidecarPath(cloud_path);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;
  OutlineFile file = ReadOutlines(path);
  if (file.cloud_points != cloud_points) {
    throw InputError(path + ": written for a cloud of " + std::to_string(file.cloud_points) + " points, but " +
                     cloud_path + " has " + std::to_string(cloud_points) +
                     "; write both again with hedgefit convert, or remove the outline file");
  }
  return std::move(file.outlines);
}

}  // namespace hedgefit::cloud
