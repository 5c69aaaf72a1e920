#include "stereo/matching.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/LU>
#include <Eigen/QR>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define HEDGEFIT_HAVE_AVX512_REFINE 1
#endif

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <mutex>
#include <vector>

#include "pipeline/error.hpp"
#include "pipeline/parallel.hpp"
#include "stereo/bspline.hpp"
#include "stereo/ldlt5.hpp"

namespace hedgefit::stereo {

const pipeline::OptionTable<SgbmOptions>& SgbmOptions::Table() {
  using O = SgbmOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .AddEnum("mode", &O::mode,
                   {{"hh", SgbmMode::kHh8}, {"sgbm", SgbmMode::kSgbm5}, {"3way", SgbmMode::kSgbm3Way}, {"hh4", SgbmMode::kHh4}},
                   "paths: hh (8), sgbm (5), 3way, hh4")
          .Add("block_size", &O::block_size, "matching block, odd", "px").Range(1, 31)
          .Add("p1", &O::p1, "smoothness penalty, 0 = 8 * channels * block^2").Min(0)
          .Add("p2", &O::p2, "smoothness penalty, 0 = 32 * channels * block^2").Min(0)
          .Add("uniqueness", &O::uniqueness_ratio, "uniqueness ratio", "%").Range(0, 100)
          .Add("lrc_tolerance", &O::lrc_tolerance_px, "left-right check tolerance; < 0 turns it off", "px")
          .Add("fill_holes", &O::fill_holes, "fill rejected pixels from the background side")
          .Add("bilateral_sigma", &O::bilateral_sigma_disp, "bilateral range sigma (the paper uses ~1.5); 0 = off", "px")
          .Min(0)
          .Add("bilateral_sigma_space", &O::bilateral_sigma_space, "bilateral spatial sigma", "px").Min(0)
          .Add("refine_radius", &O::refine_radius,
               "sub-pixel refinement window half-size (slanted window, masked); 0 = off", "px")
          .Range(0, 15)
          .Add("refine_max_radius", &O::refine_max_radius,
               "a pixel the refine_radius window does not pin to refine_retry_sigma is tried with this one (0 = never)",
               "px")
          .Range(0, 15)
          .Add("refine_retry_sigma", &O::refine_retry_sigma_px,
               "below this standard deviation the refine_radius window's estimate is kept", "px")
          .Min(0)
          .Add("refine_iterations", &O::refine_iterations, "Gauss-Newton steps per pixel").Range(1, 50)
          .Add("refine_max_sigma", &O::refine_max_sigma_px,
               "a refined value whose standard deviation is larger is not used", "px")
          .Min(1e-6)
          .Add("refine_drop_uncertain", &O::refine_drop_uncertain,
               "drop pixels the refinement cannot settle (else keep SGBM's value, biased far on a dome)")
          .Add("refine_curvature", &O::refine_curvature,
               "correct each refined disparity for the surface's curvature, fitted on a (2 n + 1)^2 grid of refined "
               "values every 2 px (or every thinning stride) about it; 0 = off")
          .Range(0, 10)
          .Add("half_res_from_stride", &O::half_res_from_stride,
               "when max_points thins a hedge to every s-th pixel with s at least this, SGBM runs at half resolution "
               "and the refinement at full; 0 = never")
          .Range(0, 1000)
          .Add("correct_vertical", &O::correct_vertical,
               "estimate the pair's residual vertical disparity (rectification error) and remove it before the "
               "refinement")
          .Add("correct_vertical_min", &O::correct_vertical_min_px,
               "a residual vertical disparity smaller than this everywhere is left alone", "px")
          .Min(0);
  return table;
}

void SgbmOptions::Check() const {
  Table().Validate(*this);
  if (num_disparities < 1) throw Error("num_disparities: must be >= 1 px");
  if (block_size % 2 == 0) throw Error("option 'block_size': must be odd (1, 3, 5, ... 31 px)");
  if (p2 > 0 && p2 <= p1) throw Error("option 'p1'/'p2': need p1 < p2 (0 = automatic)");
}

void CheckNearestDepth(double focal_px, double baseline_mm, double min_z_mm, int width_px) {
  // SGBM's search, its block and the range's rounding up to 16 must fit in the row.
  constexpr int kSlackPx = 32;
  const double needed = focal_px * baseline_mm / min_z_mm;
  if (!(min_z_mm > 0) || needed + kSlackPx < width_px) return;
  const double nearest = focal_px * baseline_mm / std::max(1.0, double(width_px - kSlackPx));
  char buf[320];
  std::snprintf(buf, sizeof(buf),
                "min_z %g mm (--min-z) needs a disparity of %.0f px; the nearest this rig can match in a %d px wide "
                "image is %.0f mm; raise it to the nearest depth of the scene (min_z is in mm)",
                min_z_mm, needed, width_px, std::ceil(nearest));
  throw InputError(buf);
}

void DisparityRangeForDepth(double focal_px, double baseline_mm, double min_z_mm, double max_z_mm, int* min_disparity,
                            int* num_disparities) {
  CheckDepthRange(min_z_mm, max_z_mm);
  const double d_max = focal_px * baseline_mm / min_z_mm, d_min = focal_px * baseline_mm / max_z_mm;
  *min_disparity = std::max(0, static_cast<int>(std::floor(d_min)) - 2);
  const int span = static_cast<int>(std::ceil(d_max)) + 2 - *min_disparity;
  *num_disparities = ((span + 15) / 16) * 16;
}

int FillHolesFromBackground(cv::Mat* disparity) {
  int filled = 0;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < disparity->rows; ++y) {
    float* row = disparity->ptr<float>(y);
    const int w = disparity->cols;
    std::vector<float> left(static_cast<std::size_t>(w), nan), right(static_cast<std::size_t>(w), nan);
    float last = nan;
    for (int x = 0; x < w; ++x) {
      if (!std::isnan(row[x])) last = row[x];
      left[std::size_t(x)] = last;
    }
    last = nan;
    for (int x = w - 1; x >= 0; --x) {
      if (!std::isnan(row[x])) last = row[x];
      right[std::size_t(x)] = last;
    }
    for (int x = 0; x < w; ++x) {
      if (!std::isnan(row[x])) continue;
      const float a = left[std::size_t(x)], b = right[std::size_t(x)];
      // Occluded pixels belong to the farther surface: the smaller disparity.
      const float v = std::isnan(a) ? b : std::isnan(b) ? a : std::min(a, b);
      if (!std::isnan(v)) {
        row[x] = v;
        ++filled;
      }
    }
  }
  return filled;
}

