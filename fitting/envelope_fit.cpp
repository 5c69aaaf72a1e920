#include "fitting/envelope_fit.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "pipeline/error.hpp"
#include "pipeline/parallel.hpp"
#include "fitting/algebraic_fit.hpp"
#include "fitting/geometric_fit.hpp"

namespace hedgefit::fitting {

namespace {

constexpr double kMinScaleMm = 0.01;
// top_bias_px was measured where one pixel spans 1.4-3.2 mm (1.3-3 m on the benches' rigs), a
// fraction of a leaf. Where a pixel spans more, the window averages whole leaves and the reading
// cannot grow past the layer's mean depth; it is not extrapolated: a larger footprint counts as
// this one (at 24 m, PCL's real outdoor pair, the footprint is 65 mm and would add 33 mm).
constexpr double kMaxTopBiasFootprintMm = 4.0;
// Parameters: centre (3), R, log mu, log sigma, logit w (the share on the envelope).
constexpr int kParams = 7;
// The search starts with a quarter of the leaves on the envelope (logit -1: w 0.27), between a
// freshly clipped ball and an overgrown one; on POV-Ray's and hedgefit's gardens the fits end
// anywhere from 0 to 1.
constexpr double kStartLogitShare = -1.0;
// The second start: almost none on the envelope (logit -6: w 0.0025), the exponential alone.
constexpr double kNoShareLogit = -6.0;
// ... unless the first search ended with less than this share: that start's basin already.
constexpr double kNoShareSkip = 0.01;

// log(erfc(z)) and its derivative, accurate where erfc underflows (z > 5: the asymptotic series).
double LogErfc(double z, double* derivative) {
  if (z > 5) {
    const double z2 = z * z, a = 1 - 0.5 / z2 + 0.75 / (z2 * z2), da = 1 / (z2 * z) - 3 / (z2 * z2 * z);
    *derivative = -2 * z - 1 / z + da / a;
    return -z2 - std::log(z * std::sqrt(M_PI)) + std::log(a);
  }
  const double e = std::erfc(z);
  *derivative = -2 / std::sqrt(M_PI) * std::exp(-z * z) / e;
  return std::log(e);
}

// Negative log-likelihood of the shell model over all points, parameters: centre (3), R,
// log mu, log sigma, logit w. Points are centred on their mean (double precision far from the origin).
struct ShellLikelihood {
  const std::vector<Eigen::Vector3d>* pts;
  const std::vector<double>* bias;  // per point: how deep the matcher reads a leaf on the envelope (radial, mm); may be null
  Eigen::Vector3d view;      // viewpoint, in the centred frame
  double log_outlier;        // log(share / width of the uniform outlier density)
  double log_inlier_share;   // log(1 - share)

