#include "fitting/geometric_fit.hpp"

#include <ceres/ceres.h>

#include <chrono>
#include <limits>
#include <cmath>
#include <thread>

#include "pipeline/error.hpp"

namespace hedgefit::fitting {

namespace {

// |p - c| - r with its analytic Jacobian: d/dc = -(p - c)^T / |p - c|, d/dr = -1.
class SphereDistanceCost : public ceres::SizedCostFunction<1, 3, 1> {
 public:
  explicit SphereDistanceCost(const Eigen::Vector3d& p) : p_(p) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector3d> c(parameters[0]);
    const Eigen::Vector3d d = p_ - c;
    const double n = d.norm();
    residuals[0] = n - parameters[1][0];
    if (jacobians) {
      if (jacobians[0]) {
        const Eigen::Vector3d g = n > 0 ? Eigen::Vector3d(-d / n) : Eigen::Vector3d::Zero();
        jacobians[0][0] = g.x();
        jacobians[0][1] = g.y();
        jacobians[0][2] = g.z();
      }
      if (jacobians[1]) jacobians[1][0] = -1.0;
    }
    return true;
  }

 private:
  Eigen::Vector3d p_;
};

// The same residuals for a block of points at once: with no robust loss (which Ceres
// applies per block) one block per 256 points saves most of Ceres' per-block overhead.
class SphereDistanceBlockCost : public ceres::CostFunction {
 public:
  explicit SphereDistanceBlockCost(std::vector<Eigen::Vector3d> points) : points_(std::move(points)) {
    set_num_residuals(static_cast<int>(points_.size()));
    mutable_parameter_block_sizes()->push_back(3);
    mutable_parameter_block_sizes()->push_back(1);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector3d> c(parameters[0]);
    for (std::size_t i = 0; i < points_.size(); ++i) {
      const Eigen::Vector3d d = points_[i] - c;
      const double n = d.norm();
      residuals[i] = n - parameters[1][0];
      if (jacobians && jacobians[0]) {
        const Eigen::Vector3d g = n > 0 ? Eigen::Vector3d(-d / n) : Eigen::Vector3d::Zero();
        jacobians[0][3 * i + 0] = g.x();
        jacobians[0][3 * i + 1] = g.y();
        jacobians[0][3 * i + 2] = g.z();
      }
      if (jacobians && jacobians[1]) jacobians[1][i] = -1.0;
    }
    return true;
  }

 private:
  std::vector<Eigen::Vector3d> points_;
};

// The same residual for Ceres' automatic differentiation.
struct SphereDistanceFunctor {
  explicit SphereDistanceFunctor(const Eigen::Vector3d& p) : p_(p) {}
  template <class T>
  bool operator()(const T* c, const T* r, T* residual) const {
    const T dx = T(p_.x()) - c[0], dy = T(p_.y()) - c[1], dz = T(p_.z()) - c[2];
    residual[0] = ceres::sqrt(dx * dx + dy * dy + dz * dz) - r[0];
    return true;
  }
  Eigen::Vector3d p_;
};

ceres::LossFunction* MakeLoss(RobustLoss loss, double scale) {
  switch (loss) {
    case RobustLoss::kNone: return nullptr;
    case RobustLoss::kHuber: return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy: return new ceres::CauchyLoss(scale);
    case RobustLoss::kTukey: return new ceres::TukeyLoss(scale);
  }
  return nullptr;
}

}  // namespace

const std::vector<std::pair<std::string, RobustLoss>>& LossNames() {
  static const std::vector<std::pair<std::string, RobustLoss>> names{
      {"none", RobustLoss::kNone}, {"huber", RobustLoss::kHuber}, {"cauchy", RobustLoss::kCauchy},
      {"tukey", RobustLoss::kTukey}};
  return names;
}

const char* LossName(RobustLoss loss) { return pipeline::EnumName(LossNames(), loss); }

const pipeline::OptionTable<GeometricFitOptions>& GeometricFitOptions::Table() {
  using O = GeometricFitOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .AddEnum("initial", &O::initial,
                   {{"kasa", AlgebraicMethod::kKasa}, {"pratt", AlgebraicMethod::kPratt},
                    {"taubin", AlgebraicMethod::kTaubin}, {"hyper", AlgebraicMethod::kHyper}},
                   "start from this algebraic fit")
          .AddEnum("loss", &O::loss, LossNames(), "robust loss")
          .Add("loss_scale", &O::loss_scale_mm, "residual where the loss starts to down-weight", "mm").Min(1e-9)
          .AddEnum("derivatives", &O::analytic_derivatives, {{"analytic", true}, {"automatic", false}}, "Jacobians")
          .Add("max_iterations", &O::max_iterations, "Levenberg-Marquardt iterations at most", "iterations")
          .Range(1, 10000)
          .Add("covariance", &O::compute_covariance, "compute standard errors of centre and radius")
          .Add("threads", &O::num_threads, "Ceres threads, 0 = all cores", "threads").Range(0, 1024);
  return table;
}