namespace {

cv::Mat GreyFloat(const cv::Mat& img) {
  cv::Mat grey, f;
  if (img.channels() == 3) {
    cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  } else {
    grey = img;
  }
  grey.convertTo(f, CV_32F);
  return f;
}

// The 2-D cubic B-spline of `coeffs` at (x, y): value and both derivatives; false outside.
bool SampleBSpline2D(const cv::Mat& coeffs, double x, double y, double* v, double* vx, double* vy) {
  const int ix = FloorInt(x), iy = FloorInt(y);
  if (ix < 1 || iy < 1 || ix + 2 >= coeffs.cols || iy + 2 >= coeffs.rows) return false;
  double wx[4], dwx[4], wy[4], dwy[4];
  BSplineWeights(x - ix, wx, dwx);
  BSplineWeights(y - iy, wy, dwy);
  double s = 0, sx = 0, sy = 0;
  for (int j = 0; j < 4; ++j) {
    const float* row = coeffs.ptr<float>(iy - 1 + j) + (ix - 1);
    double r = 0, rx = 0;
    for (int i = 0; i < 4; ++i) r += wx[i] * row[i], rx += dwx[i] * row[i];
    s += wy[j] * r, sx += wy[j] * rx, sy += dwy[j] * r;
  }
  *v = s, *vx = sx, *vy = sy;
  return true;
}

// Gauss-Newton for one window about (x, y): disparity, its slopes, a vertical shift, gain and
// offset. True with the shift and its standard deviation when it settles.
bool SolveVerticalWindow(const cv::Mat& L, const cv::Mat& C, const cv::Mat& mask, int x, int y, double d0, int r,
                         double* dy_out, double* sigma_out, double dy0 = 0) {
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  Vec6 q;
  q << d0, 0, 0, dy0, 0, 0;
  const int side = 2 * r + 1;
  for (int it = 0; it < 8; ++it) {
    Mat6 H = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    double ssr = 0;
    int used = 0;
    for (int j = -r; j <= r; ++j) {
      if (y + j < 0 || y + j >= L.rows) continue;
      const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y + j);
      const float* lrow = L.ptr<float>(y + j);
      for (int i = -r; i <= r; ++i) {
        if (x + i < 0 || x + i >= L.cols || (m && m[x + i] == 0)) continue;
        double v = 0, vx = 0, vy = 0;
        if (!SampleBSpline2D(C, x + i - (q[0] + q[1] * i + q[2] * j), y + j + q[3], &v, &vx, &vy)) continue;
        const double res = lrow[x + i] - (1 + q[4]) * v - q[5];
        const double gx = (1 + q[4]) * vx;
        Vec6 J;
        J << gx, gx * i, gx * j, -(1 + q[4]) * vy, -v, -1.0;
        // H += J J^T on the upper triangle, as Eigen's rankUpdate forms it (each term J_c J_r).
        for (int c = 0; c < 6; ++c) {
          for (int k = 0; k <= c; ++k) H(k, c) += J[c] * J[k];
        }
        g -= J * res;
        ssr += res * res;
        ++used;
      }
    }
    if (used < (side * side * 3) / 5) return false;
    H = H.selfadjointView<Eigen::Upper>();
    const Eigen::LDLT<Mat6> ldlt(H);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
    const Vec6 step = ldlt.solve(g);
    q += step;
    if (!q.allFinite() || std::abs(q[0] - d0) > 1.0 || std::abs(q[3] - dy0) > 2.0) return false;
    if (std::abs(step[0]) < 1e-3 && std::abs(step[3]) < 1e-3) {
      *dy_out = q[3];
      *sigma_out = std::sqrt(ssr / std::max(1, used - 6) * ldlt.solve(Vec6::Unit(3))[3]);
      return true;
    }
  }
  return false;
}

// EstimateVerticalDisparity on the left view's grey levels `L` and the right view's 2-D spline
// coefficients `C`.
VerticalDisparity EstimateVerticalDisparityFloat(const cv::Mat& L, const cv::Mat& C, const cv::Mat& disparity,
                                                 const cv::Mat& mask) {
  constexpr int kRadius = 4, kMinSamples = 30;
  constexpr double kMaxSigmaPx = 0.1;
  // About 400 windows over the known pixels, at most one per 8 x 8 block: a window settles to
  // 0.02-0.05 px on real pairs, so the plane's standard error is ~0.003 px, far below
  // correct_vertical_min.
  const int known = cv::countNonZero(disparity == disparity);
  const int step = std::max(8, static_cast<int>(std::sqrt(known / 400.0)));
  struct Sample {
    double x, y, dy;
  };
  std::vector<Sample> samples;
  std::mutex lock;
  const int grid_rows = (L.rows - 2 * kRadius + step - 1) / step;
  cv::parallel_for_(cv::Range(0, std::max(0, grid_rows)), [&](const cv::Range& range) {
    std::vector<Sample> local;
    for (int k = range.start; k < range.end; ++k) {
      const int y = kRadius + k * step;
      const float* drow = disparity.ptr<float>(y);
      const std::uint8_t* mrow = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
      for (int x = kRadius; x + kRadius < L.cols; x += step) {
        if (!std::isfinite(drow[x]) || (mrow && mrow[x] == 0)) continue;
        double dy = 0, sigma = 0;
        if (SolveVerticalWindow(L, C, mask, x, y, drow[x], kRadius, &dy, &sigma) && sigma <= kMaxSigmaPx) {
          local.push_back({double(x), double(y), dy});
        }
      }
    }
    const std::lock_guard<std::mutex> guard(lock);
    samples.insert(samples.end(), local.begin(), local.end());
  });
  // The threads finish in any order: sorted, the fit is the same on every run.
  std::sort(samples.begin(), samples.end(), [](const Sample& a, const Sample& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
  VerticalDisparity out;
  if (int(samples.size()) < kMinSamples) return out;
  // A plane in (x, y), least squares on the samples within 3 MADs of the last fit (mismatches,
  // occlusion edges and repeated texture give the outliers).
  const cv::Size size = L.size();
  std::vector<bool> inlier(samples.size(), true);
  for (int round = 0; round < 4; ++round) {
    Eigen::MatrixXd A(samples.size(), 3);
    Eigen::VectorXd b(samples.size());
    int n = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (!inlier[i]) continue;
      A.row(n) << 1, (samples[i].x - 0.5 * size.width) / size.width, (samples[i].y - 0.5 * size.height) / size.height;
      b[n++] = samples[i].dy;
    }
    if (n < kMinSamples) return VerticalDisparity();
    const Eigen::Vector3d c = A.topRows(n).colPivHouseholderQr().solve(b.head(n));
    out.offset_px = c[0], out.slope_x_px = c[1], out.slope_y_px = c[2], out.samples = n;
    std::vector<double> residual(samples.size());
    for (std::size_t i = 0; i < samples.size(); ++i) {
      residual[i] = std::abs(samples[i].dy - out.At(samples[i].x, samples[i].y, size));
    }
    std::vector<double> sorted = residual;
    std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
    const double mad = 1.4826 * sorted[sorted.size() / 2];
    for (std::size_t i = 0; i < samples.size(); ++i) inlier[i] = residual[i] <= 3 * std::max(mad, 0.01);
  }
  return out;
}

// The right view's grey levels at (x, y + v.At(x, y)): the vertical disparity removed. `grey`
// is the view, `coeffs` its 2-D spline; pixels whose spline support leaves the image (the
// outer two rows and columns) keep their value.
//
// Every sample lies on a whole column, where the cubic B-spline's weights along the row are
// BSplineWeights(0) = (1/6, 4/6, 1/6, 0) for every pixel, and only the value is wanted: this is
// SampleBSpline2D's value, operation for operation in its order, without the derivatives it
// also forms; VerticalDisparity::At's column and row terms (each a division) are taken from a
// table and once per row, and added in At's order. The same bits as sampling through
// SampleBSpline2D and At, which it replaced.
cv::Mat ShiftRows(const cv::Mat& grey, const cv::Mat& coeffs, const VerticalDisparity& v) {
  cv::Mat out = grey.clone();
  double wx[4];
  BSplineWeights(0.0, wx, nullptr);
  const cv::Size size = coeffs.size();
  std::vector<double> column_term(std::size_t(std::max(0, coeffs.cols)));
  for (int x = 0; x < coeffs.cols; ++x) {
    column_term[std::size_t(x)] = v.slope_x_px * (double(x) - 0.5 * size.width) / size.width;
  }
  cv::parallel_for_(cv::Range(0, coeffs.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      float* o = out.ptr<float>(y);
      const double row_term = v.slope_y_px * (double(y) - 0.5 * size.height) / size.height;
      for (int x = 1; x + 2 < coeffs.cols; ++x) {
        const double at = y + (v.offset_px + column_term[std::size_t(x)] + row_term);
        const int iy = FloorInt(at);
        if (iy < 1 || iy + 2 >= coeffs.rows) continue;
        double wy[4];
        BSplineWeights(at - iy, wy, nullptr);
        double s = 0;
        for (int j = 0; j < 4; ++j) {
          const float* row = coeffs.ptr<float>(iy - 1 + j) + (x - 1);
          double r = 0;
          for (int i = 0; i < 4; ++i) r += wx[i] * row[i];
          s += wy[j] * r;
        }
        o[x] = static_cast<float>(s);
      }
    }
  });
  return out;
}

}  // namespace