  // The negative log-likelihood of points [begin, end), and its gradient added to `grad`
  // (kParams values). By hand: automatic differentiation (Ceres' Jets) cost three times as much,
  // and this sum is the fit's whole cost. tests/fitting/envelope_fit_test.cpp checks it against
  // central differences.
  double Sum(const double* p, std::size_t begin, std::size_t end, double* grad) const {
    // Floors on the leaf depth and the noise (far below any camera's): without them the
    // likelihood of a smooth surface grows without bound as sigma -> 0, and a line search step
    // there overflows.
    const Eigen::Vector3d c(p[0], p[1], p[2]);
    const double R = p[3], mu0 = kMinScaleMm + std::exp(p[4]), sigma = kMinScaleMm + std::exp(p[5]);
    const double dmu_da = mu0 - kMinScaleMm, dsigma_dg = sigma - kMinScaleMm;
    // Per evaluation, not per point: the densities' constants.
    const double lambda = 1 / mu0, lambda_sigma2 = lambda * sigma * sigma, inv_sigma = 1 / sigma,
                 inv_sqrt2_sigma = inv_sigma / std::sqrt(2.0);
    const double w = 1 / (1 + std::exp(-p[6]));
    const double log_w = -std::log1p(std::exp(-p[6])), log_1w = -std::log1p(std::exp(p[6]));
    const double emg_const = log_inlier_share + log_1w + std::log(lambda / 2);
    const double clip_const = log_inlier_share + log_w - std::log(sigma * std::sqrt(2 * M_PI));
    const double b = log_outlier;
    double total = 0;
    double g_c[3] = {0, 0, 0}, g_R = 0, g_lambda = 0, g_sigma = 0, g_u = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const Eigen::Vector3d& q = (*pts)[i];
      const Eigen::Vector3d d = q - c, r = q - view;
      const double s = d.norm(), rn = r.norm();
      // Depth is seen along the view ray: its radial share is cos(theta) at the point.
      double cos_t = -r.dot(d) / (rn * s + 1e-12);
      Eigen::Vector3d dcos_dc = r / (rn * s + 1e-12) + cos_t * d / (s * s + 1e-12);
      if (cos_t < 0.1) cos_t = 0.1, dcos_dc.setZero();
      // Leaf depth and stereo noise both lie along the ray: in the radial direction both are
      // scaled by cos(theta), so x / cos(theta) follows the face-on model; log(cos_t) is the
      // Jacobian of that scaling.
      // Depth below the envelope, along the ray (less the matcher's reading of the outermost
      // leaves too deep: a constant per point, so the derivatives below keep their form).
      const double x = (R - s - (bias ? (*bias)[i] : 0.0)) / cos_t;
      const double log_cos = std::log(cos_t);
      // The leaves below the envelope: an exponentially modified Gaussian (exponential depth
      // plus N(0, sigma^2)).
      const double z = (lambda_sigma2 - x) * inv_sqrt2_sigma;
      double dlerfc = 0;
      const double a1 = emg_const + lambda / 2 * (lambda_sigma2 - 2 * x) + LogErfc(z, &dlerfc) - log_cos;
      // The leaves the shears cut flush with the envelope: N(0, sigma^2) about it.
      const double xs = x * inv_sigma;
      const double a2 = clip_const - 0.5 * xs * xs - log_cos;
      const double m = std::max(std::max(a1, a2), b);
      const double e1 = std::exp(a1 - m), e2 = std::exp(a2 - m), e3 = std::exp(b - m), sum = e1 + e2 + e3;
      total -= m + std::log(sum);
      if (grad == nullptr) continue;
      // Each density's share of the point (the outlier density has no parameters).
      const double p1 = e1 / sum, p2 = e2 / sum;
      const double da1_dx = -lambda - dlerfc * inv_sqrt2_sigma, da2_dx = -x * inv_sigma * inv_sigma;
      const double gx = -(p1 * da1_dx + p2 * da2_dx), g_logcos = p1 + p2;
      const Eigen::Vector3d dx_dc = (d / s - x * dcos_dc) / cos_t;
      const Eigen::Vector3d gc = gx * dx_dc + g_logcos * dcos_dc / cos_t;
      g_c[0] += gc.x(), g_c[1] += gc.y(), g_c[2] += gc.z();
      g_R += gx / cos_t;
      g_lambda -= p1 * (1 / lambda + lambda_sigma2 - x + dlerfc * sigma / std::sqrt(2.0));
      const double dz_dsigma = lambda / std::sqrt(2.0) + x * inv_sqrt2_sigma * inv_sigma;
      g_sigma -= p1 * (lambda * lambda * sigma + dlerfc * dz_dsigma) + p2 * (-inv_sigma + xs * xs * inv_sigma);
      g_u -= p1 * (-w) + p2 * (1 - w);
    }
    if (grad != nullptr) {
      grad[0] += g_c[0], grad[1] += g_c[1], grad[2] += g_c[2], grad[3] += g_R;
      grad[4] += g_lambda * (-lambda * lambda) * dmu_da;  // d lambda / d log(mu0 - floor)
      grad[5] += g_sigma * dsigma_dg;
      grad[6] += g_u;
    }
    return total;
  }
};

// The mean negative log-likelihood and its gradient (automatic differentiation), summed over
// fixed chunks of the points in parallel and added in chunk order, so the result does not
// depend on the thread count.
class ParallelShellCost : public ceres::FirstOrderFunction {
 public:
  explicit ParallelShellCost(const ShellLikelihood& model) : model_(model) {}
  int NumParameters() const override { return kParams; }
  bool Evaluate(const double* p, double* cost, double* gradient) const override {
    const std::size_t n = model_.pts->size();
    constexpr std::size_t kChunks = 16;
    const std::size_t chunk = (n + kChunks - 1) / kChunks;
    std::array<double, kChunks> partial{};
    std::array<std::array<double, kParams>, kChunks> partial_grad{};
    pipeline::ParallelFor(kChunks, 0, 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t c = b; c < e; ++c) {
        partial[c] = model_.Sum(p, std::min(n, c * chunk), std::min(n, (c + 1) * chunk),
                                gradient ? partial_grad[c].data() : nullptr);
      }
    });
    const double inv_n = 1.0 / double(std::max<std::size_t>(1, n));
    double total = 0;
    for (const double v : partial) total += v;
    cost[0] = total * inv_n;
    bool finite = std::isfinite(cost[0]);
    if (gradient) {
      for (int k = 0; k < kParams; ++k) {
        double g = 0;
        for (const auto& pg : partial_grad) g += pg[std::size_t(k)];
        gradient[k] = g * inv_n;
        finite = finite && std::isfinite(gradient[k]);
      }
    }
    // A non-finite value or gradient is an invalid point for the line search, which then steps
    // back, rather than a Ceres CHECK failure.
    return finite;
  }

 private:
  ShellLikelihood model_;
};

