#pragma once
/// The table of sphere-fitting methods, COLMAP-style: one row per method with its name, its
/// stage, a description and its options (declared once, in the method's OptionTable). The
/// fitters.* stages, `compare`, `render` and the benches all read this table, so a new
/// fitter is its own files plus one row here.

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "cloud/outline_rays.hpp"
#include "pipeline/stage.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

/// What a fit sees besides its own options.
struct FitInputs {
  const std::vector<Eigen::Vector3d>* points_mm = nullptr;  ///< the points, mm
  /// Optional, one per point: the lateral size of one pixel there (Z / f, mm), a capture cloud's
  /// "pixel_mm" field (null or empty: none); the envelope fit uses it for the matcher's reading of
  /// the outermost leaves.
  const std::vector<double>* pixel_mm = nullptr;
  /// Optional: the hedge's outline as tangent rays (stereo::MeasureOutlines); the envelope fit
  /// fits to it too.
  const std::vector<cloud::TangentRay>* outline = nullptr;
  /// Optional, one per point: where each point was seen from (a fused cloud of several captures,
  /// its view_x/y/z_mm fields; null or empty: the cloud's origin); the envelope fit uses it.
  const std::vector<Eigen::Vector3d>* viewpoints = nullptr;
  std::uint64_t seed = 42;                                  ///< for methods that sample
  const Sphere* previous = nullptr;  ///< an earlier fit, for options such as initial = previous
  std::vector<std::size_t>* inliers = nullptr;  ///< out: inlier indices, for methods that have them
  /// The points are one hedge's (a capture's segmented hedge, hedge_id >= 1), not a scene to pick a
  /// ball out of: a consensus fit is then judged against all of them (NotABallReason).
  bool one_hedge = false;
};

/// A method with its options bound and checked: call it on any number of inputs.
using BoundFit = std::function<SphereFitResult(const FitInputs&)>;

struct FitMethod {
  std::string name;         ///< "kasa": what --methods takes
  std::string stage;        ///< "fitters.algebraic": the pipeline stage that runs it
  std::string description;  ///< one line
  std::vector<pipeline::OptionSpec> options;  ///< its options (types, defaults, units, ranges)
  bool has_inliers = false;  ///< robust: reports which points it kept
  /// Builds the fit from resolved options; throws hedgefit::Error naming a bad option.
  std::function<BoundFit(const pipeline::Options&)> bind;
  int trust = 0;  ///< higher = preferred when one fit must stand for the cloud
  /// A sphere fit. false for shape diagnostics (the ellipsoid), whose "radius" is a summary:
  /// they run when named, not in "all" or the Table 2 benches.
  bool sphere = true;
};

/// Every method, in the order tables and plots list them.
const std::vector<FitMethod>& FitMethods();

/// Their names, in the same order.
std::vector<std::string> FitMethodNames();

/// The names of the sphere fits (what "all" means), in the same order.
std::vector<std::string> SphereMethodNames();

/// The method called `name`; throws hedgefit::Error "`where`: unknown method 'x' (did you mean
/// 'y'?); choose from ..." otherwise.
const FitMethod& FindFitMethod(const std::string& name, const std::string& where);

/// Of the methods named in `names`, the one with the highest trust; nullptr if none is a method.
const FitMethod* MostTrusted(const std::vector<std::string>& names);

/// A comma-separated list of names, each checked by FindFitMethod; "all" stands for
/// SphereMethodNames() ("all,ellipsoid" adds the ellipsoid).
std::vector<std::string> ParseMethodList(const std::string& text, const std::string& where);

/// Runs one method with `given` options (the rest at their defaults; options the method does
/// not declare are ignored, so one map can serve several methods). `one_hedge` and `pixel_mm`:
/// see FitInputs.
SphereFitResult RunFitMethod(const std::string& name, const std::vector<Eigen::Vector3d>& points_mm,
                             const std::map<std::string, pipeline::OptionValue>& given = {}, std::uint64_t seed = 42,
                             bool one_hedge = false, const std::vector<double>* pixel_mm = nullptr,
                             const std::vector<cloud::TangentRay>* outline = nullptr);

/// Ceres reports a solver's trouble (e.g. "Linear solver failure" while a geometric refit of
/// a degenerate sphere steps) through glog, at WARNING, on stderr: dozens of lines before the
/// one hedgefit writes. Each fit says what went wrong in its own result, so the command line and
/// the Python module call this once to keep only glog's errors. A library user who wants the
/// solver's warnings does not call it.
void QuietSolverWarnings();

}  // namespace hedgefit::fitting