cv::Mat GreyLevels(const cv::Mat& image) { return GreyFloat(image); }

bool RefineMatch2D(const cv::Mat& left_grey, const cv::Mat& right_coeffs, int x, int y, double disparity_px,
                   double dy_px, double* dy_out, double* sigma_out) {
  return SolveVerticalWindow(left_grey, right_coeffs, cv::Mat(), x, y, disparity_px, 4, dy_out, sigma_out, dy_px);
}

void CheckDepthRange(double min_z_mm, double max_z_mm) {
  char buf[320];
  // A depth typed in metres (3.5 for 3500 mm) is the usual cause: say the unit, and the value it
  // likely meant.
  auto hint = [](double v) {
    char h[96] = "";
    if (v > 0 && v < 100) std::snprintf(h, sizeof(h), "; depths are in mm (%g for %g m)", v * 1000, v);
    return std::string(h);
  };
  if (!(min_z_mm > 0)) {
    std::snprintf(buf, sizeof(buf), "option 'min_z': %g mm; give the nearest depth to search, in mm, above 0", min_z_mm);
    throw Error(buf);
  }
  if (!(max_z_mm > min_z_mm)) {
    std::snprintf(buf, sizeof(buf), "option 'max_z': %g mm is not beyond option 'min_z' (%g mm)%s", max_z_mm, min_z_mm,
                  hint(max_z_mm).c_str());
    throw Error(buf);
  }
}

double VerticalDisparity::MaxAbs(cv::Size size) const {
  double m = 0;
  for (const double x : {0.0, double(size.width)}) {
    for (const double y : {0.0, double(size.height)}) m = std::max(m, std::abs(At(x, y, size)));
  }
  return m;
}

VerticalDisparity EstimateVerticalDisparity(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity,
                                            const cv::Mat& mask) {
  return EstimateVerticalDisparityFloat(GreyFloat(left), BSplineCoefficients2D(GreyFloat(right)), disparity, mask);
}

namespace {

// How far a pixel's refined disparity may be moved for the curvature of the surface about it. On
// the lab's real-camera spheres 99 % of the corrections are below 0.1 px and 0.04 % (hedgefit's
// renders; POV-Ray's none) above 0.2 px; a quadratic that asks for more is fitted across an edge,
// a leaf or noise, and then says nothing about the window's own surface.
constexpr double kMaxCurvatureCorrectionPx = 0.2;
// Neighbours whose refined disparities differ from the pixel's by more than this lie on another
// surface (a leaf in front, the background), not on the one whose curvature is wanted.
constexpr float kCurvatureSameSurfacePx = 3.0f;

// Removes from each refined disparity what the curvature of the disparity surface did to its
// affine window's estimate. `gain` (CV_32FC3) holds, per refined pixel, how far the window's
// estimate moves per unit of each quadratic coefficient (u^2, u v, v^2 in px); NaN elsewhere.
// The coefficients come from a quadratic fitted to the refined disparities on a (2 c + 1)^2 grid
// of `step_px` about the pixel. Their own curvature biases agree to first order with the pixel's
// and go into the quadratic's constant, so the curvature is read without that bias.
void CorrectCurvature(const cv::Mat& gain, int c, int step_px, cv::Mat* disparity) {
  // The refined disparities alone (NaN elsewhere), so a neighbour costs one load.
  cv::Mat before(disparity->size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int y = 0; y < before.rows; ++y) {
    const float* d = disparity->ptr<float>(y);
    const cv::Vec3f* g = gain.ptr<cv::Vec3f>(y);
    float* b = before.ptr<float>(y);
    for (int x = 0; x < before.cols; ++x) {
      if (std::isfinite(g[x][0])) b[x] = d[x];
    }
  }
  const int side = 2 * c + 1, w = before.cols, h = before.rows;
  using Basis = Eigen::Matrix<double, 6, 1>;
  auto basis = [&](int i, int j) {
    const double u = double(i) * step_px, v = double(j) * step_px;
    Basis b;
    b << 1, u, v, u * u, u * v, v * v;
    return b;
  };
  // With every grid neighbour known (the common case inside a surface) the quadratic's three
  // curvature terms are fixed weightings of the differences (2-D Savitzky-Golay kernels).
  Eigen::Matrix<double, 6, 6> full = Eigen::Matrix<double, 6, 6>::Zero();
  for (int j = -c; j <= c; ++j) {
    for (int i = -c; i <= c; ++i) full += basis(i, j) * basis(i, j).transpose();
  }
  const Eigen::Matrix<double, 6, 6> full_inverse = full.inverse();
  std::vector<std::array<float, 3>> kernel(std::size_t(side * side));
  // Per grid point its basis and the upper triangle of its outer product (21 terms), so a pixel
  // whose neighbourhood has gaps sums its normal equations without a multiplication.
  std::vector<Basis> bases(std::size_t(side * side));
  std::vector<std::array<double, 21>> outer(std::size_t(side * side));
  for (int j = -c, k = 0; j <= c; ++j) {
    for (int i = -c; i <= c; ++i, ++k) {
      const Basis b = basis(i, j);
      const Eigen::Vector3d kk = (full_inverse * b).tail<3>();
      kernel[std::size_t(k)] = {float(kk[0]), float(kk[1]), float(kk[2])};
      bases[std::size_t(k)] = b;
      for (int a = 0, t = 0; a < 6; ++a) {
        for (int e = a; e < 6; ++e, ++t) outer[std::size_t(k)][std::size_t(t)] = b[a] * b[e];
      }
    }
  }
  std::array<double, 21> full_upper{};
  for (const auto& o : outer) {
    for (std::size_t t = 0; t < 21; ++t) full_upper[t] += o[t];
  }
  // Half the grid, and at least the whole 3 x 3 grid: 6 unknowns need some redundancy.
  const int min_neighbours = std::max(9, side * side / 2);
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    struct Known {
      int k;       // grid index
      float diff;  // the neighbour's disparity less the pixel's, px
    };
    std::vector<Known> known;
    std::vector<int> missing;
    known.reserve(std::size_t(side * side));
    missing.reserve(std::size_t(side * side));
    for (int y = rows.start; y < rows.end; ++y) {
      const cv::Vec3f* grow = gain.ptr<cv::Vec3f>(y);
      for (int x = 0; x < w; ++x) {
        const cv::Vec3f g = grow[x];
        if (!std::isfinite(g[0])) continue;
        const float dc = before.at<float>(y, x);
        known.clear();
        missing.clear();
        float q0 = 0, q1 = 0, q2 = 0;  // the full grid's curvature terms, summed as we go
        for (int j = -c, k = 0; j <= c; ++j) {
          const int yy = y + j * step_px;
          if (yy < 0 || yy >= h) {
            for (int i = 0; i < side; ++i, ++k) missing.push_back(k);
            continue;
          }
          const float* brow = before.ptr<float>(yy);
          for (int i = -c; i <= c; ++i, ++k) {
            const int xx = x + i * step_px;
            const float diff = xx >= 0 && xx < w ? brow[xx] - dc : std::numeric_limits<float>::quiet_NaN();
            if (std::abs(diff) <= kCurvatureSameSurfacePx) {  // NaN (not refined) fails the test
              known.push_back({k, diff});
              const auto& kk = kernel[std::size_t(k)];
              q0 += kk[0] * diff, q1 += kk[1] * diff, q2 += kk[2] * diff;
            } else {
              missing.push_back(k);
            }
          }
        }
        if (int(known.size()) < min_neighbours) continue;
        Eigen::Vector3d p(q0, q1, q2);
        if (!missing.empty()) {
          // The normal equations of the grid less its missing points (fewer to remove than to add).
          std::array<double, 21> upper = full_upper;
          for (const int k : missing) {
            const auto& o = outer[std::size_t(k)];
            for (std::size_t t = 0; t < 21; ++t) upper[t] -= o[t];
          }
          Basis rhs = Basis::Zero();
          for (const Known& n : known) rhs += bases[std::size_t(n.k)] * double(n.diff);
          Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
          for (int a = 0, t = 0; a < 6; ++a) {
            for (int e = a; e < 6; ++e, ++t) A(a, e) = upper[std::size_t(t)];
          }
          const Eigen::LDLT<Eigen::Matrix<double, 6, 6>, Eigen::Upper> ldlt(A);
          if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) continue;
          p = ldlt.solve(rhs).tail<3>();
        }
        const double fix = p[0] * g[0] + p[1] * g[1] + p[2] * g[2];
        if (std::isfinite(fix) && std::abs(fix) <= kMaxCurvatureCorrectionPx) {
          disparity->at<float>(y, x) = static_cast<float>(dc - fix);
        }
      }
    }
  });
}

}  // namespace

