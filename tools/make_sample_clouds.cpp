// Generates sample_clouds/: spherical caps with known truth, as a stereo rig sees them.
// Usage: make_sample_clouds OUT_DIR [--seed N]
//
// Each cloud is what a camera at the origin (x right, y down, z forward, mm) sees of
// a sphere: the cap facing it, sampled uniformly by area, with depth noise along the
// viewing ray that grows as Z^2 (sigma_Z = Z^2 sigma_d / (f b), the paper's rig:
// f = 933.3 px, b = 140 mm, sigma_d = 0.1 px), plus a fraction of outliers spread
// through the cap's bounding box grown by 150 mm (stereo's flying pixels).
// Beside each CLOUD.pcd, CLOUD.truth.json gives centre and radius in mm.

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include "cloud/cloud_io.hpp"

namespace {

using hedgefit::cloud::PointCloud;

constexpr double kFocalPx = 933.3;
constexpr double kBaselineMm = 140.0;
constexpr double kSigmaDisparityPx = 0.1;
constexpr double kPi = 3.14159265358979323846;

struct CapSpec {
  std::string name;
  Eigen::Vector3d center_mm;
  double radius_mm = 300;
  double half_angle_deg = 60;   ///< cap half-angle around the direction to the camera
  double outlier_fraction = 0;  ///< of the final point count
  int points = 4000;            ///< inliers on the cap
  bool ground_plane = false;    ///< add a textured ground plane under the sphere
};

double SigmaZ(double z_mm) { return z_mm * z_mm * kSigmaDisparityPx / (kFocalPx * kBaselineMm); }

// Moves p along its viewing ray by N(0, sigma_Z(p.z)).
Eigen::Vector3d AddDepthNoise(const Eigen::Vector3d& p, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, SigmaZ(p.z()));
  return p * ((p.z() + n(rng)) / p.z());
}

PointCloud MakeCap(const CapSpec& s, std::mt19937_64& rng) {
  PointCloud cloud;
  // Cap axis points from the centre towards the camera.
  const Eigen::Vector3d axis = (-s.center_mm).normalized();
  const Eigen::Quaterniond to_axis = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const double cos_max = std::cos(s.half_angle_deg * kPi / 180.0);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e18), hi = -lo;
  for (int i = 0; i < s.points; ++i) {
    const double cos_t = cos_max + (1.0 - cos_max) * u01(rng);  // uniform by area
    const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
    const double phi = 2 * kPi * u01(rng);
    const Eigen::Vector3d n = to_axis * Eigen::Vector3d(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t);
    const Eigen::Vector3d p = s.center_mm + s.radius_mm * n;
    if (p.normalized().dot(n) >= 0) continue;  // faces away from the camera: hidden
    const Eigen::Vector3d q = AddDepthNoise(p, rng);
    cloud.points_mm.push_back(q.cast<float>());
    // Foliage-like greens, brighter towards the camera.
    const double shade = 0.55 + 0.45 * (-p.normalized().dot(n));
    cloud.colors.push_back({static_cast<std::uint8_t>(40 * shade), static_cast<std::uint8_t>(150 * shade + 40 * u01(rng)),
                            static_cast<std::uint8_t>(35 * shade)});
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  if (s.ground_plane) {
    // A ground plane under the sphere (y down: the plane is at y = cy + r), 1.6 m x 1.2 m.
    const double y = s.center_mm.y() + s.radius_mm;
    std::uniform_real_distribution<double> ux(s.center_mm.x() - 800, s.center_mm.x() + 800);
    std::uniform_real_distribution<double> uz(s.center_mm.z() - 600, s.center_mm.z() + 600);
    const int n = s.points;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p(ux(rng), y, uz(rng));
      if ((p - s.center_mm).norm() < s.radius_mm) continue;  // under the sphere
      cloud.points_mm.push_back(AddDepthNoise(p, rng).cast<float>());
      const auto g = static_cast<std::uint8_t>(90 + 40 * u01(rng));
      cloud.colors.push_back({g, static_cast<std::uint8_t>(g - 10), static_cast<std::uint8_t>(g - 30)});
    }
  }
  const int outliers = static_cast<int>(std::lround(s.outlier_fraction / (1 - s.outlier_fraction) * cloud.size()));
  std::uniform_real_distribution<double> ox(lo.x() - 150, hi.x() + 150), oy(lo.y() - 150, hi.y() + 150),
      oz(lo.z() - 150, hi.z() + 150);
  for (int i = 0; i < outliers; ++i) {
    cloud.points_mm.emplace_back(static_cast<float>(ox(rng)), static_cast<float>(oy(rng)), static_cast<float>(oz(rng)));
    cloud.colors.push_back({120, 120, 120});
  }
  cloud.Flatten();
  return cloud;
}

