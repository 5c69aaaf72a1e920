#include "cloud/truth_file.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

#include "cloud/cloud_io.hpp"
#include "cloud/error.hpp"

namespace hedgefit::cloud {

void WriteSphereTruth(const std::string& path, const SphereTruth& t) {
  nlohmann::json j;
  j["center_mm"] = {t.center_mm.x(), t.center_mm.y(), t.center_mm.z()};
  j["radius_mm"] = t.radius_mm;
  j["frame"] = t.frame;
  WriteTextFileAtomic(path, j.dump() + "\n");
}

SphereTruth ReadSphereTruth(const std::string& path) {
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
  const auto bad = [&] { return Error(path + ": needs \"center_mm\": [x, y, z] and \"radius_mm\": r (numbers, mm)"); };
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
  if (j.contains("frame") && j["frame"].is_string()) t.frame = j["frame"].get<std::string>();
  return t;
}

}  // namespace hedgefit::cloud
