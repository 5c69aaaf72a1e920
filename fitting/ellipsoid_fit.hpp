#pragma once
/// Not quite spheres: a general ellipsoid by Li & Griffiths' (2004) direct least squares, on
/// centred and scaled data. It tells a ball from a dome: the axes and their directions, and the
/// vertical one (closest to the camera's y, down in the image) against the horizontal ones.

#include <Eigen/Core>

#include <vector>

#include "pipeline/option_table.hpp"
#include "fitting/sphere_fit.hpp"

namespace hedgefit::fitting {

struct EllipsoidFit {
  bool converged = false;
  std::string message;                                    ///< why not, when not converged
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();   ///< mm
  Eigen::Vector3d axes_mm = Eigen::Vector3d::Zero();     ///< semi-axes, mm, largest first
  Eigen::Matrix3d directions = Eigen::Matrix3d::Identity();  ///< column k: direction of axes_mm[k]
  double vertical_axis_mm = 0;    ///< the semi-axis closest to the camera's y axis (down), mm
  double horizontal_axis_mm = 0;  ///< the semi-axis closest to the camera's x axis, mm; the third
                                  ///< (depth) axis is seen only from the front and is looser
  double rms_mm = 0;              ///< RMS of the first-order (Sampson) distances to the surface, mm
  double wall_ms = 0;
};

/// Fits an ellipsoid; fails (converged = false) on fewer than 9 points, degenerate data, or a
/// quadric that is not an ellipsoid.
EllipsoidFit FitEllipsoid(const std::vector<Eigen::Vector3d>& points_mm);

struct SpheroidFitOptions {
  Eigen::Vector3d up = Eigen::Vector3d(0, -1, 0);  ///< the vertical, in the cloud's frame (camera: -y)
  double loss_scale_mm = 10.0;  ///< Huber: residuals beyond this (leaf gaps, strays) are down-weighted
  void Check() const;
  static const pipeline::OptionTable<SpheroidFitOptions>& Table();  ///< the options, declared once
};

/// A sphere flattened or stretched along the vertical: centre, horizontal semi-axis a and
/// vertical semi-axis b, by least squares on the radial distance to the surface (Ceres, from the
/// geometric sphere fit, Huber loss). Five parameters instead of the general ellipsoid's nine:
/// on the cap a camera sees of a leafy hedge the general fit is ill-conditioned, this one is not.
/// b / a < 1 is a dome, > 1 an egg. `axes_mm` holds (a, a, b), directions (horizontal, horizontal,
/// up).
EllipsoidFit FitSpheroid(const std::vector<Eigen::Vector3d>& points_mm, const SpheroidFitOptions& options = {});

}  // namespace hedgefit::fitting