std::string TruthJson(const CapSpec& s, std::uint64_t seed, std::size_t points) {
  char buf[1024];
  std::snprintf(buf, sizeof(buf),
                "{\n  \"center_mm\": [%.3f, %.3f, %.3f],\n  \"radius_mm\": %.3f,\n  \"frame\": \"left camera, x right, y down, "
                "z forward\",\n  \"generator\": {\"tool\": \"make_sample_clouds\", \"seed\": %llu, \"half_angle_deg\": %.1f, "
                "\"outlier_fraction\": %.2f, \"sigma_disparity_px\": %.2f, \"focal_px\": %.1f, \"baseline_mm\": %.1f, "
                "\"ground_plane\": %s, \"points\": %zu}\n}\n",
                s.center_mm.x(), s.center_mm.y(), s.center_mm.z(), s.radius_mm, static_cast<unsigned long long>(seed),
                s.half_angle_deg, s.outlier_fraction, kSigmaDisparityPx, kFocalPx, kBaselineMm,
                s.ground_plane ? "true" : "false", points);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: make_sample_clouds OUT_DIR [--seed N]\n");
    return 1;
  }
  const std::filesystem::path out = argv[1];
  std::uint64_t seed = 20221;
  for (int i = 2; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--seed") seed = std::stoull(argv[i + 1]);
  }
  std::filesystem::create_directories(out);
  std::vector<CapSpec> specs;
  // The paper's lab distances, a 60-degree cap, 10 % outliers.
  for (int z = 2000; z <= 2600; z += 300) {
    specs.push_back({"cap_z" + std::to_string(z) + "_a60_o10", {80, -40, double(z)}, 300, 60, 0.10, 4000, false});
  }
  // At 2300 mm: the cap half-angle from 30 to 90 degrees, and outliers from 0 to 30 %.
  for (int a : {30, 45, 90}) {
    specs.push_back({"cap_z2300_a" + std::to_string(a) + "_o10", {80, -40, 2300}, 300, double(a), 0.10, 4000, false});
  }
  specs.push_back({"cap_z2300_a60_o0", {80, -40, 2300}, 300, 60, 0.0, 4000, false});
  specs.push_back({"cap_z2300_a60_o30", {80, -40, 2300}, 300, 60, 0.30, 4000, false});
  specs.push_back({"scene_ground_z2300", {-150, 100, 2300}, 300, 70, 0.05, 4000, true});
  for (std::size_t i = 0; i < specs.size(); ++i) {
    std::mt19937_64 rng(seed + i);  // each cloud reproducible on its own
    const PointCloud cloud = MakeCap(specs[i], rng);
    const std::string base = (out / specs[i].name).string();
    hedgefit::cloud::WriteOptions w;
    w.pcd_encoding = hedgefit::cloud::PcdEncoding::kBinaryCompressed;
    hedgefit::cloud::WriteCloud(base + ".pcd", cloud, w);
    hedgefit::cloud::WriteTextFileAtomic(base + ".truth.json", TruthJson(specs[i], seed + i, cloud.size()));
    std::printf("%s.pcd  %zu points\n", base.c_str(), cloud.size());
  }
  return 0;
}
