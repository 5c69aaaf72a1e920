#include "stereo/capture.hpp"

#include "cloud/cloud_stages.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>

#include "pipeline/error.hpp"
#include "pipeline/pipeline.hpp"
#include "stereo/rectification.hpp"
#include "stereo/stereo_stages.hpp"

namespace hedgefit::stereo {

const pipeline::OptionTable<MatchOptions>& MatchOptions::Table() {
  using O = MatchOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Nest(SgbmOptions::Table(), &O::sgbm)
          .Add("min_z", &O::min_z_mm, "working range, nearest", "mm").Min(1)
          .Add("max_z", &O::max_z_mm, "working range, farthest", "mm").Min(1)
          .Add("region_only", &O::region_only, "match only the mask's bounding box")
          .Add("margin", &O::margin_px, "margin around the mask's bounding box", "px").Range(0, 10000)
          .Add("precise_resampling", &O::precise_resampling, "B-spline rectification of the matched region")
          .Add("max_points", &O::max_points,
               "per hedge at most: larger regions keep every s-th pixel and row; 0 = all", "points")
          .Range(0, 1e9)
          .Add("min_stride", &O::min_stride,
               "every n-th pixel and row at most, where that keeps 2,500 points (pixels 1 apart share most of the "
               "refinement's window); 1 = every pixel; max_points 0 keeps every pixel")
          .Range(1, 64)
          .Add("coarse_range", &O::coarse_range,
               "a hedge without a depth range from its segmentation is matched coarsely first, and finely over "
               "the disparities it took there")
          .Add("garden_refine_max_radius", &O::garden_refine_max_radius,
               "for hedges found by depth (leafy shells), the refinement's retry window instead of "
               "refine_max_radius; at most refine_radius = no retry",
               "px")
          .Range(0, 15)
          .Add("garden_refine_curvature", &O::garden_refine_curvature,
               "for hedges found by depth (leafy shells), the curvature correction's grid instead of "
               "refine_curvature; 0 = off")
          .Range(0, 10)
          .Add("garden_sigma_ratio", &O::garden_sigma_ratio,
               "for hedges found by depth, a refined pixel less certain than this times its tile's median is left "
               "out of the cloud (windows across leaves at different depths); 0 = keep all")
          .Min(0)
          .Add("garden_sigma_tile", &O::garden_sigma_tile_px, "the garden_sigma_ratio median's square", "px")
          .Range(4, 4096);
  return table;
}

void MatchOptions::Check() const {
  Table().Validate(*this);
  sgbm.Check();
  CheckDepthRange(min_z_mm, max_z_mm);
}

namespace {

// The disparities a hedge's mask takes, from a coarse match: the pair at a quarter of the
// resolution over the mask's region and the whole search range of `sg` (no refinement, no
// filling), the masked pixels' 1st to 99th percentile, widened by 8 px (two coarse pixels) and by
// 5 %. Narrows `sg` to them; leaves it as it was when under a fifth of the masked pixels match (a
// textureless or mismatched hedge keeps the whole range).
void NarrowRangeToMask(const cv::Mat& left, const cv::Mat& right, const cv::Mat& mask, int margin_px, SgbmOptions* sg) {
  constexpr int k = 4;
  const cv::Rect roi = MatchRegion(mask, *sg, margin_px);
  if (roi.width < 32 * k || roi.height < 8 * k) return;
  const cv::Size small(roi.width / k, roi.height / k);
  cv::Mat l, r, m;
  cv::resize(left(roi), l, small, 0, 0, cv::INTER_AREA);
  cv::resize(right(roi), r, small, 0, 0, cv::INTER_AREA);
  cv::resize(mask(roi), m, small, 0, 0, cv::INTER_NEAREST);
  SgbmOptions c = *sg;
  c.refine_radius = 0;
  c.fill_holes = false;
  c.bilateral_sigma_disp = 0;
  c.min_disparity = sg->min_disparity / k;
  const int end = sg->min_disparity + sg->num_disparities;
  c.num_disparities = (((end + k - 1) / k - c.min_disparity + 15) / 16) * 16;
  if (small.width <= c.min_disparity + c.num_disparities + c.block_size) return;
  const DisparityMap d = ComputeDisparity(l, r, c);
  std::vector<float> v;
  for (int y = 0; y < small.height; ++y) {
    const float* dr = d.disparity.ptr<float>(y);
    const std::uint8_t* mr = m.ptr<std::uint8_t>(y);
    const std::uint8_t* rej = d.rejected.ptr<std::uint8_t>(y);
    for (int x = 0; x < small.width; ++x) {
      if (mr[x] != 0 && rej[x] == 0 && std::isfinite(dr[x])) v.push_back(dr[x] * k);
    }
  }
  if (v.size() < std::max<std::size_t>(50, std::size_t(cv::countNonZero(m)) / 5)) return;
  const auto at = [&](double q) {
    auto it = v.begin() + std::ptrdiff_t(q * double(v.size() - 1));
    std::nth_element(v.begin(), it, v.end());
    return double(*it);
  };
  const double lo = at(0.01), hi = at(0.99);
  const double widen = 8 + 0.05 * hi;
  const int new_min = std::max(sg->min_disparity, int(std::floor(lo - widen)));
  const int new_end = std::min(end, int(std::ceil(hi + widen)));
  const int num = ((std::max(16, new_end - new_min) + 15) / 16) * 16;
  if (num >= sg->num_disparities) return;
  sg->min_disparity = new_min;
  sg->num_disparities = num;
}

}  // namespace

namespace {

// MatchHedge's work: its disparity, filled and sigma maps are the matched region's size
// (`matched_region` says where it lies), so several hedges are merged without full-frame copies.
MatchResult MatchHedgeRegion(const StereoRig& rig, const cv::Mat* raw_left, const cv::Mat* raw_right, cv::Mat* left_rect,
                             cv::Mat* right_rect, const cv::Mat& mask, const MatchOptions& options) {
  options.Check();
  MatchResult r;
  SgbmOptions sg = options.sgbm;
  CheckNearestDepth(rig.P1.at<double>(0, 0), rig.baseline_mm, options.min_z_mm, left_rect->cols);
  DisparityRangeForDepth(rig.P1.at<double>(0, 0), rig.baseline_mm, options.min_z_mm, options.max_z_mm,
                         &sg.min_disparity, &sg.num_disparities);
  if (options.coarse_range && options.region_only && !mask.empty() && cv::countNonZero(mask) > 0) {
    NarrowRangeToMask(*left_rect, *right_rect, mask, options.margin_px, &sg);
  }
  r.min_disparity = sg.min_disparity;
  r.num_disparities = sg.num_disparities;
  const cv::Size size = left_rect->size();
  cv::Rect roi(0, 0, size.width, size.height);
  if (options.region_only && !mask.empty() && cv::countNonZero(mask) > 0) roi = MatchRegion(mask, sg, options.margin_px);
  r.matched_region = roi;
  r.matched_area = roi.area();
  if (options.precise_resampling && raw_left != nullptr && raw_right != nullptr) {
    const auto t0 = std::chrono::steady_clock::now();
    RectifyRegionPrecisely(rig, *raw_left, *raw_right, roi, left_rect, right_rect);
    r.rectify_region_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  // Thinning: the smallest stride that keeps the mask's pixels (the whole region without one)
  // within max_points, and at least min_stride where that still leaves kMinThinnedPoints: a small
  // hedge costs little, and the cleaning's neighbour statistics (20-30 neighbours each) and the
  // fits' jackknife want its points (PCL's outdoor shrub covers 1,500 pixels).
  constexpr double kMinThinnedPoints = 2500;
  const double pixels = mask.empty() ? double(roi.area()) : double(cv::countNonZero(mask));
  const int min_stride = pixels / (options.min_stride * options.min_stride) >= kMinThinnedPoints ? options.min_stride : 1;
  r.stride = options.max_points > 0 ? std::max(min_stride, int(std::ceil(std::sqrt(pixels / options.max_points)))) : 1;
  // A hedge near the image's edge: the region cannot reach as far past the mask as the search
  // needs (MatchRegion), so the match is padded by what is missing on that side.
  int pad_left = 0, pad_right = 0;
  if (!mask.empty()) {
    const cv::Rect box = cv::boundingRect(mask);
    if (!box.empty()) {
      pad_left = std::max(0, sg.min_disparity + sg.num_disparities + sg.block_size - (box.x - roi.x));
      pad_right = std::max(0, sg.num_disparities + sg.block_size - (roi.x + roi.width - box.x - box.width));
    }
  }
  DisparityMap d = ComputeDisparity((*left_rect)(roi), (*right_rect)(roi), sg, mask.empty() ? cv::Mat() : mask(roi),
                                    r.stride, pad_left, pad_right);
  r.sgbm_ms = d.sgbm_ms;
  r.refine_ms = d.refine_ms;
  r.disparity = d.disparity;
  r.filled = d.rejected;
  r.disparity_sigma = d.sigma.empty() ? cv::Mat(roi.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()))
                                      : d.sigma;
  r.filled_count = d.filled;
  r.vertical = d.vertical;
  r.vertical_max_px = d.vertical.samples > 0 ? d.vertical.MaxAbs(roi.size()) : 0.0;
  // SGBM searches a few pixels beyond the working range, and filling and refinement can move a
  // value further: no point outside [min_z, max_z] leaves the matcher.
  const double fb = rig.P1.at<double>(0, 0) * rig.baseline_mm;
  const float d_lo = float(fb / options.max_z_mm), d_hi = float(fb / options.min_z_mm);
  r.disparity.forEach<float>([&](float& v, const int*) {
    if (v < d_lo || v > d_hi) v = std::numeric_limits<float>::quiet_NaN();
  });
  return r;
}

}  // namespace

namespace {

// `region` placed at `roi` in a frame of `size` holding `outside` everywhere else, written row by
// row in one pass on every core. A fill of the frame and then a copy of the region, on one core,
// took 7 ms of a lab frame for the three maps.
template <typename T>
cv::Mat PlaceInFrame(const cv::Mat& region, const cv::Rect& roi, cv::Size size, T outside) {
  cv::Mat out(size, cv::traits::Type<T>::value);
  if (region.empty() || roi.empty()) {
    out.setTo(outside);
    return out;
  }
  CV_Assert(region.size() == roi.size() && region.type() == out.type() &&
            (roi & cv::Rect(0, 0, size.width, size.height)) == roi);
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      T* row = out.ptr<T>(y);
      if (y < roi.y || y >= roi.y + roi.height) {
        std::fill_n(row, size.width, outside);
        continue;
      }
      std::fill_n(row, roi.x, outside);
      std::copy_n(region.ptr<T>(y - roi.y), roi.width, row + roi.x);
      std::fill_n(row + roi.x + roi.width, size.width - roi.x - roi.width, outside);
    }
  }, 8);
  return out;
}

}  // namespace

