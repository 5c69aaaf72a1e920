#include "fitting/ellipsoid_fit.hpp"

#include <Eigen/Dense>
#include <ceres/ceres.h>

#include <chrono>
#include <cmath>
#include <memory>

#include "pipeline/error.hpp"
#include "fitting/geometric_fit.hpp"

namespace hedgefit::fitting {

EllipsoidFit FitEllipsoid(const std::vector<Eigen::Vector3d>& points_mm) {
  const auto t0 = std::chrono::steady_clock::now();
  EllipsoidFit out;
  auto done = [&] {
    out.wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return out;
  };
  if (points_mm.size() < 9) {
    out.message = "an ellipsoid needs at least 9 points";
    return done();
  }
  if (auto why = DegeneracyReason(points_mm)) {
    out.message = *why;
    return done();
  }
  // Centre and scale to unit RMS radius: the design matrix is then well conditioned.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points_mm) mean += p;
  mean /= double(points_mm.size());
  double s2 = 0;
  for (const auto& p : points_mm) s2 += (p - mean).squaredNorm();
  const double scale = std::sqrt(s2 / double(points_mm.size()));
  // Rows: x^2 y^2 z^2 2yz 2xz 2xy | 2x 2y 2z 1.
  Eigen::Matrix<double, 10, 10> S = Eigen::Matrix<double, 10, 10>::Zero();
  for (const auto& p : points_mm) {
    const Eigen::Vector3d q = (p - mean) / scale;
    Eigen::Matrix<double, 10, 1> d;
    d << q.x() * q.x(), q.y() * q.y(), q.z() * q.z(), 2 * q.y() * q.z(), 2 * q.x() * q.z(), 2 * q.x() * q.y(), 2 * q.x(),
        2 * q.y(), 2 * q.z(), 1;
    S += d * d.transpose();
  }
  const Eigen::Matrix<double, 6, 6> S11 = S.topLeftCorner<6, 6>();
  const Eigen::Matrix<double, 6, 4> S12 = S.topRightCorner<6, 4>();
  const Eigen::Matrix<double, 4, 4> S22 = S.bottomRightCorner<4, 4>();
  // The constraint 4J - I^2 = 1 (k = 4), which makes the quadric an ellipsoid.
  Eigen::Matrix<double, 6, 6> C = Eigen::Matrix<double, 6, 6>::Zero();
  C.topLeftCorner<3, 3>() << -1, 1, 1, 1, -1, 1, 1, 1, -1;
  C(3, 3) = C(4, 4) = C(5, 5) = -4;
  const Eigen::Matrix<double, 4, 6> T = -S22.ldlt().solve(S12.transpose());
  const Eigen::Matrix<double, 6, 6> M = C.inverse() * (S11 + S12 * T);
  Eigen::EigenSolver<Eigen::Matrix<double, 6, 6>> es(M);
  int best = -1;
  for (int k = 0; k < 6; ++k) {
    if (std::abs(es.eigenvalues()[k].imag()) < 1e-9 && es.eigenvalues()[k].real() > 0 &&
        (best < 0 || es.eigenvalues()[k].real() > es.eigenvalues()[best].real())) {
      best = k;
    }
  }
  if (best < 0) {
    out.message = "no ellipsoid fits these points";
    return done();
  }
  const Eigen::Matrix<double, 6, 1> v1 = es.eigenvectors().col(best).real();
  const Eigen::Matrix<double, 4, 1> v2 = T * v1;
  Eigen::Matrix3d A;
  A << v1[0], v1[5], v1[4], v1[5], v1[1], v1[3], v1[4], v1[3], v1[2];
  const Eigen::Vector3d b(v2[0], v2[1], v2[2]);
  const double d = v2[3];
  // (q - c)^T A (q - c) = c^T A c - d, with c = -A^-1 b.
  const Eigen::Vector3d c = -A.ldlt().solve(b);
  const double k = c.dot(A * c) - d;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A / k);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0) || !c.allFinite()) {
    out.message = "the fitted quadric is not an ellipsoid";
    return done();
  }
  // Axes largest first: the smallest eigenvalue is the longest axis.
  for (int i = 0; i < 3; ++i) {
    out.axes_mm[i] = scale / std::sqrt(eig.eigenvalues()[i]);
    out.directions.col(i) = eig.eigenvectors().col(i);
  }
  out.center_mm = mean + scale * c;
  // The axes closest to the camera's y (down in the image) and x: both lie across the line of
  // sight, where a cap seen from the front constrains them well (the depth axis is looser).
  auto closest = [&](int row) {
    int best_axis = 0;
    for (int i = 1; i < 3; ++i) {
      if (std::abs(out.directions(row, i)) > std::abs(out.directions(row, best_axis))) best_axis = i;
    }
    return best_axis;
  };
  out.vertical_axis_mm = out.axes_mm[closest(1)];
  out.horizontal_axis_mm = out.axes_mm[closest(0)];
  // First-order distance |Q(q)| / |grad Q(q)| per point, in mm.
  const Eigen::Matrix3d An = A / k;
  double sum = 0;
  for (const auto& p : points_mm) {
    const Eigen::Vector3d q = (p - mean) / scale - c;
    const double value = q.dot(An * q) - 1;
    const double grad = (2 * An * q).norm();
    const double dist = grad > 0 ? value / grad : 0;
    sum += dist * dist;
  }
  out.rms_mm = scale * std::sqrt(sum / double(points_mm.size()));
  out.converged = true;
  return done();
}