namespace {

// Set by ForcePortableRefinement: the refinement's 4-lane sums even where AVX-512 would do 16.
bool g_force_portable_refine = false;

// Gauss-Newton in a (2r+1)^2 window about (x, y) from SGBM's d0: true and the estimate and its
// standard deviation when it settles. One per worker: it keeps the window's samples.
//
// Each sample's terms are single precision, four samples at a time (OpenCV's universal
// intrinsics: SSE2 on baseline x86-64, NEON on ARM), and summed in four lanes; the sums, the
// solve and everything after them are double. Single precision carries the grey levels (8-bit
// images, so 24 bits hold them and their spline coefficients with room to spare) and each
// sample's position within its window; the window's place in the image stays double, so no
// precision is lost with the column's size.
class WindowRefiner {
 public:
  WindowRefiner(const cv::Mat& L, const cv::Mat& R, const cv::Mat& mask, int iterations, bool curvature,
                double max_sigma_px, int max_radius)
      : L_(L), R_(R), mask_(mask), iterations_(iterations), curvature_(curvature), max_sigma_px_(max_sigma_px) {
    const std::size_t n = std::size_t((2 * max_radius + 1) * (2 * max_radius + 1)) + 4;
    // Room for the largest window and its padding to a whole number of 16 samples.
    di_.resize(n + 15), dj_.resize(n + 15), left_.resize(n + 15), live_.resize(n + 15), rows_.resize(n + 15);
    offsets_.resize(n + 15);
#ifdef HEDGEFIT_HAVE_AVX512_REFINE
    wide_ = !g_force_portable_refine && __builtin_cpu_supports("avx512f");
#endif
  }
  bool Solve(int x, int y, float d0, int r, double* d_out, double* sigma_out_px, cv::Vec3f* gain_out);

 private:
  // The normal equations' sums over the window at parameters q (the upper triangle of J J^T, 15
  // sums, and -J res), the residuals' square sum, the samples used and, with `respond`, vq[t] =
  // J^T (gv m_t): the window's response to the quadratic term m_t = u^2, u v, v^2 (a surface bent
  // by k_t m_t leaves the residuals -gv k_t m_t, which the step takes in as H^-1 J^T (gv m_t) k_t).
  struct Sums {
    double hs[15], g[5], vq[3][5], ssr;
    int used;
  };
  Sums Accumulate(int x, const Eigen::Matrix<double, 5, 1>& q, bool respond) const;
#ifdef HEDGEFIT_HAVE_AVX512_REFINE
  Sums Accumulate16(int x, const Eigen::Matrix<double, 5, 1>& q, bool respond) const;
#endif