MatchResult MatchHedge(const StereoRig& rig, const cv::Mat* raw_left, const cv::Mat* raw_right, cv::Mat* left_rect,
                       cv::Mat* right_rect, const cv::Mat& mask, const MatchOptions& options) {
  MatchResult r = MatchHedgeRegion(rig, raw_left, raw_right, left_rect, right_rect, mask, options);
  // The full rectified size: NaN, not filled and no sigma outside the region.
  const cv::Size size = left_rect->size();
  const cv::Rect roi = r.matched_region;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  r.disparity = PlaceInFrame<float>(r.disparity, roi, size, nan);
  r.filled = PlaceInFrame<std::uint8_t>(r.filled, roi, size, 0);
  r.disparity_sigma = PlaceInFrame<float>(r.disparity_sigma, roi, size, nan);
  const cv::Mat& disparity = r.disparity;
  const cv::Mat& filled = r.filled;
  if (!mask.empty()) {
    HedgeMatch h;
    h.pixels = cv::countNonZero(mask);
    h.stride = r.stride;
    // Over the matched region: outside it every disparity is NaN (three full-frame masks a frame
    // otherwise, each a fresh 2.3 MB allocation for a 1920 x 1200 frame).
    const cv::Mat d = disparity(roi);
    h.measured = roi.empty() ? 0 : cv::countNonZero((d == d) & (filled(roi) == 0) & (mask(roi) != 0));
    h.vertical = r.vertical;
    h.vertical_max_px = r.vertical_max_px;
    r.hedges.push_back(h);
  }
  return r;
}