const pipeline::OptionTable<SpheroidFitOptions>& SpheroidFitOptions::Table() {
  using O = SpheroidFitOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("up", &O::up, "the vertical in the cloud's frame ([0, -1, 0]: a level camera, y down)")
          .Add("loss_scale", &O::loss_scale_mm, "Huber loss scale: larger residuals are down-weighted", "mm").Min(1e-6);
  return table;
}

void SpheroidFitOptions::Check() const {
  Table().Validate(*this);
  if (!(up.norm() > 0)) throw Error("option 'up': give a non-zero vertical direction");
}

namespace {

// Radial distance from the surface (x^2 + y^2) / a^2 + h^2 / b^2 = 1 (h along up), along the ray
// from the centre: |q| (1 - 1 / sqrt(rho^2 / a^2 + h^2 / b^2)); exact for a sphere, first order
// in the flattening otherwise.
struct SpheroidResidual {
  Eigen::Vector3d p;
  Eigen::Vector3d up;
  template <class T>
  bool operator()(const T* c, const T* a, const T* b, T* residual) const {
    const T qx = T(p.x()) - c[0], qy = T(p.y()) - c[1], qz = T(p.z()) - c[2];
    const T h = qx * T(up.x()) + qy * T(up.y()) + qz * T(up.z());
    const T n2 = qx * qx + qy * qy + qz * qz;
    const T rho2 = n2 - h * h;
    using std::sqrt;
    const T k = sqrt(rho2 / (a[0] * a[0]) + h * h / (b[0] * b[0]));
    residual[0] = sqrt(n2) * (T(1) - T(1) / k);
    return true;
  }
};

}  // namespace

EllipsoidFit FitSpheroid(const std::vector<Eigen::Vector3d>& points_mm, const SpheroidFitOptions& options) {
  options.Check();
  const auto t0 = std::chrono::steady_clock::now();
  EllipsoidFit out;
  auto done = [&] {
    out.wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return out;
  };
  GeometricFitOptions go;
  go.compute_covariance = false;
  const SphereFitResult start = FitSphereGeometric(points_mm, go);
  if (!start.converged) {
    out.message = "no starting sphere: " + start.message;
    return done();
  }
  const Eigen::Vector3d up = options.up.normalized();
  // Centred on the starting centre: the parameters are then small numbers of the same size.
  const Eigen::Vector3d origin = start.sphere.center_mm;
  double c[3] = {0, 0, 0}, a = start.sphere.radius_mm, b = start.sphere.radius_mm;
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // one loss for every residual
  ceres::Problem problem(problem_options);
  const std::unique_ptr<ceres::LossFunction> loss(new ceres::HuberLoss(options.loss_scale_mm));
  for (const auto& p : points_mm) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<SpheroidResidual, 1, 3, 1, 1>(
                                 new SpheroidResidual{p - origin, up}),
                             loss.get(), c, &a, &b);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = 100;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable() || !(a > 0) || !(b > 0) || !std::isfinite(a) || !std::isfinite(b)) {
    out.message = "the spheroid fit did not converge: " + summary.message;
    return done();
  }
  out.converged = true;
  out.center_mm = origin + Eigen::Vector3d(c[0], c[1], c[2]);
  // Any two horizontal directions complete the frame.
  Eigen::Vector3d h1 = up.unitOrthogonal(), h2 = up.cross(h1);
  if (a >= b) {
    out.axes_mm = Eigen::Vector3d(a, a, b);
    out.directions.col(0) = h1, out.directions.col(1) = h2, out.directions.col(2) = up;
  } else {
    out.axes_mm = Eigen::Vector3d(b, a, a);
    out.directions.col(0) = up, out.directions.col(1) = h1, out.directions.col(2) = h2;
  }
  out.vertical_axis_mm = b;
  out.horizontal_axis_mm = a;
  double ss = 0;
  for (const auto& p : points_mm) {
    double r = 0;
    SpheroidResidual{p - origin, up}(c, &a, &b, &r);
    ss += r * r;
  }
  out.rms_mm = std::sqrt(ss / double(points_mm.size()));
  return done();
}

}  // namespace hedgefit::fitting
