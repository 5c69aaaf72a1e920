#include "fitting/algebraic_fit.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>

namespace hedgefit::fitting {

namespace {

using Matrix5d = Eigen::Matrix<double, 5, 5>;
using Vector5d = Eigen::Matrix<double, 5, 1>;

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

Eigen::Vector3d Mean(const std::vector<Eigen::Vector3d>& pts) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (const auto& p : pts) m += p;
  return m / double(pts.size());
}

// METHOD.md's corrected Kasa equations on centred data q = p - mean (so mean(q) = 0):
//   Cov(q) c = 1/2 mean(q |q|^2),   r^2 = mean(|q|^2) + |c|^2.
bool Kasa(const std::vector<Eigen::Vector3d>& pts, Sphere* out) {
  const Eigen::Vector3d mean = Mean(pts);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  double mean_sq = 0.0;
  for (const auto& p : pts) {
    const Eigen::Vector3d q = p - mean;
    const double q2 = q.squaredNorm();
    cov.noalias() += q * q.transpose();
    rhs += q * q2;
    mean_sq += q2;
  }
  const double n = double(pts.size());
  cov /= n;
  rhs /= 2.0 * n;
  mean_sq /= n;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(cov);
  if (ldlt.info() != Eigen::Success) return false;
  const Eigen::Vector3d c = ldlt.solve(rhs);
  out->center_mm = c + mean;
  out->radius_mm = std::sqrt(mean_sq + c.squaredNorm());
  return c.allFinite();
}

// The constraint matrix N of a^T N a = 1 for a = (A, B, D) of A|q|^2 + B.q + D = 0, for
// data centred (mean(q) = 0) and scaled (mean |q|^2 = 1).
Matrix5d Constraint(AlgebraicMethod method) {
  Matrix5d pratt = Matrix5d::Zero();  // |B|^2 - 4 A D
  pratt.block<3, 3>(1, 1).setIdentity();
  pratt(0, 4) = pratt(4, 0) = -2.0;
  Matrix5d taubin = Matrix5d::Zero();  // mean |grad|^2 = 4 A^2 mean|q|^2 + |B|^2
  taubin(0, 0) = 4.0;
  taubin.block<3, 3>(1, 1).setIdentity();
  switch (method) {
    case AlgebraicMethod::kPratt: return pratt;
    case AlgebraicMethod::kTaubin: return taubin;
    case AlgebraicMethod::kHyper: return 2.0 * taubin - pratt;
    case AlgebraicMethod::kKasa: break;
  }
  return taubin;
}

// Minimises a^T M a subject to a^T N a = 1. With M = V L V^T and Y = V L^(1/2) V^T, b = Y a
// turns it into maximising b^T K b / b^T b, K = Y^-1 N Y^-1 (symmetric): b is K's top
// eigenvector. Exact data (M singular) give the null vector of M directly.
bool GeneralisedFit(const std::vector<Eigen::Vector3d>& pts, AlgebraicMethod method, Sphere* out) {
  const Eigen::Vector3d mean = Mean(pts);
  double spread = 0.0;
  for (const auto& p : pts) spread += (p - mean).squaredNorm();
  const double s = std::sqrt(spread / double(pts.size()));
  const double inv_s = 1.0 / s;
  Matrix5d m = Matrix5d::Zero();
  for (const auto& p : pts) {
    const Eigen::Vector3d q = (p - mean) * inv_s;
    Vector5d u;
    u << q.squaredNorm(), q.x(), q.y(), q.z(), 1.0;
    m.selfadjointView<Eigen::Lower>().rankUpdate(u);
  }
  m = m.selfadjointView<Eigen::Lower>();
  m /= double(pts.size());

  const Eigen::SelfAdjointEigenSolver<Matrix5d> eig(m);
  const Vector5d lambda = eig.eigenvalues();
  const Matrix5d v = eig.eigenvectors();
  Vector5d a;
  if (lambda[0] <= 1e-14 * lambda[4]) {
    a = v.col(0);  // the points satisfy the sphere equation exactly
  } else {
    const Vector5d inv_sqrt = lambda.cwiseSqrt().cwiseInverse();
    const Matrix5d y_inv = v * inv_sqrt.asDiagonal() * v.transpose();
    const Matrix5d n = Constraint(method);
    const Matrix5d k = y_inv * n * y_inv;
    const Eigen::SelfAdjointEigenSolver<Matrix5d> keig(0.5 * (k + k.transpose()));
    if (!(keig.eigenvalues()[4] > 0)) return false;
    a = y_inv * keig.eigenvectors().col(4);
  }
  const double A = a[0];
  const Eigen::Vector3d B = a.segment<3>(1);
  const double D = a[4];
  if (!(std::abs(A) > 1e-12 * a.norm())) return false;  // a plane: infinite radius
  const Eigen::Vector3d c = -B / (2.0 * A);
  const double r2 = (B.squaredNorm() - 4.0 * A * D) / (4.0 * A * A);
  if (!(r2 > 0)) return false;
  out->center_mm = c * s + mean;
  out->radius_mm = std::sqrt(r2) * s;
  return out->center_mm.allFinite() && std::isfinite(out->radius_mm);
}

}  // namespace

const char* MethodName(AlgebraicMethod method) {
  switch (method) {
    case AlgebraicMethod::kKasa: return "kasa";
    case AlgebraicMethod::kPratt: return "pratt";
    case AlgebraicMethod::kTaubin: return "taubin";
    case AlgebraicMethod::kHyper: return "hyper";
  }
  return "?";
}

SphereFitResult FitSphereAlgebraic(const std::vector<Eigen::Vector3d>& points_mm, const AlgebraicFitOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  SphereFitResult r;
  r.method = MethodName(options.method);
  r.points_used = points_mm.size();
  if (auto reason = DegeneracyReason(points_mm)) {
    r.message = *reason;
    r.wall_ms = MsSince(t0);
    return r;
  }
  const bool ok = options.method == AlgebraicMethod::kKasa ? Kasa(points_mm, &r.sphere)
                                                           : GeneralisedFit(points_mm, options.method, &r.sphere);
  if (!ok) {
    r.message = "the points fit a plane better than any sphere (infinite radius)";
    r.wall_ms = MsSince(t0);
    return r;
  }
  r.converged = true;
  r.inliers = points_mm.size();
  r.rms_mm = RmsResidual(points_mm, r.sphere);
  r.wall_ms = MsSince(t0);
  return r;
}

}  // namespace hedgefit::fitting