MatchResult MatchHedges(const StereoRig& rig, const cv::Mat* raw_left, const cv::Mat* raw_right, cv::Mat* left_rect,
                        cv::Mat* right_rect, const cv::Mat& hedge_labels, const MatchOptions& options,
                        const std::vector<HedgeRegion>& hedges) {
  double max_id = 0;
  cv::minMaxLoc(hedge_labels, nullptr, &max_id);
  MatchResult all;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  all.disparity = cv::Mat(hedge_labels.size(), CV_32F, cv::Scalar(nan));
  all.filled = cv::Mat::zeros(hedge_labels.size(), CV_8U);
  all.disparity_sigma = cv::Mat(hedge_labels.size(), CV_32F, cv::Scalar(nan));
  int matched_area = 0;
  for (int id = 1; id <= int(max_id); ++id) {
    const cv::Mat mask = hedge_labels == id;
    if (cv::countNonZero(mask) == 0) continue;
    // Each hedge's own depth range, when the segmentation measured one: fewer disparities.
    MatchOptions own = options;
    bool leafy = false;  // found by depth: a leafy shell
    for (const HedgeRegion& h : hedges) {
      if (h.id == id && h.max_z_mm > h.min_z_mm) {
        own.min_z_mm = std::max(options.min_z_mm, h.min_z_mm);
        own.max_z_mm = std::min(options.max_z_mm, h.max_z_mm);
        own.coarse_range = false;  // the segmentation's own coarse match gave the range
        own.sgbm.refine_max_radius = options.garden_refine_max_radius;  // a leafy shell: see the option
        own.sgbm.refine_curvature = options.garden_refine_curvature;    // likewise
        leafy = own.max_z_mm > own.min_z_mm;
        if (!leafy) own = options;
      }
    }
    MatchResult m = MatchHedgeRegion(rig, raw_left, raw_right, left_rect, right_rect, mask, own);
    // Merged within the hedge's region only: its mask lies inside it.
    const cv::Rect roi = m.matched_region;
    const cv::Mat inside = mask(roi);
    m.disparity.copyTo(all.disparity(roi), inside);
    m.filled.copyTo(all.filled(roi), inside);
    m.disparity_sigma.copyTo(all.disparity_sigma(roi), inside);
    all.filled_count += cv::countNonZero(m.filled & inside);
    HedgeMatch h;
    h.id = id;
    h.pixels = cv::countNonZero(inside);
    h.stride = m.stride;
    h.measured = cv::countNonZero((all.disparity(roi) == all.disparity(roi)) & (all.filled(roi) == 0) & inside);
    h.vertical = m.vertical;
    h.vertical_max_px = m.vertical_max_px;
    all.hedges.push_back(h);
    if (leafy && options.garden_sigma_ratio > 0) {
      // On the full-frame maps, so the squares stay those of the image (from its origin).
      all.less_certain_dropped += DropLessCertain(mask, all.disparity_sigma, all.filled, options.garden_sigma_ratio,
                                                  options.garden_sigma_tile_px, &all.disparity);
    }
    all.matched_region = all.matched_region.empty() ? m.matched_region : (all.matched_region | m.matched_region);
    matched_area += m.matched_region.area();
    if (all.num_disparities == 0) {
      all.min_disparity = m.min_disparity;
      all.num_disparities = m.num_disparities;
    } else {
      const int hi = std::max(all.min_disparity + all.num_disparities, m.min_disparity + m.num_disparities);
      all.min_disparity = std::min(all.min_disparity, m.min_disparity);
      all.num_disparities = hi - all.min_disparity;
    }
    all.stride = std::max(all.stride, m.stride);
    all.rectify_region_ms += m.rectify_region_ms;
    all.sgbm_ms += m.sgbm_ms;
    all.refine_ms += m.refine_ms;
    if (m.vertical_max_px > all.vertical_max_px) all.vertical = m.vertical, all.vertical_max_px = m.vertical_max_px;
  }
  all.matched_area = matched_area;
  return all;
}