  const cv::Mat& L_;
  const cv::Mat& R_;
  const cv::Mat& mask_;
  int iterations_;
  bool curvature_;
  double max_sigma_px_;
  // The window's samples, structure of arrays, padded to a multiple of 4 (16 with AVX-512) with
  // dead ones: the first `samples_` of each.
  int samples_ = 0;
  std::vector<float> di_, dj_, left_, live_;
  std::vector<const float*> rows_;
  // With AVX-512: 16 samples at a time, each sample's row as its offset in floats from R's first.
  std::vector<std::int32_t> offsets_;
  bool wide_ = false;
};

WindowRefiner::Sums WindowRefiner::Accumulate(int x, const Eigen::Matrix<double, 5, 1>& q, bool respond) const {
  const int w = L_.cols;
  static const float kZeros[4] = {0, 0, 0, 0};
  using V = cv::v_float32x4;
  const V sixth = cv::v_setall_f32(1.f / 6), half = cv::v_setall_f32(0.5f), one = cv::v_setall_f32(1.f),
          two = cv::v_setall_f32(2.f), three = cv::v_setall_f32(3.f), zero = cv::v_setzero_f32();
  V hs[15], g[5], vq[3][5], ssr = zero, used = zero;
  for (V& v : hs) v = zero;
  for (V& v : g) v = zero;
  for (auto& t : vq) {
    for (V& v : t) v = zero;
  }
  // Sample (di, dj) is read in the right view at x + di - (d + sx di + sy dj): the window's
  // column x - d, double, split into a whole column and a fraction, plus each sample's offset.
  const double base = x - q[0], whole = std::floor(base);
  const int column = int(whole);
  const V fraction = cv::v_setall_f32(float(base - whole)), sx = cv::v_setall_f32(float(q[1])),
          sy = cv::v_setall_f32(float(q[2])), gain = cv::v_setall_f32(float(1 + q[3])),
          offset = cv::v_setall_f32(float(q[4]));
  for (int k = 0; k < samples_; k += 4) {
    const V vdi = cv::v_load(&di_[std::size_t(k)]), vdj = cv::v_load(&dj_[std::size_t(k)]);
    V live = cv::v_load(&live_[std::size_t(k)]);
    const V at = fraction + vdi - sx * vdi - sy * vdj;
    const cv::v_int32x4 floor_at = cv::v_floor(at);
    const V t = at - cv::v_cvt_f32(floor_at);
    int shift[4];
    cv::v_store(shift, floor_at);
    float alive[4];
    cv::v_store(alive, live);
    V tap[4];
    for (int l = 0; l < 4; ++l) {
      const int x0 = column + shift[l];
      const bool inside = alive[l] != 0.f && x0 >= 1 && x0 + 2 < w;
      if (!inside) alive[l] = 0.f;
      tap[l] = cv::v_load(inside ? rows_[std::size_t(k + l)] + (x0 - 1) : kZeros);
    }
    live = cv::v_load(alive);
    V c0, c1, c2, c3;  // lane l: sample k + l's four coefficients
    cv::v_transpose4x4(tap[0], tap[1], tap[2], tap[3], c0, c1, c2, c3);
    const V t2 = t * t, t3 = t2 * t, u = one - t;
    const V w0 = u * u * u * sixth, w1 = (three * t3 - (two + two + two) * t2 + (two + two)) * sixth,
            w2 = (three * (t2 - t3 + t) + one) * sixth, w3 = t3 * sixth;
    const V dw0 = zero - half * u * u, dw1 = (three * half) * t2 - two * t, dw2 = t - (three * half) * t2 + half,
            dw3 = half * t2;
    const V rv = (w0 * c0 + w1 * c1 + w2 * c2 + w3 * c3) * live;
    const V gv = gain * (dw0 * c0 + dw1 * c1 + dw2 * c2 + dw3 * c3) * live;
    const V res = (cv::v_load(&left_[std::size_t(k)]) - gain * rv - offset) * live;
    const V J[5] = {gv, gv * vdi, gv * vdj, zero - rv, zero - live};
    for (int a = 0, m = 0; a < 5; ++a) {
      g[a] = g[a] - J[a] * res;
      for (int c = a; c < 5; ++c, ++m) hs[m] = cv::v_muladd(J[a], J[c], hs[m]);
    }
    if (respond) {
      const V mt[3] = {vdi * vdi, vdi * vdj, vdj * vdj};
      for (int tq = 0; tq < 3; ++tq) {
        const V gm = gv * mt[tq];
        for (int a = 0; a < 5; ++a) vq[tq][a] = cv::v_muladd(J[a], gm, vq[tq][a]);
      }
    }
    ssr = cv::v_muladd(res, res, ssr);
    used = used + live;
  }
  Sums out{};
  for (int m = 0; m < 15; ++m) out.hs[m] = double(cv::v_reduce_sum(hs[m]));
  for (int a = 0; a < 5; ++a) {
    out.g[a] = double(cv::v_reduce_sum(g[a]));
    for (int tq = 0; respond && tq < 3; ++tq) out.vq[tq][a] = double(cv::v_reduce_sum(vq[tq][a]));
  }
  out.ssr = double(cv::v_reduce_sum(ssr));
  out.used = int(std::lround(cv::v_reduce_sum(used)));
  return out;
}

#ifdef HEDGEFIT_HAVE_AVX512_REFINE
// GCC 12 reports its own intrinsics' deliberately undefined lanes as "maybe uninitialized".
#pragma GCC diagnostic push
#if !defined(__clang__)  // clang (the fuzz build) has no such group and warns about the name
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#pragma GCC diagnostic ignored "-Wuninitialized"
// Accumulate, 16 samples at a time: the same terms in the same single precision, the four taps
// gathered by each sample's row offset (a sample off the row or dead gathers nothing and counts
// 0), and the products fused. The lanes' sums add in another order than Accumulate's four, so
// the two differ in the last bits of the sums (a test bounds how far the refined disparities
// move: bits of float rounding, not of the estimate).
__attribute__((target("avx512f"))) WindowRefiner::Sums WindowRefiner::Accumulate16(
    int x, const Eigen::Matrix<double, 5, 1>& q, bool respond) const {
  const int w = L_.cols;
  const float* r0 = R_.ptr<float>(0);
  const __m512 zero = _mm512_setzero_ps(), one = _mm512_set1_ps(1.f), sixth = _mm512_set1_ps(1.f / 6),
               half = _mm512_set1_ps(0.5f), two = _mm512_set1_ps(2.f), three = _mm512_set1_ps(3.f),
               four = _mm512_set1_ps(4.f), six = _mm512_set1_ps(6.f), three_halves = _mm512_set1_ps(1.5f);
  __m512 hs[15], g[5], vq[3][5], ssr = zero, used = zero;
  for (__m512& v : hs) v = zero;
  for (__m512& v : g) v = zero;
  for (auto& t : vq) {
    for (__m512& v : t) v = zero;
  }
  const double base = x - q[0], whole = std::floor(base);
  const int column = int(whole);
  const __m512 fraction = _mm512_set1_ps(float(base - whole)), sx = _mm512_set1_ps(float(q[1])),
               sy = _mm512_set1_ps(float(q[2])), gain = _mm512_set1_ps(float(1 + q[3])),
               offset = _mm512_set1_ps(float(q[4]));
  const __m512i vcolumn = _mm512_set1_epi32(column), lo = _mm512_set1_epi32(1), hi = _mm512_set1_epi32(w - 2);
  for (int k = 0; k < samples_; k += 16) {
    const __m512 vdi = _mm512_loadu_ps(&di_[std::size_t(k)]), vdj = _mm512_loadu_ps(&dj_[std::size_t(k)]);
    const __m512 at = _mm512_sub_ps(_mm512_sub_ps(_mm512_add_ps(fraction, vdi), _mm512_mul_ps(sx, vdi)),
                                    _mm512_mul_ps(sy, vdj));
    const __m512i floor_at = _mm512_cvt_roundps_epi32(at, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    const __m512 t = _mm512_sub_ps(at, _mm512_cvtepi32_ps(floor_at));
    const __m512i x0 = _mm512_add_epi32(vcolumn, floor_at);
    const __mmask16 inside = _mm512_cmpneq_ps_mask(_mm512_loadu_ps(&live_[std::size_t(k)]), zero) &
                             _mm512_cmpge_epi32_mask(x0, lo) & _mm512_cmplt_epi32_mask(x0, hi);
    const __m512i at0 = _mm512_add_epi32(_mm512_loadu_si512(&offsets_[std::size_t(k)]), _mm512_sub_epi32(x0, lo));
    const __m512 c0 = _mm512_mask_i32gather_ps(zero, inside, at0, r0, 4);
    const __m512 c1 = _mm512_mask_i32gather_ps(zero, inside, _mm512_add_epi32(at0, lo), r0, 4);
    const __m512 c2 = _mm512_mask_i32gather_ps(zero, inside, _mm512_add_epi32(at0, _mm512_set1_epi32(2)), r0, 4);
    const __m512 c3 = _mm512_mask_i32gather_ps(zero, inside, _mm512_add_epi32(at0, _mm512_set1_epi32(3)), r0, 4);
    const __m512 live = _mm512_mask_mov_ps(zero, inside, one);
    const __m512 t2 = _mm512_mul_ps(t, t), t3 = _mm512_mul_ps(t2, t), u = _mm512_sub_ps(one, t);
    const __m512 w0 = _mm512_mul_ps(_mm512_mul_ps(_mm512_mul_ps(u, u), u), sixth);
    const __m512 w1 = _mm512_mul_ps(_mm512_add_ps(_mm512_sub_ps(_mm512_mul_ps(three, t3), _mm512_mul_ps(six, t2)), four), sixth);
    const __m512 w2 = _mm512_mul_ps(_mm512_add_ps(_mm512_mul_ps(three, _mm512_add_ps(_mm512_sub_ps(t2, t3), t)), one), sixth);
    const __m512 w3 = _mm512_mul_ps(t3, sixth);
    const __m512 dw0 = _mm512_sub_ps(zero, _mm512_mul_ps(_mm512_mul_ps(half, u), u));
    const __m512 dw1 = _mm512_sub_ps(_mm512_mul_ps(three_halves, t2), _mm512_mul_ps(two, t));
    const __m512 dw2 = _mm512_add_ps(_mm512_sub_ps(t, _mm512_mul_ps(three_halves, t2)), half);
    const __m512 dw3 = _mm512_mul_ps(half, t2);
    // Dead and off-row samples gathered 0 for every tap: their value and slope are 0 already.
    const __m512 rv = _mm512_fmadd_ps(w3, c3, _mm512_fmadd_ps(w2, c2, _mm512_fmadd_ps(w1, c1, _mm512_mul_ps(w0, c0))));
    const __m512 gv = _mm512_mul_ps(
        gain, _mm512_fmadd_ps(dw3, c3, _mm512_fmadd_ps(dw2, c2, _mm512_fmadd_ps(dw1, c1, _mm512_mul_ps(dw0, c0)))));
    const __m512 res = _mm512_maskz_mov_ps(
        inside, _mm512_sub_ps(_mm512_fnmadd_ps(gain, rv, _mm512_loadu_ps(&left_[std::size_t(k)])), offset));
    const __m512 J[5] = {gv, _mm512_mul_ps(gv, vdi), _mm512_mul_ps(gv, vdj), _mm512_sub_ps(zero, rv),
                         _mm512_sub_ps(zero, live)};
    for (int a = 0, m = 0; a < 5; ++a) {
      g[a] = _mm512_fnmadd_ps(J[a], res, g[a]);
      for (int c = a; c < 5; ++c, ++m) hs[m] = _mm512_fmadd_ps(J[a], J[c], hs[m]);
    }
    if (respond) {
      const __m512 mt[3] = {_mm512_mul_ps(vdi, vdi), _mm512_mul_ps(vdi, vdj), _mm512_mul_ps(vdj, vdj)};
      for (int tq = 0; tq < 3; ++tq) {
        const __m512 gm = _mm512_mul_ps(gv, mt[tq]);
        for (int a = 0; a < 5; ++a) vq[tq][a] = _mm512_fmadd_ps(J[a], gm, vq[tq][a]);
      }
    }
    ssr = _mm512_fmadd_ps(res, res, ssr);
    used = _mm512_add_ps(used, live);
  }
  Sums out{};
  for (int m = 0; m < 15; ++m) out.hs[m] = double(_mm512_reduce_add_ps(hs[m]));
  for (int a = 0; a < 5; ++a) {
    out.g[a] = double(_mm512_reduce_add_ps(g[a]));
    for (int tq = 0; respond && tq < 3; ++tq) out.vq[tq][a] = double(_mm512_reduce_add_ps(vq[tq][a]));
  }
  out.ssr = double(_mm512_reduce_add_ps(ssr));
  out.used = int(std::lround(_mm512_reduce_add_ps(used)));
  return out;
}
#pragma GCC diagnostic pop
#endif

bool WindowRefiner::Solve(int x, int y, float d0, int r, double* d_out, double* sigma_out_px, cv::Vec3f* gain_out) {
  const cv::Mat& L = L_;
  const cv::Mat& R = R_;
  const cv::Mat& mask = mask_;
  const int w = L.cols, h = L.rows, iterations = iterations_;
  const bool curvature = curvature_;
  const double max_sigma_px = max_sigma_px_;
  const int side = 2 * r + 1, min_samples = std::max(9, (side * side * 2) / 5);  // 40 % of the window
  const float* r0 = R.ptr<float>(0);
  std::size_t n = 0;
  for (int j = std::max(0, y - r); j <= std::min(h - 1, y + r); ++j) {
    const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(j);
    const float* lrow = L.ptr<float>(j);
    const float* rrow = R.ptr<float>(j);
    const std::int32_t offset = std::int32_t(rrow - r0);
    for (int i = std::max(0, x - r); i <= std::min(w - 1, x + r); ++i) {
      if (m && m[i] == 0) continue;
      di_[n] = float(i - x), dj_[n] = float(j - y), left_[n] = lrow[i], live_[n] = 1.f;
      rows_[n] = rrow, offsets_[n] = offset;
      ++n;
    }
  }
  if (int(n) < min_samples) return false;
  const std::size_t lanes = wide_ ? 16 : 4;
  for (; n % lanes != 0; ++n) {  // dead samples: their terms are multiplied by live 0
    di_[n] = 0.f, dj_[n] = 0.f, left_[n] = 0.f, live_[n] = 0.f, rows_[n] = nullptr, offsets_[n] = 0;
  }
  samples_ = int(n);
  // Parameters: disparity at (x, y), its slopes along x and y (a slanted window:
  // surfaces seen at an angle, like a sphere's limb, are stretched between the views),
  // gain and offset between the cameras.
  Eigen::Matrix<double, 5, 1> q;
  q << d0, 0, 0, 0, 0;
  double sigma = 0;
  for (int it = 0; it < iterations; ++it) {
    // The window's response to curvature is wanted where the search ends, linearised as its
    // last step is: with the correction on, every pixel takes all its steps (one that settles
    // within 1e-3 px early would otherwise stop before the last), and the response is summed
    // in the last step only.
    const bool respond = curvature && it + 1 == iterations;
#ifdef HEDGEFIT_HAVE_AVX512_REFINE
    const Sums sums = wide_ ? Accumulate16(x, q, respond) : Accumulate(x, q, respond);
#else
    const Sums sums = Accumulate(x, q, respond);
#endif
    const int n_used = sums.used;
    // Textureless windows (tiny gradient energy) or a singular system: not settled.
    if (n_used < min_samples || sums.hs[0] < 0.25 * n_used) return false;
    Ldlt5 ldlt;
    if (!ldlt.Factor(sums.hs)) return false;
    double step[5];
    ldlt.Solve(sums.g, step);
    const bool last = (!curvature && std::abs(step[0]) < 1e-3) || it + 1 == iterations;
    // The estimate's standard deviation from the window's residuals and H^-1, of the
    // iteration that ends the search.
    if (last) sigma = std::sqrt(sums.ssr / std::max(1, n_used - 5) * ldlt.InverseFirst());
    if (respond) {
      for (int tq = 0; tq < 3; ++tq) {
        double response[5];
        ldlt.Solve(sums.vq[tq], response);
        (*gain_out)[tq] = float(response[0]);
      }
    }
    for (int a = 0; a < 5; ++a) q[a] += step[a];
    if (!std::isfinite(q[0]) || std::abs(q[0] - d0) > 1.0) return false;
    if (last) break;
  }
  *d_out = q[0];
  *sigma_out_px = sigma;
  return sigma <= max_sigma_px;
}

}  // namespace

void ForcePortableRefinement(bool portable) { g_force_portable_refine = portable; }

int RefineSubpixel(const cv::Mat& left, const cv::Mat& right, const cv::Mat& mask, const cv::Mat& skip, int radius,
                   int iterations, cv::Mat* disparity, double max_sigma_px, cv::Mat* sigma_out, cv::Mat* dropped,
                   int max_radius, double retry_sigma_px, int curvature_radius, int curvature_step_px) {
  if (sigma_out) sigma_out->create(disparity->size(), CV_32F), sigma_out->setTo(std::numeric_limits<float>::quiet_NaN());
  if (radius <= 0 || iterations <= 0) return 0;
  max_radius = std::max(radius, max_radius);
  const cv::Mat L = GreyFloat(left);
  // The right image is interpolated along rows only (rectified geometry), with cubic
  // B-splines: their prefilter makes the interpolant exact at the samples, and their
  // sub-pixel phase error - a periodic bias in the disparity, as in image correlation -
  // is several times smaller than Keys' or linear interpolation's on textured images.
  const cv::Mat R = BSplineCoefficientsAlongRows(GreyFloat(right));
  const int w = L.cols, h = L.rows;
  std::atomic<int> refined{0};
  const bool curvature = curvature_radius > 0 && curvature_step_px > 0;
  // Per refined pixel: how far the affine window's estimate moves per unit of each quadratic
  // coefficient of the disparity surface, d = ... + k_uu u^2 + k_uv u v + k_vv v^2 (u, v in px).
  cv::Mat gain;
  if (curvature) gain = cv::Mat(disparity->size(), CV_32FC3, cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    WindowRefiner refiner(L, R, mask, iterations, curvature, max_sigma_px, max_radius);
    int local = 0;
    for (int y = rows.start; y < rows.end; ++y) {
      float* drow = disparity->ptr<float>(y);
      const std::uint8_t* mrow = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
      const std::uint8_t* srow = skip.empty() ? nullptr : skip.ptr<std::uint8_t>(y);
      for (int x = 0; x < w; ++x) {
        const float d0 = drow[x];
        if (!std::isfinite(d0) || (mrow && mrow[x] == 0) || (srow && srow[x] != 0)) continue;
        double d = d0, sigma = 0;
        cv::Vec3f response(0, 0, 0), response2(0, 0, 0);
        // The small window where it pins the disparity well (sigma <= retry_sigma); else the
        // large one, which averages more of the noise (Kanade and Okutomi's adaptive window);
        // else the small one if it settled at all.
        bool ok = refiner.Solve(x, y, d0, radius, &d, &sigma, &response);
        if (max_radius > radius && !(ok && sigma <= retry_sigma_px)) {
          double d2 = d0, sigma2 = 0;
          if (refiner.Solve(x, y, d0, max_radius, &d2, &sigma2, &response2)) d = d2, sigma = sigma2, ok = true, response = response2;
        }
        if (ok) {
          drow[x] = static_cast<float>(d);
          if (sigma_out) sigma_out->at<float>(y, x) = static_cast<float>(sigma);
          if (curvature) gain.at<cv::Vec3f>(y, x) = response;
          ++local;
        } else if (dropped) {
          drow[x] = std::numeric_limits<float>::quiet_NaN();
          dropped->at<std::uint8_t>(y, x) = 255;
        }
      }
    }
    refined += local;
  });
  if (curvature) CorrectCurvature(gain, curvature_radius, curvature_step_px, disparity);
  return refined.load();
}

