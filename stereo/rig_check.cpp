#include "stereo/rig_check.hpp"

#include <cstdio>

#include "pipeline/error.hpp"

namespace hedgefit::stereo {

void CheckRowSearchRange(const StereoRig& rig, double min_z_mm, double max_z_mm, const std::string& min_z_name,
                         const std::string& max_z_name) {
  if (!(min_z_mm > 0 && max_z_mm > min_z_mm)) {
    throw Error(min_z_name + "/" + max_z_name + ": need 0 < min-z < max-z (mm)");
  }
  // The nearest depth sets the widest disparity searched: it must fit in the (half-size) image.
  const double widest_px = rig.P1.at<double>(0, 0) * rig.baseline_mm / min_z_mm / 2;
  if (!(widest_px < rig.image_size.width / 4.0)) {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "%s %g: a point that near is %.0f px apart in the half-size views, over a quarter of their "
                  "width; raise %s to the scene's nearest depth",
                  min_z_name.c_str(), min_z_mm, widest_px, min_z_name.c_str());
    throw Error(buf);
  }
}

RigCheck CheckRigOnPair(const StereoRig& rig, const cv::Mat& left_bgr, const cv::Mat& right_bgr, double min_z_mm,
                        double max_z_mm, double tolerance_px, const std::string& source) {
  RigCheck c;
  try {
    c.rows = MeasureRowAgreement(rig, left_bgr, right_bgr, min_z_mm, max_z_mm);
  } catch (const ProcessingError&) {
    throw;
  } catch (const Error& e) {
    throw Error(source + ": " + e.what());
  }
  // A plane through fewer windows is not a measurement of the whole frame.
  if (c.rows.samples < kMinRowWindows) {
    char buf[512];
    std::snprintf(buf, sizeof(buf),
                  "%s: fewer than %d textured windows matched between %g and %g mm to measure the rows; capture a "
                  "textured scene there, or set --min-z/--max-z (rows more than 2 px apart cannot be measured: such "
                  "a rig is not these cameras')",
                  source.c_str(), kMinRowWindows, min_z_mm, max_z_mm);
    throw ProcessingError(buf);
  }
  c.max_abs_px = c.rows.MaxAbs(rig.image_size);
  c.fits = c.max_abs_px <= tolerance_px;
  return c;
}

}  // namespace hedgefit::stereo