int DropLessCertain(const cv::Mat& mask, const cv::Mat& sigma, const cv::Mat& filled, double ratio, int tile_px,
                    cv::Mat* disparity) {
  if (!(ratio > 0) || sigma.empty() || mask.empty()) return 0;
  const cv::Rect box = cv::boundingRect(mask);
  if (box.empty()) return 0;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int x0 = (box.x / tile_px) * tile_px, y0 = (box.y / tile_px) * tile_px;
  const int bands = (box.y + box.height - y0 + tile_px - 1) / tile_px;
  std::atomic<int> dropped{0};
  // A band of squares reads and writes its own rows only, so the bands run side by side and leave
  // out exactly what one band after another would.
  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& range) {
    std::vector<float> values;
    int local = 0;
    for (int band = range.start; band < range.end; ++band) {
      for (int tx = x0; tx < box.x + box.width; tx += tile_px) {
        const cv::Rect tile = cv::Rect(tx, y0 + band * tile_px, tile_px, tile_px) & box;
        // Measured: in the mask, not filled, a finite disparity and sigma.
        auto each_measured = [&](auto&& act) {
          for (int y = tile.y; y < tile.y + tile.height; ++y) {
            const std::uint8_t* m = mask.ptr<std::uint8_t>(y);
            const std::uint8_t* f = filled.empty() ? nullptr : filled.ptr<std::uint8_t>(y);
            const float* s = sigma.ptr<float>(y);
            float* d = disparity->ptr<float>(y);
            for (int x = tile.x; x < tile.x + tile.width; ++x) {
              if (m[x] != 0 && (f == nullptr || f[x] == 0) && std::isfinite(d[x]) && std::isfinite(s[x])) act(s[x], d[x]);
            }
          }
        };
        values.clear();
        each_measured([&](float s, float&) { values.push_back(s); });
        if (values.size() < 8) continue;
        const auto mid = values.begin() + std::ptrdiff_t(values.size() / 2);
        std::nth_element(values.begin(), mid, values.end());
        const double limit = ratio * double(*mid);
        each_measured([&](float s, float& d) {
          if (s > limit) d = nan, ++local;
        });
      }
    }
    dropped += local;
  });
  return dropped.load();
}