namespace {

// The right view's matcher for the left-right check, set up as opencv_contrib's
// ximgproc::createRightMatcher does: the mirrored search range and no uniqueness, consistency or
// speckle rejection of its own. Written here so that the stereo library does not link ximgproc,
// which links imgcodecs and its ~140 libraries into every command.
cv::Ptr<cv::StereoSGBM> RightMatcherFor(const cv::Ptr<cv::StereoSGBM>& left) {
  cv::Ptr<cv::StereoSGBM> right = cv::StereoSGBM::create(-(left->getMinDisparity() + left->getNumDisparities()) + 1,
                                                         left->getNumDisparities(), left->getBlockSize());
  right->setUniquenessRatio(0);
  right->setP1(left->getP1());
  right->setP2(left->getP2());
  right->setMode(left->getMode());
  right->setPreFilterCap(left->getPreFilterCap());
  right->setDisp12MaxDiff(1000000);
  right->setSpeckleWindowSize(0);
  return right;
}

}  // namespace

namespace {

// ComputeDisparity on views whose first `blind_px` columns are padding: a match that reads the
// right view there is no match.
namespace {

// The left-right check: a left disparity stays when the right matcher's disparity at the pixel it
// points to agrees within `lrc` px; `min_d` is the search's first disparity.
void LeftRightCheck(const cv::Mat& d16_right, double lrc, int min_d, DisparityMap* out) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int cols = out->disparity.cols;
  for (int y = 0; y < out->disparity.rows; ++y) {
    float* d = out->disparity.ptr<float>(y);
    const short* rr = d16_right.ptr<short>(y);
    std::uint8_t* rej = out->rejected.ptr<std::uint8_t>(y);
    for (int x = 0; x < cols; ++x) {
      if (std::isnan(d[x])) {
        rej[x] = 255;
        continue;
      }
      const int xr = static_cast<int>(std::lround(x - d[x]));
      bool ok = xr >= 0 && xr < cols;
      if (ok) {
        const short rv = rr[xr];
        const float dr = -rv / 16.0f;
        ok = rv != std::numeric_limits<short>::min() && rv <= 0 && std::abs(dr - d[x]) <= lrc && -rv > (min_d - 1) * 16;
      }
      if (!ok) {
        d[x] = nan;
        rej[x] = 255;
      }
    }
  }
}

// Refines what SGBM and the check accepted (not `off_grid`), after taking the pair's residual
// vertical disparity out of the right view.
void RefineAccepted(const cv::Mat& left, const cv::Mat& right, const cv::Mat& mask, const SgbmOptions& o, int stride,
                    const cv::Mat& off_grid, DisparityMap* out_map) {
  DisparityMap& out = *out_map;
  // The refinement matches along rows: the pair's residual vertical disparity goes first.
  cv::Mat refine_right = right;
  if (o.correct_vertical) {
    const cv::Mat right_grey = GreyFloat(right), coeffs = BSplineCoefficients2D(right_grey);
    cv::Mat known = out.disparity.clone();
    known.setTo(std::numeric_limits<float>::quiet_NaN(), out.rejected);
    out.vertical = EstimateVerticalDisparityFloat(GreyFloat(left), coeffs, known, mask);
    // Below correct_vertical_min the rows agree to the refinement's own precision, and
    // resampling the view would only perturb it.
    out.vertical.applied = out.vertical.samples > 0 && out.vertical.MaxAbs(left.size()) >= o.correct_vertical_min_px;
    refine_right = out.vertical.applied ? ShiftRows(right_grey, coeffs, out.vertical) : right_grey;
  }
  RefineSubpixel(left, refine_right, mask, off_grid.empty() ? out.rejected : (out.rejected | off_grid), o.refine_radius,
                 o.refine_iterations, &out.disparity, o.refine_max_sigma_px, &out.sigma,
                 o.refine_drop_uncertain ? &out.rejected : nullptr, o.refine_max_radius, o.refine_retry_sigma_px,
                 // Neighbours 1 px apart share most of their windows' samples, so their errors move
                 // together; 2 px is the closest spacing that reads the curvature, and a thinned
                 // hedge's refined pixels lie every stride-th.
                 o.refine_curvature, std::max(2, stride));
}

}  // namespace

