#pragma once
/// PCL's sample-consensus sphere fit (SACMODEL_SPHERE) made reproducible and precise:
/// a seed option, data centred before PCL sees them (PCL works in float), and radius
/// limits re-checked after PCL's refinement, which does not enforce them.

#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/option_table.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

enum class ConsensusMethod { kRansac, kMsac, kLmeds, kProsac, kMlesac };

struct RansacFitOptions {
  ConsensusMethod method = ConsensusMethod::kRansac;  ///< PCL estimator
  double distance_threshold_mm = 10.0;  ///< inlier band half-width around the sphere, mm
  int max_iterations = 10000;           ///< sample draws at most
  double probability = 0.99;            ///< desired chance of drawing one outlier-free sample
  double min_radius_mm = 50.0;          ///< radius limits for candidate spheres, mm: no hedge is
  double max_radius_mm = 5000.0;        ///< smaller than a fist or larger than a house
  bool optimize = true;                 ///< refine on the inliers (PCL's LM, on centred data)
  /// > 0: draw the 2nd-4th points of each sample within this distance of the first (mm),
  /// so a small sphere in a large scene is found (PCL's setSamplesMaxDist); 0 = anywhere.
  double sample_radius_mm = 0.0;
  std::uint64_t seed = 42;              ///< PCL otherwise always uses 12345 (or the time)
  /// Throws hedgefit::Error naming the bad option.
  void Check() const;
  static const pipeline::OptionTable<RansacFitOptions>& Table();  ///< the options, declared once (not the seed)
};

/// "ransac", "msac", "lmeds", "prosac", "mlesac"; parses the same names (Error if unknown).
/// The estimators by name, the one list the option table and ConsensusName() read.
const std::vector<std::pair<std::string, ConsensusMethod>>& ConsensusNames();
const char* ConsensusName(ConsensusMethod method);

/// Fits by sample consensus; `inlier_indices`, if given, receives the final inliers.
SphereFitResult FitSphereRansac(const std::vector<Eigen::Vector3d>& points_mm, const RansacFitOptions& options,
                                std::vector<std::size_t>* inlier_indices = nullptr);

}  // namespace hedgefit::fitting