VerticalDisparity MeasureRowAgreement(const StereoRig& rig, const cv::Mat& left_bgr, const cv::Mat& right_bgr,
                                      double min_z_mm, double max_z_mm) {
  if (left_bgr.size() != rig.image_size || right_bgr.size() != rig.image_size) {
    throw Error("the images are " + std::to_string(left_bgr.cols) + "x" + std::to_string(left_bgr.rows) + " and " +
                std::to_string(right_bgr.cols) + "x" + std::to_string(right_bgr.rows) + ", the rig is for " +
                std::to_string(rig.image_size.width) + "x" + std::to_string(rig.image_size.height) +
                "; use the rig of these cameras");
  }
  cv::Mat left, right;
  RectifyPair(rig, left_bgr, right_bgr, &left, &right);
  SgbmOptions sg;
  DisparityRangeForDepth(rig.P1.at<double>(0, 0) / 2, rig.baseline_mm, min_z_mm, max_z_mm, &sg.min_disparity,
                         &sg.num_disparities);
  sg.refine_radius = 0;
  sg.fill_holes = false;
  cv::Mat half_left, half_right;
  cv::resize(left, half_left, cv::Size(left.cols / 2, left.rows / 2), 0, 0, cv::INTER_AREA);
  cv::resize(right, half_right, half_left.size(), 0, 0, cv::INTER_AREA);
  if (half_left.cols < 16 || half_left.rows < 16) return VerticalDisparity();
  const DisparityMap half = ComputeDisparity(half_left, half_right, sg);
  cv::Mat d;
  cv::resize(half.disparity * 2.0f, d, left.size(), 0, 0, cv::INTER_NEAREST);
  return EstimateVerticalDisparity(left, right, d);
}