DisparityMap MatchViews(const cv::Mat& left, const cv::Mat& right, const SgbmOptions& o, const cv::Mat& mask, int stride,
                        int blind_px) {
  const int channels = left.channels();
  const int num = ((o.num_disparities + 15) / 16) * 16;
  const int p1 = o.p1 > 0 ? o.p1 : 8 * channels * o.block_size * o.block_size;
  const int p2 = o.p2 > 0 ? o.p2 : 32 * channels * o.block_size * o.block_size;
  const int mode = o.mode == SgbmMode::kHh8       ? cv::StereoSGBM::MODE_HH
                   : o.mode == SgbmMode::kSgbm5   ? cv::StereoSGBM::MODE_SGBM
                   : o.mode == SgbmMode::kSgbm3Way ? cv::StereoSGBM::MODE_SGBM_3WAY
                                                   : cv::StereoSGBM::MODE_HH4;
  // Half resolution for a thinned hedge: the disparity range halves with the images (rounded
  // outwards), the check's tolerance too.
  const bool half = o.half_res_from_stride > 0 && stride >= std::max(2, o.half_res_from_stride) && left.cols >= 64 &&
                    left.rows >= 32;
  cv::Mat l = left, r = right;
  int min_d = o.min_disparity, num_d = num;
  double lrc = o.lrc_tolerance_px;
  if (half) {
    cv::resize(left, l, cv::Size(left.cols / 2, left.rows / 2), 0, 0, cv::INTER_AREA);
    cv::resize(right, r, l.size(), 0, 0, cv::INTER_AREA);
    min_d = static_cast<int>(std::floor(o.min_disparity / 2.0));
    num_d = ((static_cast<int>(std::ceil((o.min_disparity + num) / 2.0)) - min_d + 15) / 16) * 16;
    if (lrc >= 0) lrc = std::max(0.5, lrc / 2);
  }
  const auto t_sgbm = std::chrono::steady_clock::now();
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(min_d, num_d, o.block_size, p1, p2,
                                                        o.disp12_max_diff, 0, o.uniqueness_ratio, 0, 0, mode);
  // The left and the right matcher (for the left-right check) run side by side: OpenCV's HH
  // modes are single-threaded, so on two cores this halves the matching time.
  cv::Mat d16_left, d16_right;
  pipeline::ParallelFor(o.lrc_tolerance_px >= 0 ? 2 : 1, 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      if (i == 0) {
        sgbm->compute(l, r, d16_left);
      } else {
        RightMatcherFor(sgbm)->compute(r, l, d16_right);  // negative disparities, as OpenCV's right matcher gives
      }
    }
  });
  DisparityMap out;
  const float invalid_left = float(min_d - 1) * 16.0f;
  const int blind = half ? (blind_px + 1) / 2 : blind_px;
  out.disparity.create(l.size(), CV_32F);
  out.rejected = cv::Mat::zeros(l.size(), CV_8U);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < l.rows; ++y) {
    const short* s = d16_left.ptr<short>(y);
    float* d = out.disparity.ptr<float>(y);
    for (int x = 0; x < l.cols; ++x) d[x] = s[x] <= invalid_left || x * 16 - s[x] < blind * 16 ? nan : s[x] / 16.0f;
  }
  if (lrc >= 0) LeftRightCheck(d16_right, lrc, min_d, &out);
  if (half) {
    // Back to full resolution: each pixel takes its half-resolution pixel's disparity, doubled.
    cv::Mat d_full, rej_full;
    cv::resize(out.disparity * 2.0f, d_full, left.size(), 0, 0, cv::INTER_NEAREST);
    cv::resize(out.rejected, rej_full, left.size(), 0, 0, cv::INTER_NEAREST);
    out.disparity = d_full;
    out.rejected = rej_full;
  }
  // Refine what SGBM and the check accepted, before holes are filled from it.
  cv::Mat off_grid;
  if (stride > 1) {
    off_grid = cv::Mat(left.size(), CV_8U, cv::Scalar(255));
    for (int y = 0; y < left.rows; y += stride) {
      std::uint8_t* row = off_grid.ptr<std::uint8_t>(y);
      for (int x = 0; x < left.cols; x += stride) row[x] = 0;
    }
  }
  const auto t_refine = std::chrono::steady_clock::now();
  if (o.refine_radius > 0) RefineAccepted(left, right, mask, o, stride, off_grid, &out);
  out.sgbm_ms = std::chrono::duration<double, std::milli>(t_refine - t_sgbm).count();
  out.refine_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_refine).count();
  if (o.fill_holes) out.filled = FillHolesFromBackground(&out.disparity);
  if (!off_grid.empty()) {
    out.disparity.setTo(std::numeric_limits<float>::quiet_NaN(), off_grid);
    out.rejected.setTo(0, off_grid);
  }
  if (o.bilateral_sigma_disp > 0 && o.bilateral_sigma_space > 0) {
    // Edge-preserving smoothing of the (filled) map; pixels still unknown stay unknown.
    cv::Mat known = out.disparity == out.disparity;  // false for NaN
    cv::Mat src = out.disparity.clone();
    src.setTo(0, ~known);
    cv::Mat smooth;
    const int diameter = static_cast<int>(std::ceil(o.bilateral_sigma_space * 2)) * 2 + 1;
    cv::bilateralFilter(src, smooth, diameter, o.bilateral_sigma_disp, o.bilateral_sigma_space);
    smooth.copyTo(out.disparity, known);
  }
  return out;
}

}  // namespace

