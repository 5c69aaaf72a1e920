#include "stereo/row_check.hpp"

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cfloat>
#include <cstdint>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "pipeline/error.hpp"
#include "stereo/bspline.hpp"

namespace hedgefit::stereo {

namespace {

constexpr double kMaxSigmaPx = 0.25;  // a refined window's vertical shift must be pinned to this

cv::Mat Grey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat g;
  cv::cvtColor(image, g, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return g;
}

double Median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Corners spread over the frame: the strongest few of each cell, so the edges (where distortion
// shows) are sampled as well as the textured middle.
// Only the cells whose index (row-major) is `phase` modulo `period`.
std::vector<cv::Point2f> SpreadCorners(const cv::Mat& grey, const cv::Mat& valid, int max_corners, int period,
                                       int phase) {
  std::vector<cv::Point2f> all;
  const int per_cell = std::max(2, max_corners / (kCellsX * kCellsY));
  for (int cy = 0; cy < kCellsY; ++cy) {
    for (int cx = 0; cx < kCellsX; ++cx) {
      if ((cy * kCellsX + cx) % period != phase) continue;
      const cv::Rect cell(cx * grey.cols / kCellsX, cy * grey.rows / kCellsY, grey.cols / kCellsX, grey.rows / kCellsY);
      if (cell.width < 16 || cell.height < 16) continue;
      std::vector<cv::Point2f> found;
      cv::goodFeaturesToTrack(grey(cell), found, per_cell, 0.01, std::max(6, cell.width / 8),
                              valid.empty() ? cv::noArray() : cv::InputArray(valid(cell)), 7);
      for (const cv::Point2f& p : found) all.emplace_back(p.x + float(cell.x), p.y + float(cell.y));
    }
  }
  return all;
}

// dy = offset + slope_x (x - W/2) / W + slope_y (y - H/2) / H, least squares on the samples that
// stay within 3 MADs (at least 0.05 px) of the previous fit.
VerticalDisparity FitPlane(const std::vector<RowSample>& s, cv::Size size) {
  VerticalDisparity p;
  std::vector<char> keep(s.size(), 1);
  for (int round = 0; round < 3; ++round) {
    cv::Matx33d ata = cv::Matx33d::zeros();
    cv::Vec3d atb(0, 0, 0);
    int n = 0;
    for (std::size_t i = 0; i < s.size(); ++i) {
      if (!keep[i]) continue;
      const cv::Vec3d a(1, (s[i].x - 0.5 * size.width) / size.width, (s[i].y - 0.5 * size.height) / size.height);
      ata += a * a.t();
      atb += a * double(s[i].dy);
      ++n;
    }
    if (n < 6) return VerticalDisparity{};
    cv::Vec3d x;
    if (!cv::solve(cv::Mat(ata), cv::Mat(atb), x, cv::DECOMP_CHOLESKY)) return VerticalDisparity{};
    p.offset_px = x[0], p.slope_x_px = x[1], p.slope_y_px = x[2], p.samples = n;
    std::vector<double> res;
    for (const RowSample& r : s) res.push_back(std::abs(r.dy - p.At(r.x, r.y, size)));
    const double cut = std::max(0.05, 3 * 1.4826 * Median(res));
    for (std::size_t i = 0; i < s.size(); ++i) keep[i] = res[i] <= cut;
  }
  return p;
}

// A periodic texture (a brick wall, a fence, tiles, a trellis) tracks to the next brick over, or
// the next course up, as readily as to its match; and the next brick over is not on quite the same
// row (perspective), so a wall "reads" rows a pixel apart on a rig that fits. A tracked corner
// counts only when its match is unique along its row: normalised cross-correlation of the tracking
// window (15 x 15 at half size) along the match's row (within a pixel, kTwinReachPx either side),
// and no second peak, beyond the slopes of the match's own, within kTwinMargin of it. A match
// more than kTwinRowPx off its own row must also have no such twin on that row (within a pixel):
// a real drift of a few pixels leaves none on leaves, lawn or gravel.
constexpr int kTwinReachPx = 40;  // half size: the 80 px either side of the match in full size
constexpr double kTwinMargin = 0.05, kTwinRowPx = 3.0;

}  // namespace

namespace internal {

// c[k] += sum_j t[j] s[k + j] for k < cols: one template row's share of the cross-correlation.
// Compiled for AVX-512 as well, chosen when the processor has it (the loop over k is 16 wide).
__attribute__((target_clones("avx512f", "default"))) static void CorrelateRow(const float* s, const std::uint8_t* t,
                                                                         int t_cols, float* c, int cols) {
  for (int j = 0; j < t_cols; ++j) {
    const float tj = float(t[j]);
    const float* sj = s + j;
    for (int k = 0; k < cols; ++k) c[k] += tj * sj[k];
  }
}

// cv::matchTemplate's TM_CCOEFF_NORMED of the 8-bit `tpl` over the 8-bit `strip`, with the same
// normalisation and the same guards for a flat window or template (OpenCV's common_matchTemplate),
// but the cross-correlation summed directly: over a strip 17 rows by about 95 columns OpenCV goes
// through a DFT, which took about half the rig check's CPU time. Products of 8-bit values summed
// over up to 258 pixels stay under 2^24, so float sums them exactly (a larger template rounds as
// floats do), and the loop over the result's columns vectorises.
cv::Mat CorrCoeffNormed(const cv::Mat& strip, const cv::Mat& tpl) {
  CV_Assert(strip.type() == CV_8UC1 && tpl.type() == CV_8UC1 && tpl.rows <= strip.rows && tpl.cols <= strip.cols);
  const int rows = strip.rows - tpl.rows + 1, cols = strip.cols - tpl.cols + 1;
  cv::Mat out(rows, cols, CV_32F, cv::Scalar(0));
  const double n = double(tpl.total());
  double sum_t = 0, sum_t2 = 0;
  for (int i = 0; i < tpl.rows; ++i) {
    for (int j = 0; j < tpl.cols; ++j) {
      const double v = tpl.at<std::uint8_t>(i, j);
      sum_t += v, sum_t2 += v * v;
    }
  }
  const double mean_t = sum_t / n, var_t = std::max(0.0, sum_t2 / n - mean_t * mean_t);
  if (var_t < DBL_EPSILON) {
    out.setTo(1.0f);
    return out;
  }
  const double norm_t = std::sqrt(var_t * n);
  const int w = strip.cols;
  std::vector<float> s(static_cast<std::size_t>(strip.rows * w)), cc(static_cast<std::size_t>(cols));
  for (int i = 0; i < strip.rows; ++i) {
    const std::uint8_t* srow = strip.ptr<std::uint8_t>(i);
    for (int k = 0; k < w; ++k) s[std::size_t(i * w + k)] = float(srow[k]);
  }
  // Each column's sum and sum of squares over the window's rows, in integers (exact), moved down
  // a row at a time; along the row, the window's slid the same way.
  std::vector<std::int32_t> col(static_cast<std::size_t>(w), 0), col2(static_cast<std::size_t>(w), 0);
  for (int i = 0; i < tpl.rows; ++i) {
    const std::uint8_t* srow = strip.ptr<std::uint8_t>(i);
    for (int k = 0; k < w; ++k) col[std::size_t(k)] += srow[k], col2[std::size_t(k)] += srow[k] * srow[k];
  }
  for (int r = 0; r < rows; ++r) {
    if (r > 0) {
      const std::uint8_t* gone = strip.ptr<std::uint8_t>(r - 1);
      const std::uint8_t* come = strip.ptr<std::uint8_t>(r + tpl.rows - 1);
      for (int k = 0; k < w; ++k) {
        col[std::size_t(k)] += come[k] - gone[k];
        col2[std::size_t(k)] += come[k] * come[k] - gone[k] * gone[k];
      }
    }
    std::fill(cc.begin(), cc.end(), 0.0f);
    for (int i = 0; i < tpl.rows; ++i) CorrelateRow(&s[std::size_t((r + i) * w)], tpl.ptr<std::uint8_t>(i), tpl.cols, cc.data(), cols);
    std::int64_t wsum = 0, wsum2 = 0;
    for (int j = 0; j < tpl.cols; ++j) wsum += col[std::size_t(j)], wsum2 += col2[std::size_t(j)];
    for (int c = 0; c < cols; ++c) {
      if (c > 0) {
        wsum += col[std::size_t(c + tpl.cols - 1)] - col[std::size_t(c - 1)];
        wsum2 += col2[std::size_t(c + tpl.cols - 1)] - col2[std::size_t(c - 1)];
      }
      const double sum = double(wsum), sum2 = double(wsum2);
      double num = double(cc[std::size_t(c)]) - sum * mean_t;
      const double t = std::sqrt(std::max(sum2 - sum * sum / n, 0.0)) * norm_t;
      if (std::abs(num) < t) num /= t;
      else if (std::abs(num) < t * 1.125) num = num > 0 ? 1 : -1;
      else num = 0;
      out.at<float>(r, c) = float(num);
    }
  }
  return out;
}

}  // namespace internal

namespace {

// The best correlation of `tpl` centred on each column of [x - reach, x + reach] (clipped to the
// image) within a pixel of row `y` of `img`; `*first` is the column of the first. Empty when the
// band leaves the image above or below.
std::vector<float> CorrelationAlongRow(const cv::Mat& img, const cv::Mat& tpl, int x, int y, int* first) {
  const int hw = tpl.cols / 2, hh = tpl.rows / 2;
  const int x0 = std::max(hw, x - kTwinReachPx), x1 = std::min(img.cols - 1 - hw, x + kTwinReachPx);
  if (y - 1 - hh < 0 || y + 1 + hh >= img.rows || x1 < x0) return {};
  const cv::Mat ncc = internal::CorrCoeffNormed(img(cv::Rect(x0 - hw, y - 1 - hh, x1 - x0 + tpl.cols, tpl.rows + 2)), tpl);
  std::vector<float> best(std::size_t(ncc.cols), -1.0f);
  for (int r = 0; r < ncc.rows; ++r) {
    for (int c = 0; c < ncc.cols; ++c) best[std::size_t(c)] = std::max(best[std::size_t(c)], ncc.at<float>(r, c));
  }
  *first = x0;
  return best;
}

// Whether the half-size corner `at` of `left`, matched at `to` in `right`, has a twin (above).
bool HasTwin(const cv::Mat& left, const cv::Mat& right, cv::Point2f at, cv::Point2f to) {
  constexpr int kHalf = 7;
  const cv::Point a(int(std::lround(at.x)), int(std::lround(at.y))), m(int(std::lround(to.x)), int(std::lround(to.y)));
  const cv::Rect t(a.x - kHalf, a.y - kHalf, 2 * kHalf + 1, 2 * kHalf + 1);
  if ((t & cv::Rect(0, 0, left.cols, left.rows)) != t) return false;
  const cv::Mat tpl = left(t);
  int first = 0;
  const std::vector<float> p = CorrelationAlongRow(right, tpl, m.x, m.y, &first);
  const int n = int(p.size());
  if (m.x - first < 0 || m.x - first >= n) return false;
  // The match's peak (within 2 px of where tracking put it) and its hill: the slopes down from it.
  int peak = m.x - first;
  for (int k = std::max(0, m.x - first - 2); k <= std::min(n - 1, m.x - first + 2); ++k) {
    if (p[std::size_t(k)] > p[std::size_t(peak)]) peak = k;
  }
  int lo = peak, hi = peak;
  while (lo > 0 && p[std::size_t(lo - 1)] <= p[std::size_t(lo)]) --lo;
  while (hi + 1 < n && p[std::size_t(hi + 1)] <= p[std::size_t(hi)]) ++hi;
  const float match = p[std::size_t(peak)];
  for (int k = 0; k < n; ++k) {
    if ((k < lo || k > hi) && p[std::size_t(k)] >= match - kTwinMargin) return true;
  }
  if (std::abs(2.0 * (to.y - at.y)) > kTwinRowPx) {
    for (const float v : CorrelationAlongRow(right, tpl, m.x, a.y, &first)) {
      if (v >= match - kTwinMargin) return true;
    }
  }
  return false;
}

}  // namespace

namespace {

// The cell (row-major index) a full-size pixel lies in.
int CellOf(float x, float y, cv::Size size) {
  return std::min(kCellsX - 1, int(x) * kCellsX / size.width) + kCellsX * std::min(kCellsY - 1, int(y) * kCellsY / size.height);
}

// MeasureRowsSparse's samples, from the cells whose index is `phase` modulo `period`.
std::vector<RowSample> TrackRows(const cv::Mat& left_rect, const cv::Mat& right_rect, double expected_disparity_px,
                                 double max_disparity_px, const cv::Mat& valid, int max_corners, int period, int phase) {
  std::vector<RowSample> out;
  if (left_rect.empty() || left_rect.size() != right_rect.size()) return out;
  const cv::Mat gl = Grey(left_rect), gr = Grey(right_rect);
  // Found and tracked at half resolution (a quarter of the pixels; the 16x pyramid's reach is the
  // same), then refined at full resolution, where the precision comes from.
  cv::Mat hl, hr, hvalid;
  cv::pyrDown(gl, hl);
  cv::pyrDown(gr, hr);
  if (!valid.empty()) cv::resize(valid, hvalid, hl.size(), 0, 0, cv::INTER_NEAREST);
  const std::vector<cv::Point2f> corners = SpreadCorners(hl, hvalid, max_corners, period, phase);
  if (corners.empty()) return out;
  const cv::Size win(15, 15);
  const int levels = 3;  // 8x at half size: reaches about 100 px (full size) from the expected disparity
  std::vector<cv::Mat> pl, pr;
  cv::buildOpticalFlowPyramid(hl, pl, win, levels);
  cv::buildOpticalFlowPyramid(hr, pr, win, levels);
  std::vector<cv::Point2f> there(corners.size()), back = corners;
  for (std::size_t i = 0; i < corners.size(); ++i) there[i] = corners[i] - cv::Point2f(float(expected_disparity_px / 2), 0);
  std::vector<unsigned char> ok_there, ok_back;
  std::vector<float> err;
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01);
  cv::calcOpticalFlowPyrLK(pl, pr, corners, there, ok_there, err, win, levels, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  cv::calcOpticalFlowPyrLK(pr, pl, there, back, ok_back, err, win, levels, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
  // Each tracked corner refined at full size in 2-D with the refinement's own window (disparity
  // slopes, gain, offset): pyramidal tracking moves a square window, which a slanted or leafy
  // surface and edge-like texture bias by tenths of a pixel; the 9 x 9 affine window does not.
  // The right view's spline only over a patch about each match (its prefilter forgets the patch's
  // edge within a few pixels), not over the frame.
  constexpr int kLeftHalf = 8, kRightHalf = 16;
  const cv::Rect frame(0, 0, gl.cols, gl.rows);
  std::vector<RowSample> found(corners.size());
  std::vector<char> kept(corners.size(), 0);
  cv::parallel_for_(cv::Range(0, int(corners.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      if (!ok_there[i] || !ok_back[i]) continue;
      if (cv::norm(back[i] - corners[i]) > kRoundTripPx) continue;
      const double d0 = 2.0 * (corners[i].x - there[i].x), dy0 = 2.0 * (there[i].y - corners[i].y);
      if (d0 < -1.0 || d0 > max_disparity_px + 2.0) continue;  // behind the cameras or nearer than searched
      if (HasTwin(hl, hr, corners[i], there[i])) continue;  // a periodic texture: no one match
      const int x = int(std::lround(2 * corners[i].x)), y = int(std::lround(2 * corners[i].y));
      const cv::Rect lroi(x - kLeftHalf, y - kLeftHalf, 2 * kLeftHalf + 1, 2 * kLeftHalf + 1);
      const cv::Rect rroi(int(std::lround(x - d0)) - kRightHalf, int(std::lround(y + dy0)) - kRightHalf,
                          2 * kRightHalf + 1, 2 * kRightHalf + 1);
      if ((lroi & frame) != lroi || (rroi & frame) != rroi) continue;
      const cv::Mat lf = GreyLevels(gl(lroi)), coeffs = BSplineCoefficients2D(GreyLevels(gr(rroi)));
      // In the patches' coordinates: the disparity and the shift move by the patches' offset.
      const int ox = rroi.x - lroi.x, oy = rroi.y - lroi.y;
      double dy = 0, sigma = 0;
      if (!RefineMatch2D(lf, coeffs, kLeftHalf, kLeftHalf, d0 + ox, dy0 - oy, &dy, &sigma) || !(sigma <= kMaxSigmaPx)) {
        continue;
      }
      found[std::size_t(i)] = {float(x), float(y), float(-d0), float(dy + oy)};
      kept[std::size_t(i)] = 1;
    }
  });
  for (std::size_t i = 0; i < corners.size(); ++i) {
    if (kept[i]) out.push_back(found[i]);
  }
  return out;
}

// The rows' plane and each cell's verdict from the samples of a frame of `size`.
RowAgreement SummariseRows(std::vector<RowSample> samples, cv::Size size) {
  RowAgreement out;
  out.samples = std::move(samples);
  out.size = size;
  out.plane = FitPlane(out.samples, size);
  // Each cell's median: where the rows disagree most, and how far from the plane.
  std::vector<std::vector<double>> dy(kCellsX * kCellsY);
  std::vector<cv::Point2d> at(kCellsX * kCellsY);
  for (const RowSample& s : out.samples) {
    const int c = CellOf(s.x, s.y, size);
    dy[std::size_t(c)].push_back(s.dy);
    at[std::size_t(c)] += cv::Point2d(s.x, s.y);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.cell_dy = cv::Mat_<double>(kCellsY, kCellsX, nan);
  out.cell_off_plane = cv::Mat_<double>(kCellsY, kCellsX, nan);
  for (std::size_t c = 0; c < dy.size(); ++c) {
    if (int(dy[c].size()) < kMinCellSamples) continue;
    ++out.cells;
    const double m = Median(dy[c]);
    // A cell says only what its samples pin down: its median less twice the median's standard
    // error (1.25 sigma / sqrt(n), sigma from the MAD), towards 0. A few samples on a noisy, leafy
    // patch scatter by half a pixel; a drift moves them all alike.
    std::vector<double> spread;
    for (const double v : dy[c]) spread.push_back(std::abs(v - m));
    const double se = 1.2533 * 1.4826 * Median(spread) / std::sqrt(double(dy[c].size()));
    auto shrink = [se](double v) { return v > 0 ? std::max(0.0, v - 2 * se) : std::min(0.0, v + 2 * se); };
    const cv::Point2d centre = at[c] * (1.0 / double(dy[c].size()));
    const int cx = int(c) % kCellsX, cy = int(c) / kCellsX;
    out.spoken = out.spoken.empty() ? out.CellRect(cx, cy) : (out.spoken | out.CellRect(cx, cy));
    out.cell_dy(cy, cx) = shrink(m);
    out.max_abs_px = std::max(out.max_abs_px, std::abs(shrink(m)));
    if (out.plane.samples > 0) {
      const double off = shrink(m - out.plane.At(centre.x, centre.y, size));
      out.cell_off_plane(cy, cx) = off;
      out.off_plane_px = std::max(out.off_plane_px, std::abs(off));
    }
  }
  out.plane_max_px = out.PlaneMaxOver(out.spoken);
  return out;
}

}  // namespace

RowAgreement MeasureRowsSparse(const cv::Mat& left_rect, const cv::Mat& right_rect, double expected_disparity_px,
                               double max_disparity_px, const cv::Mat& valid, int max_corners) {
  if (left_rect.empty() || left_rect.size() != right_rect.size()) return RowAgreement();
  return SummariseRows(TrackRows(left_rect, right_rect, expected_disparity_px, max_disparity_px, valid, max_corners, 1, 0),
                       left_rect.size());
}

RowAgreement MeasureRowsRolling(const cv::Mat& left_rect, const cv::Mat& right_rect, double expected_disparity_px,
                                double max_disparity_px, int max_corners, int period, RowPool* pool) {
  if (left_rect.empty() || left_rect.size() != right_rect.size()) return RowAgreement();
  period = std::max(1, period);
  const cv::Size size = left_rect.size();
  if (pool->size != size || int(pool->by_phase.size()) != period) {
    // The first frame (or another size): every cell, filed by the phase that will refresh it.
    pool->size = size;
    pool->by_phase.assign(std::size_t(period), {});
    pool->next = 0;
    for (const RowSample& r :
         TrackRows(left_rect, right_rect, expected_disparity_px, max_disparity_px, cv::Mat(), max_corners, 1, 0)) {
      pool->by_phase[std::size_t(CellOf(r.x, r.y, size) % period)].push_back(r);
    }
  } else {
    pool->by_phase[std::size_t(pool->next)] = TrackRows(left_rect, right_rect, expected_disparity_px, max_disparity_px,
                                                        cv::Mat(), max_corners, period, pool->next);
    pool->next = (pool->next + 1) % period;
  }
  std::vector<RowSample> all;
  for (const auto& phase : pool->by_phase) all.insert(all.end(), phase.begin(), phase.end());
  return SummariseRows(std::move(all), size);
}

double RowAgreement::Around(const cv::Rect& box) const {
  double rows_px = 0;
  const cv::Rect grown(box.x - box.width, box.y - box.height, 3 * box.width, 3 * box.height);
  for (int cy = 0; cy < cell_dy.rows; ++cy) {
    for (int cx = 0; cx < cell_dy.cols; ++cx) {
      if ((CellRect(cx, cy) & grown).empty()) continue;
      if (cell_dy(cy, cx) == cell_dy(cy, cx)) rows_px = std::max(rows_px, std::abs(cell_dy(cy, cx)));
    }
  }
  return rows_px;
}

double RowAgreement::PlaneMaxOver(const cv::Rect& box) const {
  if (plane.samples == 0) return 0;
  const cv::Rect r = spoken.empty() ? box : box.empty() ? spoken : (spoken | box);
  double m = 0;
  for (const cv::Point2d& p : {cv::Point2d(r.x, r.y), cv::Point2d(r.x + r.width, r.y), cv::Point2d(r.x, r.y + r.height),
                               cv::Point2d(r.x + r.width, r.y + r.height)}) {
    m = std::max(m, std::abs(plane.At(p.x, p.y, size)));
  }
  return m;
}

double DisparityErrorField::OffPlane(double u, double v) const {
  if (off_plane.empty() || size.area() == 0) return 0;
  // Cell centres at ((i + 0.5) W / kCellsX, (j + 0.5) H / kCellsY); clamp beyond the outer ones.
  const double gx = std::clamp(u * kCellsX / size.width - 0.5, 0.0, kCellsX - 1.0);
  const double gy = std::clamp(v * kCellsY / size.height - 0.5, 0.0, kCellsY - 1.0);
  const int x0 = std::min(int(gx), kCellsX - 2), y0 = std::min(int(gy), kCellsY - 2);
  const double fx = gx - x0, fy = gy - y0;
  return (1 - fy) * ((1 - fx) * off_plane(y0, x0) + fx * off_plane(y0, x0 + 1)) +
         fy * ((1 - fx) * off_plane(y0 + 1, x0) + fx * off_plane(y0 + 1, x0 + 1));
}

double DisparityErrorField::MeanAbsOver(const cv::Rect& box, double d) const {
  double sum = 0;
  for (int j = 0; j < 9; ++j) {
    for (int i = 0; i < 9; ++i) {
      const double u = box.x + box.width * i / 8.0, v = box.y + box.height * j / 8.0;
      sum += std::abs(Planar(u, v, d)) + ScaleOffset(d) + std::abs(OffPlane(u, v));
    }
  }
  return sum / 81;
}

DisparityErrorField DisparityErrorFromRows(const RowAgreement& rows, double focal_px) {
  DisparityErrorField f;
  f.size = rows.size;
  f.centre = cv::Point2d(0.5 * rows.size.width, 0.5 * rows.size.height);
  if (rows.plane.samples == 0 || rows.size.area() == 0 || !(focal_px > 0)) return f;
  f.roll = rows.plane.slope_x_px / rows.size.width;
  f.scale = rows.plane.slope_y_px / rows.size.height;
  f.cross = rows.plane.offset_px / (focal_px * focal_px);
  f.off_plane = rows.cell_off_plane.clone();
  for (double& v : f.off_plane) {
    if (v != v) v = 0;
  }
  return f;
}

const pipeline::OptionTable<RigCheckOptions>& RigCheckOptions::Table() {
  using O = RigCheckOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("tolerance_px", &O::tolerance_px,
               "rows further apart than this around a hedge, or in the plane through the measured rows, widen the hedge's "
               "interval by what they can cost, with a warning",
               "px")
          .Range(0, 10)
          .Add("unusable_px", &O::unusable_px,
               "rows further apart than this anywhere in the frame: the rig does not fit these cameras, every result "
               "is unusable",
               "px")
          .Range(0, 100)
          .Add("min_matched_share", &O::min_matched_share,
               "a hedge whose matcher measured less than this share of its pixels is unusable")
          .Range(0, 1)
          .Add("corners", &O::corners, "corners tracked over the frame to measure the rows")
          .Range(48, 5000)
          .Add("rolling", &O::rolling,
               "in a warm pipeline (stream, Python), each frame after the first tracks the corners of 1/n of the "
               "frame's cells in turn, and the rows are judged on the last n frames' together (n = 1: every cell "
               "every frame, as a one-shot measure does)", "frames")
          .Range(1, 48);
  return table;
}

void RigCheckOptions::Check() const {
  Table().Validate(*this);
  if (!(unusable_px >= tolerance_px)) throw Error("option 'unusable_px': must be at least 'tolerance_px'");
}

namespace {

cv::Rect HedgeBox(const HedgeMatch& h, const cv::Mat& labels, const cv::Mat& mask, cv::Size size) {
  cv::Rect box;
  if (!labels.empty() && h.id > 0) box = cv::boundingRect(labels == h.id);
  else if (!mask.empty()) box = cv::boundingRect(mask);
  return box.empty() ? cv::Rect(0, 0, size.width, size.height) : box;
}

std::string Format(const char* fmt, double a, double b = 0, double c = 0) {
  char buf[512];
  std::snprintf(buf, sizeof(buf), fmt, a, b, c);
  return buf;
}

}  // namespace

CaptureRigCheck CheckCaptureRig(const cv::Mat& left_rect, const cv::Mat& right_rect, const StereoRig& rig,
                                const std::vector<HedgeMatch>& hedges, const cv::Mat& labels, const cv::Mat& mask,
                                double expected_disparity_px, const RigCheckOptions& o, RowPool* pool) {
  CaptureRigCheck c;
  const cv::Size size = left_rect.size();
  c.rows = pool != nullptr && o.rolling > 1
               ? MeasureRowsRolling(left_rect, right_rect, expected_disparity_px, size.width / 3.0, o.corners, o.rolling, pool)
               : MeasureRowsSparse(left_rect, right_rect, expected_disparity_px, size.width / 3.0, cv::Mat(), o.corners);
  const RowAgreement& rows = c.rows;
  c.field = DisparityErrorFromRows(rows, rig.P1.at<double>(0, 0));
  // A check needs samples spread over a few parts of the frame. A garden of smooth lawn and sky
  // may leave only the hedges and the hedge row: then each hedge is judged on its own rows (the
  // refinement's estimate over it) and its matched share, and says the frame was not checked.
  constexpr int kMinCells = 3, kMinSamples = 30;
  const bool measured = rows.cells >= kMinCells && int(rows.samples.size()) >= kMinSamples;
  const bool frame_apart = measured && rows.max_abs_px > o.unusable_px;
  std::vector<HedgeMatch> all = hedges;
  if (all.empty()) all.push_back(HedgeMatch{});  // a plugin matcher: the capture's verdict only
  int worst = 0;  // 0 ok, 1 widened, 2 unusable, 3 unchecked
  for (const HedgeMatch& h : all) {
    pipeline::InputCheck check;
    const cv::Rect box = HedgeBox(h, labels, mask, size);
    double near_rows = 0;
    if (measured) {
      near_rows = rows.Around(box);
    } else if (h.vertical.samples > 0) {
      near_rows = h.vertical_max_px;
    }
    const double plane_px = measured ? rows.PlaneMaxOver(box) : 0;
    const bool planar = plane_px > o.tolerance_px;
    const double share = h.pixels > 0 ? std::min(1.0, h.Share()) : -1;
    std::string verdict = "ok";
    if (!measured && h.vertical.samples == 0) {
      verdict = "unchecked";
      check.fields.emplace_back("rig_check_reason",
                                Format("too few textured places matched (%.0f parts of the frame, %.0f corners) and the "
                                       "hedge's own rows were not measured",
                                       rows.cells, double(rows.samples.size())));
      check.warning = "the rig could not be checked against this capture: " +
                      std::get<std::string>(check.fields.back().second);
    } else if (frame_apart) {
      verdict = "unusable";
      check.unusable = Format("the rig file does not fit these cameras: the rectified rows are %.1f px apart in this "
                              "capture (over %.1f px; %.1f px of it not a plane: distortion or intrinsics that are not "
                              "these cameras', or the left and right files swapped); recalibrate (hedgefit calibrate) "
                              "or check the rig file (hedgefit check-rig)",
                              rows.max_abs_px, o.unusable_px, rows.off_plane_px);
    } else if (near_rows > o.unusable_px) {
      verdict = "unusable";
      check.unusable = Format("the rectified rows are %.1f px apart around this hedge (over %.1f px, more than the "
                              "matcher can correct): the rig file does not fit these cameras; recalibrate (hedgefit "
                              "calibrate) or check the rig file (hedgefit check-rig)",
                              near_rows, o.unusable_px);
    }
    if (verdict == "ok" && share >= 0 && share < o.min_matched_share) {
      verdict = "unusable";
      // Where the frame's rows were measured and agree, the rig fits these cameras and the views
      // are a pair: what is left is the hedge itself (POV-Ray's holly ball, paper seed 103, matched
      // 30 % of its pixels with the frame's rows 0.17 px apart) or its distance.
      check.unusable =
          measured ? Format("only %.0f %% of the hedge's pixels matched between the views (under %.0f %%), though the "
                            "rectified rows agree across the frame (%.2f px apart), so the rig fits: its leaves look "
                            "different from each camera (glossy leaves, glare), or the hedge lies outside "
                            "--min-z/--max-z",
                            100 * share, 100 * o.min_matched_share, rows.max_abs_px)
                   : Format("only %.0f %% of the hedge's pixels matched between the views (under %.0f %%): the rig "
                            "does not fit these cameras, the views are not a pair, its leaves look different from "
                            "each camera (glossy leaves, glare), or the hedge lies outside --min-z/--max-z",
                            100 * share, 100 * o.min_matched_share);
    }
    if (verdict == "ok" && !measured) {
      // The hedge's own rows agree, but they cover the hedge only: a roll or a focal length that
      // does not fit shows across the frame, and the frame was not measured. Said as such, so a
      // robot (`--strict`) can refuse the result rather than trust it.
      verdict = "unchecked";
      check.fields.emplace_back(
          "rig_check_reason",
          Format("too few textured places matched across the frame (%.0f parts of it, %.0f corners; a check needs 3 "
                 "and 30): only the hedge's own rows were measured (%.2f px apart), which cannot show a rig that "
                 "does not fit away from it",
                 rows.cells, double(rows.samples.size()), near_rows));
      check.warning = "the rig could not be checked against this capture's frame: " +
                      std::get<std::string>(check.fields.back().second);
    }
    if (verdict == "ok" && (planar || near_rows > o.tolerance_px)) {
      verdict = "widened";
      check.warning = Format("the rectified rows are %.2f px apart around this hedge and up to %.2f px in the plane through "
                             "the measured rows (over %.2f px): the rig has drifted since calibration; its interval is "
                             "widened by what that can cost; recalibrate (hedgefit calibrate)",
                             near_rows, plane_px, o.tolerance_px);
    }
    worst = std::max(worst, verdict == "unchecked" ? 3 : verdict == "unusable" ? 2 : verdict == "widened" ? 1 : 0);
    auto round3 = [](double v) { return std::round(v * 1000) / 1000; };
    check.fields.emplace_back("rig_check", verdict);
    check.fields.emplace_back("rig_rows_px", round3(near_rows));
    if (measured) {
      check.fields.emplace_back("rig_rows_frame_px", round3(rows.max_abs_px));
      check.fields.emplace_back("rig_rows_plane_px", round3(plane_px));
      check.fields.emplace_back("rig_rows_off_plane_px", round3(rows.off_plane_px));
    }
    if (h.vertical.samples > 0) check.fields.emplace_back("rig_rows_hedge_px", round3(h.vertical_max_px));
    if (share >= 0) check.fields.emplace_back("rig_matched_share", round3(share));
    if (verdict == "widened") {
      check.fields.emplace_back("rig_widening_px", round3(c.field.MeanAbsOver(box, expected_disparity_px)));
    }
    c.checks[h.id] = check;
  }
  c.verdict = worst == 3 ? "unchecked" : worst == 2 ? "unusable" : worst == 1 ? "widened" : "ok";
  return c;
}

}  // namespace hedgefit::stereo
