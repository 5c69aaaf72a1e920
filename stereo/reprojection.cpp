#include "stereo/reprojection.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include "pipeline/error.hpp"

namespace hedgefit::stereo {

const pipeline::OptionTable<ReprojectOptions>& ReprojectOptions::Table() {
  using O = ReprojectOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("organized", &O::organized, "keep the image grid (NaN where no point)")
          .Add("extra_fields", &O::extra_fields, "add disparity, sigma_z, pixel_mm, pixel_u and pixel_v fields")
          .Add("sigma_disparity", &O::sigma_disparity_px, "disparity noise for sigma_z where the refinement gave none", "px")
          .Min(0)
          .Add("keep_filled", &O::keep_filled, "also reproject hole-filled (unmeasured) disparities");
  return table;
}

void ReprojectOptions::Check() const { Table().Validate(*this); }

namespace {

// Reproject() of maps cut from the frame at `origin` (the pixels' coordinates in the frame).
cloud::PointCloud ReprojectFrom(const cv::Mat& disparity, const cv::Mat& mask, const cv::Mat& left_rect,
                                const StereoRig& rig, const ReprojectOptions& o, const cv::Mat& disparity_sigma,
                                const cv::Mat& hedge_labels, cv::Point origin) {
  cloud::PointCloud out;
  const cv::Matx44d Q(rig.Q);
  const cv::Matx33d R1t = cv::Matx33d(rig.R1).t();
  const double f = rig.P1.at<double>(0, 0), b = rig.baseline_mm;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> disp_field, sigma_field, pixel_field, hedge_field, u_field, v_field;
  const bool labelled = !hedge_labels.empty();
  for (int y = 0; y < disparity.rows; ++y) {
    for (int x = 0; x < disparity.cols; ++x) {
      const float d = disparity.at<float>(y, x);
      const bool use = std::isfinite(d) && d > 0 && (mask.empty() || mask.at<std::uint8_t>(y, x) != 0);
      if (!use) {
        if (o.organized) {
          out.points_mm.emplace_back(nan, nan, nan);
          out.colors.push_back({0, 0, 0});
          disp_field.push_back(nan);
          sigma_field.push_back(nan);
          pixel_field.push_back(nan);
          u_field.push_back(float(x)), v_field.push_back(float(y));
          if (labelled) hedge_field.push_back(0);
        }
        continue;
      }
      const cv::Vec4d h = Q * cv::Vec4d(x + origin.x, y + origin.y, d, 1.0);
      const cv::Vec3d p_rect(h[0] / h[3], h[1] / h[3], h[2] / h[3]);
      const cv::Vec3d p = R1t * p_rect;  // unrectified left camera frame
      out.points_mm.emplace_back(float(p[0]), float(p[1]), float(p[2]));
      const cv::Vec3b c = left_rect.channels() == 3 ? left_rect.at<cv::Vec3b>(y, x)
                                                    : cv::Vec3b::all(left_rect.at<std::uint8_t>(y, x));
      out.colors.push_back({c[2], c[1], c[0]});
      disp_field.push_back(d);
      if (labelled) hedge_field.push_back(float(hedge_labels.at<std::int32_t>(y, x)));
      const float own = disparity_sigma.empty() ? nan : disparity_sigma.at<float>(y, x);
      // The window's residuals cannot see interpolation or calibration error, so a pixel's
      // own estimate is floored at 0.02 px (the lab's remaining systematic error is ~0.01).
      const double sigma_d = std::isfinite(own) ? std::max(0.02, double(own)) : o.sigma_disparity_px;
      sigma_field.push_back(float(p_rect[2] * p_rect[2] * sigma_d / (f * b)));
      pixel_field.push_back(float(p_rect[2] / f));  // one pixel's lateral footprint at the point
      u_field.push_back(float(x + origin.x)), v_field.push_back(float(y + origin.y));  // where it was measured
    }
  }
  if (o.organized) {
    out.width = static_cast<std::uint32_t>(disparity.cols);
    out.height = static_cast<std::uint32_t>(disparity.rows);
  } else {
    out.Flatten();
  }
  if (labelled) out.fields["hedge_id"] = std::move(hedge_field);
  if (o.extra_fields) {
    out.fields["disparity"] = std::move(disp_field);
    out.fields["sigma_z"] = std::move(sigma_field);
    out.fields[cloud::kPixelSizeField] = std::move(pixel_field);
    out.fields[cloud::kPixelUField] = std::move(u_field);
    out.fields[cloud::kPixelVField] = std::move(v_field);
  }
  return out;
}

// Whether any disparity outside `in` is finite (x - x is 0 only for a finite x; a loop that vectorises).
bool FiniteOutside(const cv::Mat& disparity, const cv::Rect& in) {
  for (int y = 0; y < disparity.rows; ++y) {
    const float* row = disparity.ptr<float>(y);
    const bool inside = y >= in.y && y < in.y + in.height;
    const int spans[2][2] = {{0, inside ? in.x : disparity.cols}, {inside ? in.x + in.width : disparity.cols, disparity.cols}};
    for (const auto& span : spans) {
      int finite = 0;
      for (int x = span[0]; x < span[1]; ++x) finite |= (row[x] - row[x] == 0.0f);
      if (finite) return true;
    }
  }
  return false;
}

}  // namespace

cloud::PointCloud Reproject(const cv::Mat& disparity, const cv::Mat& mask, const cv::Mat& left_rect,
                            const StereoRig& rig, const ReprojectOptions& o, const cv::Mat& disparity_sigma,
                            const cv::Mat& hedge_labels) {
  return ReprojectFrom(disparity, mask, left_rect, rig, o, disparity_sigma, hedge_labels, cv::Point(0, 0));
}

cloud::PointCloud ReprojectMeasured(const cv::Mat& disparity, const cv::Mat& mask, const cv::Mat& filled,
                                    const cv::Mat& left_rect, const StereoRig& rig, const ReprojectOptions& options,
                                    const cv::Mat& disparity_sigma, const cv::Mat& hedge_labels,
                                    const cv::Rect& region) {
  // An unorganized cloud holds only the pixels with a disparity, in the frame's row order: read
  // over the region that can hold one, it is the same cloud (a lab frame's region is a tenth of it).
  const cv::Rect frame(0, 0, disparity.cols, disparity.rows);
  cv::Rect in = options.organized || region.empty() ? frame : (region & frame);
  if (in != frame && FiniteOutside(disparity, in)) in = frame;  // a later stage wrote past the region
  const auto cut = [&in](const cv::Mat& m) { return m.empty() ? m : m(in); };
  // Filled pixels are occluded or mismatched in the other view: no measurement, so by
  // default they stay in the dense map but not in the cloud.
  cv::Mat use = cut(mask);
  if (!filled.empty() && !options.keep_filled) use = use.empty() ? ~cut(filled) : (use & ~cut(filled));
  cloud::PointCloud cloud = ReprojectFrom(cut(disparity), use, cut(left_rect), rig, options, cut(disparity_sigma),
                                          cut(hedge_labels), in.tl());
  if (cloud.size() - cloud::CountNonFinite(cloud) == 0) {
    throw Error("no hedge found: no disparity inside the mask within the working range");
  }
  return cloud;
}

}  // namespace hedgefit::stereo