// The search in scaled lengths: centre and R in units of `scale` (the residuals' spread), so
// one unit moves the cost about as much in every parameter.
class ScaledShellCost : public ceres::FirstOrderFunction {
 public:
  ScaledShellCost(const ShellLikelihood& model, double scale) : cost_(model), scale_(scale) {}
  int NumParameters() const override { return kParams; }
  bool Evaluate(const double* q, double* cost, double* gradient) const override {
    double p[kParams];
    for (int k = 0; k < kParams; ++k) p[k] = k < 4 ? q[k] * scale_ : q[k];
    const bool ok = cost_.Evaluate(p, cost, gradient);
    if (gradient) {
      for (int k = 0; k < 4; ++k) gradient[k] *= scale_;
    }
    return ok;
  }

 private:
  ParallelShellCost cost_;
  double scale_;
};

}  // namespace

const pipeline::OptionTable<EnvelopeFitOptions>& EnvelopeFitOptions::Table() {
  using O = EnvelopeFitOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("viewpoint", &O::viewpoint_mm, "the camera's position in the cloud's frame", "mm")
          .Add("outlier_share", &O::outlier_share, "prior share of outliers (uniform)").Range(1e-6, 0.5)
          .Add("max_iterations", &O::max_iterations, "LBFGS iterations at most", "iterations").Range(1, 10000)
          .Add("max_points", &O::max_points, "the likelihood sums over at most this many points (every n-th); 0 = all",
               "points")
          .Range(0, 1e9)
          .Add("top_bias", &O::top_bias_px,
               "the matcher reads the outermost leaves this many pixel footprints too deep; added back where the "
               "cloud has a pixel_mm field (0 = off)",
               "px")
          .Range(0, 5);
  return table;
}

void EnvelopeFitOptions::Check() const { Table().Validate(*this); }

// The points about their mean, the matcher's reading of the outermost leaves below them (per
// point), the residuals' robust spread from the start and where outliers may fall; every n-th point
// when there are more than max_points.
struct ShellData {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> centred;
  std::vector<double> bias;
  double spread = 0, width = 0, mean_bias = 0;
};

ShellData PrepareShell(const std::vector<Eigen::Vector3d>& points_mm, const EnvelopeFitOptions& options,
                       const SphereFitResult& start, const std::vector<double>* pixel_mm) {
  ShellData d;
  Eigen::Vector3d& mean = d.mean;
  std::vector<Eigen::Vector3d>& centred = d.centred;
  std::vector<double>& bias = d.bias;
  for (const auto& p : points_mm) mean += p;
  mean /= double(points_mm.size());
  centred.resize(points_mm.size());
  std::vector<double> res(points_mm.size());
  for (std::size_t i = 0; i < points_mm.size(); ++i) {
    centred[i] = points_mm[i] - mean;
    res[i] = (points_mm[i] - start.sphere.center_mm).norm() - start.sphere.radius_mm;
  }
  // Robust spread of the residuals: the scale of the leaf layer and the noise together.
  std::vector<double> abs_res(res.size());
  for (std::size_t i = 0; i < res.size(); ++i) abs_res[i] = std::abs(res[i]);
  std::nth_element(abs_res.begin(), abs_res.begin() + std::ptrdiff_t(abs_res.size() / 2), abs_res.end());
  const double spread = d.spread = std::max(0.05, 1.4826 * abs_res[abs_res.size() / 2]);
  d.width = std::max(10 * spread, 0.5 * start.sphere.radius_mm);  // where outliers may fall
  // The matcher's reading of the outermost leaves below them, per point (top_bias_px footprints).
  if (pixel_mm && options.top_bias_px > 0) {
    bias.resize(points_mm.size());
    for (std::size_t i = 0; i < bias.size(); ++i) {
      const double p = (*pixel_mm)[i];
      bias[i] = std::isfinite(p) && p > 0 ? options.top_bias_px * std::min(p, kMaxTopBiasFootprintMm) : 0.0;
    }
  }
  // Every n-th point, n the smallest that keeps at most max_points.
  if (options.max_points > 0 && centred.size() > std::size_t(options.max_points)) {
    const std::size_t n = (centred.size() + std::size_t(options.max_points) - 1) / std::size_t(options.max_points);
    std::vector<Eigen::Vector3d> thinned;
    std::vector<double> thinned_bias;
    thinned.reserve(centred.size() / n + 1);
    for (std::size_t i = 0; i < centred.size(); i += n) {
      thinned.push_back(centred[i]);
      if (!bias.empty()) thinned_bias.push_back(bias[i]);
    }
    centred.swap(thinned);
    bias.swap(thinned_bias);
  }
  double& mean_bias = d.mean_bias;
  for (const double b : bias) mean_bias += b;
  if (!bias.empty()) mean_bias /= double(bias.size());
  return d;
}

