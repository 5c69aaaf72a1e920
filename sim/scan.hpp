#pragma once
/// Simulated scans of gardens with known answers, for `find`: the scene is analytic (a sloped,
/// bumpy lawn; leafy hedge balls and domes; hedge rows; rose bushes and trees made of leafy
/// blobs that let some beams through; benches and a fence), and each sensor casts its own rays:
///  - a spinning 16- or 32-beam LiDAR (VLP-16 / HDL-32E elevations, 0.2 deg azimuth steps) at
///    0.5-2 m above the lawn, driving past the garden and scanning every metre;
///  - a terrestrial scanner on a tripod, 0.15 deg steps, from two stations (about a million
///    points);
///  - a photogrammetry-like model: per-pixel depth from a ring of cameras looking in, fused, with
///    depth noise growing with range (in proportion) and a thin fuzz of outliers along the rays.
/// A beam entering a leafy shell stops on a leaf: on the envelope itself for the clipped share of
/// beams, else an exponential depth in (mean a third of the shell), as the envelope fit models.
/// Ranges get Gaussian noise; some beams drop out. Coordinates are mm, z up.

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

#include "cloud/point_cloud.hpp"

namespace hedgefit::sim {

struct ScanGround {
  double slope_x = 0, slope_y = 0;   ///< rise over run
  double bump_mm = 40;               ///< amplitude of the lawn's bumps
  double wavelength_mm = 5000;       ///< their wavelength
  double phase_x = 0, phase_y = 0;
  double Height(double x, double y) const;
};

/// A leafy sphere: a hedge ball (opaque, gaps 0) or a blob of a shrub or a crown (gappy).
struct ScanSphere {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  double radius_mm = 500;
  double shell_mm = 40;        ///< the leaf layer's depth
  double clipped_share = 0.5;  ///< beams that stop on the envelope itself
  double gap_share = 0;        ///< beams that pass through
};

/// A clipped topiary with a vertical axis: semi-axes a (along the heading), b (across) and c
/// (vertical), leafy like a ball. A dome is one whose centre is below 0.8 c above the lawn.
struct ScanSpheroid {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axes_mm = Eigen::Vector3d(400, 400, 250);
  double heading_rad = 0;
  double shell_mm = 30;
  double clipped_share = 0.5;
};

/// An axis-aligned leafy or solid box: a hedge row, a bench, a fence.
struct ScanBox {
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero(), max_mm = Eigen::Vector3d::Zero();
  double shell_mm = 0;
  double gap_share = 0;
};

/// A vertical cylinder: a trunk, a post.
struct ScanCylinder {
  Eigen::Vector2d xy_mm = Eigen::Vector2d::Zero();
  double radius_mm = 100, z0_mm = 0, z1_mm = 2000;
};

/// What the finder must not call a ball: its kind and where it stands.
struct ScanObject {
  std::string kind;  ///< "rose", "tree", "hedge row", "bench", "fence"
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
};

struct ScanScene {
  ScanGround ground;
  std::vector<ScanSphere> balls;   ///< the hedge balls (truth)
  std::vector<ScanSpheroid> topiary;  ///< squat, oblate and elliptic topiary (truth)
  std::vector<ScanSphere> blobs;   ///< shrubs' and crowns' blobs
  std::vector<ScanBox> boxes;
  std::vector<ScanCylinder> cylinders;
  std::vector<ScanObject> others;
  Eigen::Vector2d extent_mm = Eigen::Vector2d(24000, 10000);  ///< the garden: x in [0, ex], y in [0, ey]
};

/// A garden of 5-7 balls of 300-900 mm radius (some domes sunk into the lawn, two touching, one
/// pressed against a hedge row), rose bushes of a ball's size, trees, a bench and a fence, on a
/// sloped, bumpy lawn; the same for the same seed.
ScanScene RandomScanGarden(std::uint64_t seed);

/// A bed of topiary as real gardens hold them (the TrimBot2020 garden at Wageningen): 4-6 squat
/// shapes 0.5-0.9 m across and 0.35-0.6 m tall (domes, oblate spheroids, ellipsoids turned by a
/// heading), some touching and the rest 0.1-0.6 m apart, with rose bushes between them, a low
/// box hedge row, a post and a small ball; the same for the same seed.
ScanScene RandomTopiaryBed(std::uint64_t seed);

/// The sensors. kAerial: a drone's photogrammetry, 3 x 3 cameras 6 m above the lawn looking
/// down (25 degrees off nadir, inwards): the model sees tops and upper sides only.
enum class Sensor { kLidar16, kLidar32, kTerrestrial, kPhotogrammetry, kAerial };
/// "lidar16", "lidar32", "terrestrial", "photogrammetry", "aerial"; the parser throws hedgefit::Error.
const char* SensorName(Sensor s);
Sensor ParseSensor(const std::string& name);

struct ScanOptions {
  Sensor sensor = Sensor::kLidar16;
  double height_mm = 1500;     ///< the sensor above the lawn (LiDAR, terrestrial)
  double noise_mm = 10;        ///< range noise (1 sigma); photogrammetry: at 5 m
  double dropout = 0.05;       ///< share of beams that return nothing
  double outlier_share = 0.01; ///< photogrammetry: share of points flung along their ray
  double step_deg = 0;         ///< angular step; 0 = the sensor's own
  int station = -1;            ///< scan from this one of ScanStations only (a LiDAR parked); -1: all
  std::uint64_t seed = 1;
};

/// Scans `scene`; the cloud is unorganised, mm, z up.
cloud::PointCloud ScanGarden(const ScanScene& scene, const ScanOptions& options);

/// Where ScanGarden's sensor stands (mm, the scene's frame): the LiDAR's sweeps along its drive,
/// the tripod's stations, the cameras' centres.
std::vector<Eigen::Vector3d> ScanStations(const ScanScene& scene, const ScanOptions& options);

/// The scene's truth: {"hedges": [{"center_mm", "radius_mm", "shell_mm", "ground_mm"}, ...],
/// "topiary": [{"center_mm", "axes_mm", "heading_deg", "shell_mm", "ground_mm"}, ...],
/// "others": [{"kind", "center_mm"}], "frame": "world, z up, mm"}; written atomically.
void WriteScanTruth(const std::string& path, const ScanScene& scene);

}  // namespace hedgefit::sim
