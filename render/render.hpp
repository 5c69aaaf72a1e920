#pragma once
/// Off-screen VTK pictures of clouds and fitted spheres, written to PNG: drawn by
/// libhedgefit_vtk.so, loaded on the first picture (vtk_module.hpp). Works without a display (see
/// virtual_display.hpp). The same input gives the same image.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/option_table.hpp"
#include "cloud/point_cloud.hpp"
#include "fitting/trim.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::render {

enum class ColorMode { kOwn, kDistance, kDepth, kField };
enum class View { kFront, kSide, kTop, kIso };

/// "own", "distance", "depth", "field" / "front", "side", "top", "iso"; parsers throw hedgefit::Error.
ColorMode ParseColorMode(const std::string& name);
View ParseView(const std::string& name);

/// A sphere to draw, with its legend text.
struct SphereOverlay {
  std::string label;          ///< "hyper", "truth", ...
  fitting::Sphere sphere;     ///< mm
  bool truth = false;         ///< drawn as a black wireframe
  bool dashed = false;        ///< overlay: outline dashed (a fit whose points are not a ball)
  /// A clipped shape instead of the sphere: semi-axes along the heading, across it and along
  /// `up`, mm (zero: the sphere), the heading about `up` from the x axis laid flat, degrees.
  Eigen::Vector3d axes_mm = Eigen::Vector3d::Zero();
  double heading_deg = 0;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  /// What the semi-axes are of: "" or "ellipsoid", "cylinder" (a drum about `up`), "cuboid" (a box) or
  /// "cone" (base radius a at c below the centre, apex c above).
  std::string form = "";
};

/// The overlay of a fit: its sphere, or the `shape` method's clipped shape (from its extras
/// axes_mm, heading_deg and up), labelled `label`, dashed when its points are not a ball.
SphereOverlay OverlayOf(const fitting::SphereFitResult& fit, const std::string& label);

struct RenderOptions {
  /// Added to the centres the legend prints: a cloud shifted on reading (PointCloud::offset) is
  /// drawn in its own frame, and its spheres are labelled in the file's.
  Eigen::Vector3d label_offset_mm = Eigen::Vector3d::Zero();
  int width = 1024;                    ///< px (of each view when tiled)
  int height = 768;                    ///< px
  ColorMode color = ColorMode::kOwn;   ///< point colours
  /// Sphere for ColorMode::kDistance (signed distance |p - c| - r); default: the first overlay.
  std::optional<fitting::Sphere> distance_sphere;
  double distance_range_mm = 0;        ///< colour-map half range, mm; 0 = 3 robust sigmas of |d|
  /// Per-point field for ColorMode::kField (e.g. "cut_depth"), on a diverging map about 0 with
  /// half range distance_range_mm (0 = the 99th percentile of |value|).
  std::string field = "cut_depth";
  std::vector<View> views{View::kFront};  ///< several are tiled into one image
  std::array<double, 3> background{1, 1, 1};  ///< RGB in [0, 1]
  double point_size = 2.0;             ///< px
  bool wireframe = false;              ///< fitted spheres as wireframes (else translucent)
  double sphere_opacity = 0.25;        ///< translucent spheres
  void Check() const;                  ///< throws hedgefit::Error naming the option
  static const pipeline::OptionTable<RenderOptions>& Table();  ///< the options, declared once
};

/// The colour used for the i-th fitted sphere (RGB in [0, 1]).
std::array<double, 3> OverlayColor(std::size_t index);

/// Renders and writes `png_path` atomically; throws hedgefit::Error on bad input.
/// The sphere distances are coloured against: the most trustworthy fit among `spheres` by the
/// method table's ranking (fitting::MostTrusted), else the first fit; none when only the truth is drawn.
std::optional<fitting::Sphere> MostTrustedSphere(const std::vector<SphereOverlay>& spheres);

void RenderToPng(const cloud::PointCloud& cloud, const std::vector<SphereOverlay>& spheres,
                 const RenderOptions& options, const std::string& png_path);

/// A trim plan's picture (`hedgefit trim --render`): the cloud coloured by its cut_depth field,
/// from the front and the side, with each plan's target drawn as a wireframe.
void RenderTrimPlan(const cloud::PointCloud& cloud, const std::vector<fitting::TrimPlan>& plans, const std::string& png_path);

/// Camera of a view preset for a scene: position, focal point, view-up, view angle (deg).
/// Exposed so tests can project known points exactly as the renderer does.
struct CameraSetup {
  std::array<double, 3> position, focal_point, view_up;
  double view_angle_deg = 30;
};
CameraSetup CameraFor(View view, const std::array<double, 6>& bounds);

}  // namespace hedgefit::render