// The likeliest shell from the start and its restarts; `p` gets the parameters, `iterations`
// the solver's iterations over all of them.
ceres::GradientProblemSolver::Summary SolveShell(const ShellLikelihood& model, const ShellData& d, const Sphere& start_sphere,
                                                 const EnvelopeFitOptions& options, double p[kParams], int* iterations) {
  const double spread = d.spread, mean_bias = d.mean_bias;
  const Eigen::Vector3d& mean = d.mean;
  // A start: the geometric sphere, the envelope a spread outside it, leaves and noise of that
  // spread's scale, and the given share on the envelope (as a logit).
  auto start_at = [&](double logit_share, double* x) {
    const Eigen::Vector3d c = start_sphere.center_mm - mean;
    const double values[kParams] = {c.x(), c.y(), c.z(), start_sphere.radius_mm + spread + mean_bias, std::log(spread),
                                    std::log(0.5 * spread), logit_share};
    std::copy(values, values + kParams, x);
  };
  start_at(kStartLogitShare, p);
  const double unit = spread;  // lengths in the residuals' spread (ScaledShellCost)
  ceres::GradientProblem problem(new ScaledShellCost(model, unit));
  ceres::GradientProblemSolver::Options so;
  so.max_num_iterations = options.max_iterations;
  so.logging_type = ceres::SILENT;
  // A relative change of 1e-9 in the cost (tens of thousands of nats for 10000 points) is ~1e-5
  // nats: with the radius's curvature of ~N / noise^2, a few thousandths of a millimetre. 1e-12
  // took a third more iterations for the same fits (both renderers' standard and hard gardens
  // within 0.03 mm mean |AER|, the envelope stage 145-153 -> 121-126 ms on POV-Ray's row).
  so.function_tolerance = 1e-9;
  so.gradient_tolerance = 1e-10;
  auto scaled_solve = [&](double* x, ceres::GradientProblemSolver::Summary* sum) {
    for (int k = 0; k < 4; ++k) x[k] /= unit;
    ceres::Solve(so, problem, x, sum);
    for (int k = 0; k < 4; ++k) x[k] *= unit;
  };
  ceres::GradientProblemSolver::Summary summary;
  scaled_solve(p, &summary);
  *iterations = static_cast<int>(summary.iterations.size());
  // The share on the envelope and the exponential's depth trade against each other where the
  // noise is as large as the leaf layer, and the likelihood has a local optimum on each side: a
  // synthetic ball with 8 mm of exponential leaves and 6 mm of noise stopped at a third of its
  // leaves on the envelope and a mean depth of 5.7 mm (a worse likelihood than the 8.1 mm found
  // from no share). So the search also starts from almost no share (the exponential alone) and
  // the likelier end is kept (when the first search ended with next to no share it is that start's
  // basin already, and the second is skipped).
  if (1 / (1 + std::exp(-p[6])) > kNoShareSkip) {
    double q[kParams];
    start_at(kNoShareLogit, q);
    ceres::GradientProblemSolver::Summary again;
    scaled_solve(q, &again);
    *iterations += static_cast<int>(again.iterations.size());
    if (again.IsSolutionUsable() && (!summary.IsSolutionUsable() || again.final_cost < summary.final_cost)) {
      std::copy(q, q + kParams, p);
      summary = again;
    }
  }
  // Leaf depth and noise are searched as logarithms (both stay positive), so once the leaf depth
  // has shrunk towards its floor its gradient vanishes and the search stays there, all spread
  // taken for noise, even where deeper leaves explain the points better: a garden ball's fit
  // (r 600 mm) stopped at 1.6 mm of leaves and 10.4 mm of noise, its centre 6.9 mm off, where
  // every other start reached 8.2 and 7.3 mm and a centre 0.6 mm off; on synthetic leafy balls
  // with noise 4-9 mm and leaves 6-10 mm deep, 63 of 72 ended so. A fit that ends with less leaf
  // depth than half its noise is searched again with leaves half and all as deep as that noise,
  // and the likeliest kept (3 of the 72 still end without leaves, all with the noise over 1.5
  // times the leaf depth; a smooth sphere, whose leaf depth is nil, ends there again).
  if (summary.IsSolutionUsable() && std::exp(p[4]) < 0.5 * std::exp(p[5])) {
    const double noise = kMinScaleMm + std::exp(p[5]);
    double best[kParams];
    std::copy(p, p + kParams, best);
    for (const double share : {0.5, 1.0}) {
      double q[kParams] = {p[0], p[1], p[2], p[3] + share * noise, std::log(share * noise), std::log(0.6 * noise),
                           kStartLogitShare};
      ceres::GradientProblemSolver::Summary again;
      scaled_solve(q, &again);
      *iterations += static_cast<int>(again.iterations.size());
      if (again.IsSolutionUsable() && again.final_cost < summary.final_cost) {
        std::copy(q, q + kParams, best);
        summary = again;
      }
    }
    std::copy(best, best + kParams, p);
  }
  return summary;
}