DisparityMap ComputeDisparity(const cv::Mat& left, const cv::Mat& right, const SgbmOptions& o, const cv::Mat& mask,
                              int stride, int left_pad_px, int right_pad_px) {
  o.Check();
  if (left.empty() || right.empty() || left.size() != right.size() || left.type() != right.type()) {
    throw Error("stereo.sgbm: the left and right images must be non-empty and of the same size and type");
  }
  if (left_pad_px <= 0 && right_pad_px <= 0) return MatchViews(left, right, o, mask, stride, 0);
  // Whole numbers of (half-resolution) thinning steps, so the same pixels are kept.
  const int step = 2 * std::max(1, stride);
  const int pad_l = (std::max(0, left_pad_px) + step - 1) / step * step;
  const int pad_r = (std::max(0, right_pad_px) + step - 1) / step * step;
  cv::Mat l, r, m;
  cv::copyMakeBorder(left, l, 0, 0, pad_l, pad_r, cv::BORDER_REPLICATE);
  cv::copyMakeBorder(right, r, 0, 0, pad_l, pad_r, cv::BORDER_REPLICATE);
  if (!mask.empty()) cv::copyMakeBorder(mask, m, 0, 0, pad_l, pad_r, cv::BORDER_CONSTANT, cv::Scalar(0));
  DisparityMap out = MatchViews(l, r, o, m, stride, pad_l);
  const cv::Range cols(pad_l, pad_l + left.cols);
  out.disparity = out.disparity.colRange(cols).clone();
  out.rejected = out.rejected.colRange(cols).clone();
  if (!out.sigma.empty()) out.sigma = out.sigma.colRange(cols).clone();
  // The vertical disparity's model, from the padded frame to this one (the same plane).
  const double per_px = out.vertical.slope_x_px / double(l.cols);
  out.vertical.offset_px += per_px * 0.5 * (pad_l - pad_r);
  out.vertical.slope_x_px = per_px * left.cols;
  return out;
}

}  // namespace hedgefit::stereo
