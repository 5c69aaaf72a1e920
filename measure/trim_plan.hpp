#pragma once
/// The trim plan of a cloud, as a typed call (`hedgefit trim`): read, cleaned, each hedge's centre
/// fitted (or the given one), and each point's cut depth past the target (a sphere, or a clipped
/// shape with a vertical axis) with the share and the volume to cut (fitting/trim.hpp). The
/// pipeline underneath is TrimRecipe's (`trim --print-pipeline` prints it).

#include <string>
#include <vector>

#include "cloud/point_cloud.hpp"
#include "fitting/trim.hpp"
#include "pipeline/registry.hpp"

namespace hedgefit::measure {

struct TrimRequest {
  std::string cloud;            ///< cloud file; a hedge_id field gives one plan per hedge
  double scale = 1;             ///< multiply coordinates on read
  bool clean = true;            ///< the default cleaning before the fit
  std::string method = "ransac_geometric";  ///< the fit that centres the target (without `center`)
  std::vector<double> center;   ///< the target's centre, mm (empty: each hedge's fitted centre)
  double radius = 0;            ///< the target sphere's radius, mm; or `axes`
  std::vector<double> axes;     ///< a clipped shape's semi-axes A, B, C, mm (empty: a sphere)
  double heading = 0;           ///< its first semi-axis, degrees about `up` from x
  std::string shape = "ellipsoid";  ///< what `axes` are of: ellipsoid, cylinder, cuboid or cone
  double tolerance = 5;         ///< cut depths up to this count as on target, mm
  double bin_deg = 0;           ///< the volume bins' size, degrees (0: automatic)
  std::string up = "-y";        ///< the vertical
  std::string output;           ///< also write the cloud with its cut_depth field (PCD), "" none
};

struct TrimResult {
  std::vector<fitting::TrimPlan> plans;  ///< one per hedge
  cloud::PointCloud cloud;               ///< the cloud planned, with its cut_depth field
};

/// The pipeline `request` runs (JSON stages).
std::string TrimRecipe(const TrimRequest& request);

/// Runs it. A missing target (no radius, no axes) is an InputError.
TrimResult PlanTrim(const TrimRequest& request, const pipeline::Registry& registry);

}  // namespace hedgefit::measure