cv::Rect MatchRegion(const cv::Mat& mask, const SgbmOptions& sgbm, int margin_px) {
  const cv::Rect box = cv::boundingRect(mask);
  // Columns SGBM needs to the left of a pixel: its whole search range. The right matcher of the
  // left-right check searches the other way and finds nothing in its view's last min + num
  // columns, so a left pixel of disparity d within num - (d - min) columns of the region's right
  // edge fails the check: the region reaches num columns past the mask (it used to reach only the
  // margin, and a sphere's right limb lost ~20 columns, 16 % of its points with a range from 1 m).
  const int reach = sgbm.min_disparity + sgbm.num_disparities;
  const int x0 = std::max(0, box.x - margin_px - reach), y0 = std::max(0, box.y - margin_px);
  const int x1 = std::min(mask.cols, box.x + box.width + margin_px + sgbm.num_disparities);
  const int y1 = std::min(mask.rows, box.y + box.height + margin_px);
  return cv::Rect(x0, y0, x1 - x0, y1 - y0);
}

void ConvertOptions::Check() const {
  switch (mode) {
    case SegmentMode::kAuto: segment.Check(), garden.Check(); break;
    case SegmentMode::kColour: segment.Check(); break;
    case SegmentMode::kMask: mask.Check(); break;
    case SegmentMode::kDepth: depth.Check(); break;
    case SegmentMode::kGarden: garden.Check(); break;
  }
  match.Check();
  rig_check.Check();
  reproject.Check();
  if (matcher.empty()) throw Error("option 'matcher': name the matching stage, e.g. stereo.sgbm");
}

ConvertOptions ReferenceOptions() {
  ConvertOptions o;
  o.reference_cleaning = true;
  o.rig_check.rolling = 1;
  o.segment.coarse = false;
  o.match.min_stride = 1;
  return o;
}

std::string CapturePipelineJson(const ConvertOptions& o, const std::string& left, const std::string& right,
                                const std::string& rig) {
  using nlohmann::json;
  auto stage = [](const std::string& type, const std::map<std::string, pipeline::OptionValue>& values) {
    json j = {{"type", type}};
    for (const auto& [k, v] : values) j[k] = std::visit([](const auto& x) { return json(x); }, v);
    return j;
  };
  json p = json::array();
  if (!left.empty()) p.push_back({{"type", "readers.stereo"}, {"left", left}, {"right", right}, {"rig", rig}});
  p.push_back({{"type", "stereo.rectify"}});
  switch (o.mode) {
    case SegmentMode::kAuto: {
      AutoSegmentOptions a;
      a.colour = o.segment;
      a.garden = o.garden;
      a.garden_above = o.garden_above;
      p.push_back(stage("stereo.segment_auto", AutoSegmentOptions::Table().Values(a)));
      break;
    }
    case SegmentMode::kColour: p.push_back(stage("stereo.segment", SegmentOptions::Table().Values(o.segment))); break;
    case SegmentMode::kMask: p.push_back(stage("stereo.mask", MaskOptions::Table().Values(o.mask))); break;
    case SegmentMode::kDepth:
      p.push_back(stage("stereo.segment_depth", DepthSegmentOptions::Table().Values(o.depth)));
      break;
    case SegmentMode::kGarden:
      p.push_back(stage("stereo.segment_garden", GardenSegmentOptions::Table().Values(o.garden)));
      break;
  }
  p.push_back(o.matcher == "stereo.sgbm" ? stage("stereo.sgbm", MatchOptions::Table().Values(o.match))
                                         : json{{"type", o.matcher}});
  // Every capture checks its rig against its own images (whatever the matcher).
  p.push_back(stage("stereo.rig_check", RigCheckOptions::Table().Values(o.rig_check)));
  p.push_back(stage("stereo.reproject", ReprojectOptions::Table().Values(o.reproject)));
  return p.dump(2);
}

