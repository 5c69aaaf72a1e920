#include "eval/truth_file.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::eval {

namespace {

nlohmann::json TruthJson(const SphereTruth& t) {
  nlohmann::json j;
  j["center_mm"] = {t.center_mm.x(), t.center_mm.y(), t.center_mm.z()};
  j["radius_mm"] = t.radius_mm;
  if (t.surface_radius_mm) j["surface_radius_mm"] = *t.surface_radius_mm;
  if (t.shell_mm) j["shell_mm"] = *t.shell_mm;
  return j;
}

SphereTruth ParseTruth(const nlohmann::json& j, const std::string& where) {
  const auto bad = [&] { return Error(where + ": needs \"center_mm\": [x, y, z] and \"radius_mm\": r (numbers, mm)"); };
  if (!j.is_object() || !j.contains("center_mm") || !j.contains("radius_mm")) throw bad();
  const auto& c = j["center_mm"];
  if (!c.is_array() || c.size() != 3 || !j["radius_mm"].is_number()) throw bad();
  SphereTruth t;
  for (std::size_t k = 0; k < 3; ++k) {
    if (!c[k].is_number()) throw bad();
    t.center_mm[static_cast<Eigen::Index>(k)] = c[k].get<double>();
  }
  t.radius_mm = j["radius_mm"].get<double>();
  if (!(t.radius_mm > 0) || !std::isfinite(t.radius_mm) || !t.center_mm.allFinite()) throw bad();
  if (j.contains("surface_radius_mm")) {
    if (!j["surface_radius_mm"].is_number() || !(j["surface_radius_mm"].get<double>() > 0)) {
      throw Error(where + ": \"surface_radius_mm\" must be a positive number (mm)");
    }
    t.surface_radius_mm = j["surface_radius_mm"].get<double>();
  }
  if (j.contains("shell_mm")) {
    if (!j["shell_mm"].is_number() || !(j["shell_mm"].get<double>() >= 0)) {
      throw Error(where + ": \"shell_mm\" must be a number >= 0 (mm)");
    }
    t.shell_mm = j["shell_mm"].get<double>();
  }
  return t;
}

}  // namespace

void WriteSphereTruth(const std::string& path, const SphereTruth& t) {
  nlohmann::json j = TruthJson(t);
  j["frame"] = t.frame;
  cloud::WriteTextFileAtomic(path, j.dump() + "\n");
}

void WriteSphereTruths(const std::string& path, const std::vector<SphereTruth>& truths) {
  nlohmann::json j;
  j["hedges"] = nlohmann::json::array();
  for (const auto& t : truths) j["hedges"].push_back(TruthJson(t));
  j["frame"] = truths.empty() ? SphereTruth().frame : truths.front().frame;
  j["order"] = "left to right in the image, as hedgefit numbers hedges";
  cloud::WriteTextFileAtomic(path, j.dump() + "\n");
}

std::vector<SphereTruth> ReadSphereTruths(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw Error(path + ": is a directory; give a truth .json file");
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open the truth file; check the path");
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception&) {
    throw Error(path + ": invalid JSON; a truth file is {\"center_mm\": [x, y, z], \"radius_mm\": r}");
  }
  std::vector<SphereTruth> out;
  const std::string frame = j.is_object() && j.contains("frame") && j["frame"].is_string() ? j["frame"].get<std::string>() : "";
  if (j.is_object() && j.contains("hedges")) {
    if (!j["hedges"].is_array() || j["hedges"].empty()) {
      throw Error(path + ": \"hedges\" must be a non-empty array of {\"center_mm\", \"radius_mm\"}");
    }
    for (std::size_t i = 0; i < j["hedges"].size(); ++i) {
      out.push_back(ParseTruth(j["hedges"][i], path + ": hedge " + std::to_string(i + 1)));
    }
  } else {
    out.push_back(ParseTruth(j, path));
  }
  if (!frame.empty()) {
    for (auto& t : out) t.frame = frame;
  }
  return out;
}

SphereTruth ReadSphereTruth(const std::string& path) {
  std::vector<SphereTruth> all = ReadSphereTruths(path);
  if (all.size() != 1) {
    throw Error(path + ": lists " + std::to_string(all.size()) + " hedges; this needs the truth of one sphere");
  }
  return all.front();
}

}  // namespace hedgefit::eval
