#include "around/poses.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::around {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

std::string Relative(const fs::path& base, const std::string& p) {
  if (p.empty() || fs::path(p).is_absolute()) return p;
  return (base / p).lexically_normal().string();
}

// A rigid transform from 16 row-major numbers, or an error naming where.
Eigen::Isometry3d RigidFrom(const json& m, const std::string& where) {
  if (!m.is_array() || m.size() != 16) throw InputError(where + ": world_from_camera must be 16 numbers (4 x 4, row-major, mm)");
  Eigen::Matrix4d M;
  for (int k = 0; k < 16; ++k) {
    if (!m[std::size_t(k)].is_number()) throw InputError(where + ": world_from_camera holds a value that is not a number");
    M(k / 4, k % 4) = m[std::size_t(k)].get<double>();
  }
  if (!M.allFinite()) throw InputError(where + ": world_from_camera holds a non-finite number");
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0 ||
      (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
    throw InputError(where + ": world_from_camera is not a rigid motion (its 3 x 3 part must be a rotation, its last row 0 0 0 1)");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Re-orthonormalise (a matrix written to a few decimals is a rotation only to them).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot read it (check the path)");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

double RotationDeg(const Eigen::Isometry3d& delta) {
  return Eigen::AngleAxisd(delta.linear()).angle() * 180 / M_PI;
}

std::vector<PosedCapture> ReadManifest(const std::string& path) {
  json j;
  try {
    j = json::parse(ReadAll(path));
  } catch (const json::exception& e) {
    throw InputError(path + ": not a manifest (JSON): " + e.what());
  }
  if (!j.is_object() || !j.contains("captures") || !j["captures"].is_array() || j["captures"].empty()) {
    throw InputError(path + ": a manifest is {\"captures\": [{\"left\", \"right\", \"world_from_camera\"}, ...]}");
  }
  const fs::path base = fs::path(path).parent_path();
  const std::string rig = j.contains("rig") && j["rig"].is_string() ? Relative(base, j["rig"].get<std::string>()) : "";
  std::vector<PosedCapture> out;
  for (std::size_t k = 0; k < j["captures"].size(); ++k) {
    const json& c = j["captures"][k];
    const std::string where = path + ": capture " + std::to_string(k + 1);
    if (!c.is_object() || !c.contains("left") || !c.contains("right") || !c["left"].is_string() || !c["right"].is_string()) {
      throw InputError(where + ": needs \"left\" and \"right\" images");
    }
    if (!c.contains("world_from_camera")) throw InputError(where + ": needs \"world_from_camera\" (4 x 4, row-major, mm)");
    PosedCapture p;
    p.left = Relative(base, c["left"].get<std::string>());
    p.right = Relative(base, c["right"].get<std::string>());
    p.name = c.contains("name") && c["name"].is_string() ? c["name"].get<std::string>() : fs::path(p.left).stem().string();
    p.rig = c.contains("rig") && c["rig"].is_string() ? Relative(base, c["rig"].get<std::string>()) : rig;
    p.world_from_camera = RigidFrom(c["world_from_camera"], where);
    if (c.contains("time") && c["time"].is_number()) p.time_s = c["time"].get<double>();
    out.push_back(p);
  }
  return out;
}

std::vector<PosedCapture> ReadTumCaptures(const std::string& trajectory, const std::string& captures_dir) {
  std::ifstream in(trajectory);
  if (!in) throw InputError(trajectory + ": cannot read it (check the path)");
  // The captures in the folder, by the time their names hold.
  std::vector<std::pair<double, std::string>> stems;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(captures_dir, ec)) {
    const std::string f = e.path().filename().string();
    const std::size_t at = f.rfind("_left.");
    if (at == std::string::npos) continue;
    char* end = nullptr;
    const std::string stem = f.substr(0, at);
    const double t = std::strtod(stem.c_str(), &end);
    if (end && *end == '\0' && std::isfinite(t)) stems.emplace_back(t, (e.path().parent_path() / f).string());
  }
  if (ec) throw InputError(captures_dir + ": cannot list the captures' folder");
  std::vector<PosedCapture> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ss(line);
    double v[8];
    for (double& x : v) {
      if (!(ss >> x) || !std::isfinite(x)) {
        throw InputError(trajectory + ":" + std::to_string(number) + ": a TUM line is 'time tx ty tz qx qy qz qw' (metres)");
      }
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1) > 1e-2) {
      throw InputError(trajectory + ":" + std::to_string(number) + ": the quaternion is not of unit length (" +
                       std::to_string(q.norm()) + ")");
    }
    PosedCapture p;
    p.time_s = v[0];
    p.world_from_camera.linear() = q.normalized().toRotationMatrix();
    p.world_from_camera.translation() = 1000.0 * Eigen::Vector3d(v[1], v[2], v[3]);
    const std::string* left = nullptr;
    for (const auto& s : stems) {
      if (std::abs(s.first - v[0]) <= 1e-3) left = &s.second;
    }
    if (left == nullptr) {
      throw InputError(trajectory + ":" + std::to_string(number) + ": no capture in " + captures_dir +
                       " is named by time " + std::to_string(v[0]) + " (TIME_left.png and TIME_right.png)");
    }
    p.left = *left;
    const std::size_t at = left->rfind("_left.");
    p.right = left->substr(0, at) + "_right." + left->substr(at + 6);
    p.name = fs::path(*left).filename().string().substr(0, fs::path(*left).filename().string().rfind("_left."));
    out.push_back(p);
  }
  if (out.empty()) throw InputError(trajectory + ": no pose in it (TUM: 'time tx ty tz qx qy qz qw' per line)");
  return out;
}

void WriteManifest(const std::string& path, const std::vector<PosedCapture>& captures, const std::string& rig) {
  json j;
  if (!rig.empty()) j["rig"] = rig;
  j["captures"] = json::array();
  for (const PosedCapture& c : captures) {
    json e;
    e["name"] = c.name;
    e["left"] = c.left;
    e["right"] = c.right;
    if (!c.rig.empty()) e["rig"] = c.rig;
    if (c.time_s) e["time"] = *c.time_s;
    json m = json::array();
    const Eigen::Matrix4d M = c.world_from_camera.matrix();
    for (int k = 0; k < 16; ++k) m.push_back(std::round(M(k / 4, k % 4) * 1e9) / 1e9);
    e["world_from_camera"] = m;
    j["captures"].push_back(e);
  }
  cloud::WriteTextFileAtomic(path, j.dump(2) + "\n");
}

void WriteTum(const std::string& path, const std::vector<PosedCapture>& captures) {
  std::ostringstream o;
  o << "# time tx ty tz qx qy qz qw: the left camera's optical frame in the world, metres\n";
  for (const PosedCapture& c : captures) {
    const Eigen::Quaterniond q(c.world_from_camera.linear());
    const Eigen::Vector3d t = c.world_from_camera.translation() / 1000.0;
    char buf[256];
    std::snprintf(buf, sizeof(buf), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", c.time_s.value_or(0.0), t.x(), t.y(),
                  t.z(), q.x(), q.y(), q.z(), q.w());
    o << buf;
  }
  cloud::WriteTextFileAtomic(path, o.str());
}

}  // namespace hedgefit::around