ConvertResult ConvertCapture(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const StereoRig& rig,
                             const ConvertOptions& options) {
  options.Check();
  // The process's registry, so a matcher added by a plugin or a library user works here too. The
  // capture path's stages are stereo/'s and cloud/'s, both at or below this layer.
  pipeline::Registry& registry = pipeline::Registry::Global();
  registry.AddModule("cloud", &cloud::RegisterCloudStages);
  registry.AddModule("stereo", &RegisterStereoStages);
  pipeline::Pipeline pipeline = pipeline::Pipeline::FromJson(CapturePipelineJson(options), "convert", registry, {},
                                                       {"left_image", "right_image", "rig"});
  pipeline::Context ctx;
  ctx.quiet = true;
  PutCapture(left_bgr, right_bgr, rig, &ctx);
  const pipeline::RunReport report = pipeline.Run(ctx);
  ConvertResult r;
  r.cloud = std::move(ctx.Get<cloud::PointCloud>("cloud"));
  r.left_rect = ctx.Get<cv::Mat>("left_image");
  r.right_rect = ctx.Get<cv::Mat>("right_image");
  r.mask = ctx.Get<cv::Mat>("mask");
  r.disparity = ctx.Get<cv::Mat>("disparity");
  if (const cv::Mat* filled = ctx.Find<cv::Mat>("filled")) r.filled = *filled;
  if (const cv::Mat* sigma = ctx.Find<cv::Mat>("disparity_sigma")) r.disparity_sigma = *sigma;
  const cv::Rect* region = ctx.Find<cv::Rect>("matched_region");
  r.matched_region = region ? *region : cv::Rect(0, 0, r.left_rect.cols, r.left_rect.rows);
  if (const auto* hedges = ctx.Find<std::vector<HedgeRegion>>("hedges")) r.hedges = *hedges;
  if (const auto* labels = ctx.Find<cv::Mat>("hedge_labels")) r.hedge_labels = *labels;
  if (const auto* ground = ctx.Find<cv::Vec4d>("ground_plane")) r.ground = *ground;
  const int* area = ctx.Find<int>("matched_area");
  r.matched_fraction = double(area ? *area : r.matched_region.area()) / double(r.left_rect.total());
  for (const auto& s : report.stages) {
    if (s.type == "stereo.rectify") r.stage_ms.rectify += s.wall_ms;
    else if (s.type == options.matcher) r.stage_ms.match += s.wall_ms;
    else if (s.type == "stereo.reproject") r.stage_ms.reproject += s.wall_ms;
    else r.stage_ms.segment += s.wall_ms;
  }
  r.wall_ms = report.total_ms;
  return r;
}

cv::Mat ColorizeDisparity(const cv::Mat& disparity) {
  double lo = 0, hi = 1;
  cv::Mat known = disparity == disparity;
  cv::minMaxLoc(disparity, &lo, &hi, nullptr, nullptr, known);
  cv::Mat norm;
  disparity.convertTo(norm, CV_8U, 255.0 / std::max(1e-6, hi - lo), -lo * 255.0 / std::max(1e-6, hi - lo));
  cv::Mat color;
  cv::applyColorMap(norm, color, cv::COLORMAP_TURBO);
  color.setTo(cv::Scalar(0, 0, 0), ~known);
  return color;
}

}  // namespace hedgefit::stereo