EnvelopeFit FitEnvelope(const std::vector<Eigen::Vector3d>& points_mm, const EnvelopeFitOptions& options,
                        const Sphere* initial, const std::vector<double>* pixel_mm) {
  options.Check();
  if (pixel_mm && pixel_mm->empty()) pixel_mm = nullptr;  // a cloud without the field
  if (pixel_mm && pixel_mm->size() != points_mm.size()) {
    throw Error("envelope fit: " + std::to_string(pixel_mm->size()) + " pixel sizes for " +
                std::to_string(points_mm.size()) + " points");
  }
  const auto t0 = std::chrono::steady_clock::now();
  EnvelopeFit out;
  SphereFitResult& r = out.fit;
  r.method = "envelope";
  r.points_used = points_mm.size();
  if (auto why = DegeneracyReason(points_mm)) {
    r.message = *why;
    return out;
  }
  // Start: the geometric fit (mean leaf), with the envelope a little outside it.
  SphereFitResult start;
  if (initial != nullptr) {
    start.sphere = *initial;
    start.converged = true;
  } else {
    GeometricFitOptions go;
    go.compute_covariance = false;
    start = FitSphereGeometric(points_mm, go);
  }
  if (!start.converged) {
    r.message = "no starting sphere: " + start.message;
    return out;
  }
  const ShellData d = PrepareShell(points_mm, options, start, pixel_mm);
  const Eigen::Vector3d& mean = d.mean;
  const double mean_bias = d.mean_bias;
  ShellLikelihood model{&d.centred, d.bias.empty() ? nullptr : &d.bias, options.viewpoint_mm - mean,
                        std::log(options.outlier_share / d.width), std::log(1 - options.outlier_share)};
  double p[kParams];
  const ceres::GradientProblemSolver::Summary summary = SolveShell(model, d, start.sphere, options, p, &r.iterations);
  r.wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const double mu = kMinScaleMm + std::exp(p[4]), sigma = kMinScaleMm + std::exp(p[5]);
  if (!summary.IsSolutionUsable() || !std::isfinite(p[3]) || !(p[3] > 0) || !std::isfinite(mu)) {
    r.message = "the shell model did not converge: " + summary.message;
    return out;
  }
  r.sphere.center_mm = Eigen::Vector3d(p[0], p[1], p[2]) + mean;
  r.sphere.radius_mm = p[3];
  r.converged = true;
  r.rms_mm = RmsResidual(points_mm, r.sphere);
  // Inliers: points the model explains better than the outlier density.
  r.inliers = points_mm.size();
  const double w = 1 / (1 + std::exp(-p[6]));
  out.leaf_depth_mm = (1 - w) * mu;
  out.noise_mm = sigma;
  out.clipped_share = w;
  out.top_bias_mm = mean_bias;
  out.surface_radius_mm = p[3] - mean_bias - (1 - w) * mu;
  return out;
}

namespace detail {
double ShellCost(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& viewpoint_mm, double outlier_share,
                 double outlier_width_mm, const double* p, double* gradient) {
  const ShellLikelihood model{&points, nullptr, viewpoint_mm, std::log(outlier_share / outlier_width_mm),
                              std::log(1 - outlier_share)};
  double cost = 0;
  ParallelShellCost(model).Evaluate(p, &cost, gradient);
  return cost;
}
}  // namespace detail

}  // namespace hedgefit::fitting