void GeometricFitOptions::Check() const { Table().Validate(*this); }

SphereFitResult FitSphereGeometric(const std::vector<Eigen::Vector3d>& points_mm, const GeometricFitOptions& options,
                                   const Sphere* initial) {
  options.Check();
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(); };
  SphereFitResult r;
  r.method = "geometric";
  r.points_used = points_mm.size();
  if (auto reason = DegeneracyReason(points_mm)) {
    r.message = *reason;
    r.wall_ms = elapsed();
    return r;
  }
  Sphere start;
  if (initial) {
    start = *initial;
  } else {
    AlgebraicFitOptions ao;
    ao.method = options.initial;
    const SphereFitResult seed = FitSphereAlgebraic(points_mm, ao);
    if (!seed.converged) {
      r.message = "starting " + seed.method + " fit failed: " + seed.message;
      r.wall_ms = elapsed();
      return r;
    }
    start = seed.sphere;
  }
  // Solve for the centre relative to the points' mean: better conditioned far from the origin.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points_mm) mean += p;
  mean /= double(points_mm.size());
  double center[3] = {start.center_mm.x() - mean.x(), start.center_mm.y() - mean.y(), start.center_mm.z() - mean.z()};
  double radius = start.radius_mm;

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  std::unique_ptr<ceres::LossFunction> loss(MakeLoss(options.loss, options.loss_scale_mm));
  if (options.analytic_derivatives && !loss) {
    constexpr std::size_t kBlock = 256;
    for (std::size_t b = 0; b < points_mm.size(); b += kBlock) {
      std::vector<Eigen::Vector3d> block;
      for (std::size_t i = b; i < std::min(points_mm.size(), b + kBlock); ++i) block.push_back(points_mm[i] - mean);
      problem.AddResidualBlock(new SphereDistanceBlockCost(std::move(block)), nullptr, center, &radius);
    }
  } else {
    for (const auto& p : points_mm) {
      const Eigen::Vector3d q = p - mean;
      ceres::CostFunction* cost = options.analytic_derivatives
                                      ? static_cast<ceres::CostFunction*>(new SphereDistanceCost(q))
                                      : new ceres::AutoDiffCostFunction<SphereDistanceFunctor, 1, 3, 1>(
                                            new SphereDistanceFunctor(q));
      problem.AddResidualBlock(cost, loss.get(), center, &radius);
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = options.num_threads > 0 ? options.num_threads
                                           : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  r.iterations = static_cast<int>(summary.iterations.size()) - 1;
  r.sphere.center_mm = Eigen::Vector3d(center[0], center[1], center[2]) + mean;
  r.sphere.radius_mm = std::abs(radius);
  r.converged = summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
  if (!r.converged) r.message = "Ceres: " + summary.message;
  r.inliers = points_mm.size();
  r.rms_mm = RmsResidual(points_mm, r.sphere);

  if (options.compute_covariance && summary.IsSolutionUsable() && points_mm.size() > 4) {
    ceres::Covariance::Options co;
    co.num_threads = so.num_threads;
    ceres::Covariance covariance(co);
    std::vector<std::pair<const double*, const double*>> blocks = {{center, center}, {center, &radius}, {&radius, &radius}};
    if (covariance.Compute(blocks, &problem)) {
      double cc[9], cr[3], rr[1];
      covariance.GetCovarianceBlock(center, center, cc);
      covariance.GetCovarianceBlock(center, &radius, cr);
      covariance.GetCovarianceBlock(&radius, &radius, rr);
      (void)cr;
      // Ceres assumes unit-variance residuals; scale by the estimated residual variance.
      const double dof = double(points_mm.size()) - 4.0;
      const double sigma2 = 2.0 * summary.final_cost / dof;
      r.std_error_mm = Eigen::Vector4d(std::sqrt(cc[0] * sigma2), std::sqrt(cc[4] * sigma2), std::sqrt(cc[8] * sigma2),
                                       std::sqrt(rr[0] * sigma2));
    } else if (r.message.empty()) {
      r.message = "covariance is rank deficient; no standard errors";
    }
  }
  r.wall_ms = elapsed();
  return r;
}

std::optional<Sphere> RefitSphereGeometric(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& start,
                                           int max_iterations) {
  if (points_mm.size() < 4) return std::nullopt;
  // Relative to the points' mean, as FitSphereGeometric: better conditioned far from the origin.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points_mm) mean += p;
  mean /= double(points_mm.size());
  Eigen::Vector4d x;
  x << start.center_mm - mean, start.radius_mm;
  for (int it = 0; it < max_iterations; ++it) {
    // Residual e = |p - c| - r; de/dc = -(p - c) / |p - c|, de/dr = -1. The normal equations as
    // sums (Eigen's rank update of a 4 x 4 costs twice as much per point here).
    const Eigen::Vector3d c = mean + x.head<3>();
    double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0, sx = 0, sy = 0, sz = 0, gx = 0, gy = 0, gz = 0, gr = 0;
    double count = 0;
    for (const auto& p : points_mm) {
      const Eigen::Vector3d d = p - c;
      const double n = d.norm();
      if (!(n > 0)) continue;
      const Eigen::Vector3d u = d / n;  // -J's centre part
      const double e = n - x[3];
      xx += u.x() * u.x(), xy += u.x() * u.y(), xz += u.x() * u.z();
      yy += u.y() * u.y(), yz += u.y() * u.z(), zz += u.z() * u.z();
      sx += u.x(), sy += u.y(), sz += u.z();
      gx -= u.x() * e, gy -= u.y() * e, gz -= u.z() * e, gr -= e;
      count += 1;
    }
    Eigen::Matrix4d H;
    H << xx, xy, xz, sx, xy, yy, yz, sy, xz, yz, zz, sz, sx, sy, sz, count;
    const Eigen::Vector4d g(gx, gy, gz, gr);
    const Eigen::LDLT<Eigen::Matrix4d> ldlt(H);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return std::nullopt;
    const Eigen::Vector4d step = -ldlt.solve(g);
    if (!step.allFinite()) return std::nullopt;
    x += step;
    // A nanometre: far below any fit's uncertainty, and where FitSphereGeometric's tolerances stop.
    if (step.cwiseAbs().maxCoeff() < 1e-6) {
      Sphere s;
      s.center_mm = x.head<3>() + mean;
      s.radius_mm = std::abs(x[3]);
      return s;
    }
  }
  return std::nullopt;
}

std::optional<Sphere> RefitSphereHuber(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& start, double huber_mm,
                                       int max_iterations, double tolerance_mm) {
  if (points_mm.size() < 4 || !(huber_mm > 0)) return std::nullopt;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points_mm) mean += p;
  mean /= double(points_mm.size());
  // Ceres' HuberLoss(k) on e^2, halved: e^2 / 2 within k, k |e| - k^2 / 2 beyond.
  auto cost = [&](const Eigen::Vector4d& x) {
    const Eigen::Vector3d c = mean + x.head<3>();
    double sum = 0;
    for (const auto& p : points_mm) {
      const double e = std::abs((p - c).norm() - x[3]);
      sum += e <= huber_mm ? 0.5 * e * e : huber_mm * e - 0.5 * huber_mm * huber_mm;
    }
    return sum;
  };
  Eigen::Vector4d x;
  x << start.center_mm - mean, start.radius_mm;
  double f = cost(x), lambda = 1e-4;
  for (int it = 0; it < max_iterations; ++it) {
    // The weighted normal equations: weight 1 within the loss's scale, k / |e| beyond (the
    // Huber loss's own second-order model along the residual, as Ceres' Corrector makes it).
    const Eigen::Vector3d c = mean + x.head<3>();
    Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
    Eigen::Vector4d g = Eigen::Vector4d::Zero();
    for (const auto& p : points_mm) {
      const Eigen::Vector3d d = p - c;
      const double n = d.norm();
      if (!(n > 0)) continue;
      const double e = n - x[3];
      const double w = std::abs(e) <= huber_mm ? 1.0 : huber_mm / std::abs(e);
      Eigen::Vector4d j;
      j << -d / n, -1.0;
      H.selfadjointView<Eigen::Upper>().rankUpdate(j, w);
      g += w * e * j;
    }
    H = H.selfadjointView<Eigen::Upper>();
    // Levenberg-Marquardt's damping, as Ceres': a small cap of a large sphere leaves the centre
    // along its axis and the radius nearly one parameter, and Gauss-Newton's step there is
    // rounding.
    bool stepped = false;
    for (int tries = 0; tries < 10 && !stepped; ++tries) {
      Eigen::Matrix4d Hd = H;
      Hd.diagonal() += lambda * H.diagonal().cwiseMax(1e-12);
      const Eigen::Vector4d step = -Hd.ldlt().solve(g);
      const double f_try = step.allFinite() ? cost(x + step) : std::numeric_limits<double>::infinity();
      if (f_try <= f) {
        x += step, f = f_try, lambda = std::max(1e-9, lambda / 3), stepped = true;
        if (step.cwiseAbs().maxCoeff() < tolerance_mm) {
          Sphere s;
          s.center_mm = x.head<3>() + mean;
          s.radius_mm = std::abs(x[3]);
          return s;
        }
      } else {
        lambda *= 4;
      }
    }
    if (!stepped) return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace hedgefit::fitting
