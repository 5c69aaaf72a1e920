#pragma once
/// The garden test (`hedgefit bench garden`): leafy hedge balls on a lawn, before a hedge row,
/// with a pot and trees under a hard sun, rendered by the simulator at the paper's resolution.
/// Or the same gardens by POV-Ray, with hedges of real leaf discs (`renderer` povray).
/// Each scene is converted with garden segmentation (every hedge by depth) and, for contrast,
/// with the paper's colour mask; every hedge is fitted with every method and scored against
/// its outer envelope (the truth radius: where the leaves end).

#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "eval/evaluation.hpp"
#include "cloud/cleaning.hpp"
#include "cloud/outline_rays.hpp"
#include "pipeline/option_table.hpp"
#include "stereo/capture.hpp"
#include "sim/simulator.hpp"

namespace hedgefit::bench {

struct GardenOptions {
  std::string dir = "build/garden-bench";  ///< where the simulated captures go
  double scale = 1.0;                      ///< image scale of the simulated rig (1 = 1920x1200)
  bool reuse = false;                      ///< reuse captures already in `dir`
  std::string renderer = "hedgefit";       ///< hedgefit (its own ray caster) or povray (leaf discs)
  std::string camera = "ideal";            ///< povray: ideal or real (sim::CameraModel)
  bool hard = false;                       ///< sim::GardenHardPresetNames() instead of the three presets
  int random = 0;                          ///< > 0: gardens random1 ... randomN (sim::GardenPreset) instead
  int paper = 0;                           ///< > 0: gardens paper<first_seed> ... (sim::GardenPreset) instead
  int first_seed = 1;                      ///< the first seed of random and paper (1 tuning, 101 held back)
  std::string gardens;                     ///< comma-separated preset names instead of all the above
  bool leaves = false;                     ///< sim::GardenLeafPresetNames() instead (boxwood ... holly)
  bool outline = true;                     ///< the envelope fit also fits each hedge's outline (stereo::MeasureOutlines)
  double envelope_points_per_ray = -1;     ///< the envelope fit's points_per_ray; -1 = its default
  stereo::ConvertOptions convert;          ///< the capture path's options (mode is set to garden)
  /// The filter stages (JSON array) run on each capture's cloud before the fits: by default
  /// cloud::DefaultCleaningJson(), what `compare` and `measure` apply, so the figures are what a
  /// user gets; "[]" fits the matcher's cloud as it is.
  std::string cleaning;
  GardenOptions();
  /// The options a user sets (`hedgefit bench garden`'s flags), declared once.
  static const pipeline::OptionTable<GardenOptions>& Table();
};

struct GardenHedgeRow {
  int id = 0;                       ///< hedgefit's id (0 = the true hedge was not found)
  fitting::Sphere truth;            ///< envelope
  double truth_surface_mm = 0;      ///< mean leaf-surface radius
  std::size_t points = 0;
  double span_mm = 0;               ///< the points' span along their principal axis (fitting::PrincipalSpan)
  double outside_50mm = 0;          ///< share of points more than 50 mm outside the true envelope
  std::vector<fitting::SphereFitResult> fits;  ///< one per method
  std::vector<double> outside_share;            ///< per fit: fitting::OutsideShare of the points
  /// The outline's rays against the true envelope: how far each passes outside it, in px at its
  /// tangent point (negative: it cuts into the envelope), per view.
  /// Where the envelope's error comes from: the envelope fitted again with one input swapped for
  /// the renderer's truth (OracleFits): "true_points" (each point moved to the leaf its pixel
  /// truly sees, the measured outline kept), "true_outline" (each outline ray turned, about the
  /// camera, to graze the true envelope; the measured points kept), "both". Empty without a
  /// per-pixel truth or an outline.
  std::vector<std::pair<std::string, fitting::SphereFitResult>> oracle;
  std::size_t outline_rays[2] = {0, 0};
  std::vector<double> outline_quantiles_px;  ///< the rays' offsets (px, + outside) at 2, 10, 25, 50, 75, 90 %
  double outline_mean_px[2] = {0, 0}, outline_median_px[2] = {0, 0}, outline_mad_px[2] = {0, 0};
  /// The left view's mean grey-level profile across the true envelope's silhouette, 1 the hedge and
  /// 0 the background, at every whole px from -6 to +3 (+ outside), and the profiles averaged.
  std::vector<double> edge_profile;
  std::size_t edge_profile_rays = 0;
};

struct GardenScene {
  std::string name;
  std::size_t hedges_true = 0, hedges_found = 0;
  std::size_t others_found = 0;     ///< taken for hedges but in no hedge's truth (a shrub)
  std::size_t others_not_ball = 0;  ///< of those, how many the envelope fit calls not a ball
  std::size_t others_not_ball_default = 0;  ///< and how many the default fit (ransac_geometric) does
  std::vector<double> others_span_ratio;  ///< their sphere's diameter over their points' span
  std::vector<double> others_outside_share;  ///< their points' share far outside it (fitting::OutsideShare)
  double convert_ms = 0;            ///< capture to clouds, in process
  double envelope_ms = 0;           ///< the envelope fits of every hedge
  std::vector<GardenHedgeRow> rows;
  /// The paper's path on the same capture: colour mask, then a Kasa fit; error against the
  /// nearest true hedge (or why it failed).
  std::string colour_message;
  double colour_aer_mm = 0, colour_ld_mm = 0, colour_mask_share = 0;
};

/// The matcher against the renderer's own leaves: for each point of a hedge's cloud, its
/// distance from the true centre less that of the leaf its pixel truly sees (the first hit
/// through the pixel, sim::RenderGardenSurface), grouped by how deep that leaf lies below the
/// envelope. A matching window that averages the outer leaves with the ones behind reads the
/// first too deep (negative) and the deep ones too shallow (positive).
struct LeafDepthBin {
  double from_mm = 0, to_mm = 0;  ///< the true leaf's depth below the envelope
  std::size_t points = 0;
  double mean_error_mm = 0;       ///< radial: measured - true (negative: read deeper than it is)
};
struct LeafLayerErrors {
  std::vector<LeafDepthBin> bins;
  std::size_t points = 0;          ///< points whose pixel sees this hedge's leaves
  double true_outer_share = 0;     ///< of those, leaves truly within 2 mm of the envelope
  double measured_outer_share = 0; ///< and points measured within 2 mm of it
  void Add(const LeafLayerErrors& other);  ///< pools another hedge's (bins weighted by points)
};
/// `points_mm` in the left camera's frame, `surface` its RenderGardenSurface (or
/// RenderPovrayGardenSurface), `camera` its
/// intrinsics; a point whose pixel sees no leaf of this hedge (lawn, another ball: more than
/// 60 mm below or 5 mm outside the envelope) is left out.
struct GardenResult {
  std::vector<GardenScene> scenes;
  std::map<std::string, eval::MethodSummary> summary;  ///< over every found hedge
  /// The cleaned clouds of every found hedge against their true leaves (RenderGardenSurface or
  /// RenderPovrayGardenSurface), pooled.
  std::optional<LeafLayerErrors> leaf_layer;
  double seconds = 0;
};

LeafLayerErrors MeasureLeafLayer(const std::vector<Eigen::Vector3d>& points_mm, const cv::Mat& surface,
                                 const sim::SimCamera& camera, const fitting::Sphere& truth);

/// The envelope fit with its points, its outline or both replaced by the renderer's truth (see
/// GardenHedgeRow::oracle): the points by the first leaf each one's pixel sees (`surface`, left
/// camera `camera`; points whose pixel sees no leaf of this hedge are dropped), the outline's rays
/// each turned in the plane through its camera and the true centre until it grazes the true
/// envelope.
std::vector<std::pair<std::string, fitting::SphereFitResult>> OracleFits(
    const std::vector<Eigen::Vector3d>& points_mm, const std::vector<double>& pixel_mm,
    const std::vector<cloud::TangentRay>& outline, const cv::Mat& surface, const sim::SimCamera& camera,
    const fitting::Sphere& truth, const std::map<std::string, pipeline::OptionValue>& envelope_options = {});

GardenResult RunGarden(const GardenOptions& options);
void PrintGarden(const GardenResult& result);
std::string GardenJson(const GardenResult& result);

}  // namespace hedgefit::bench
