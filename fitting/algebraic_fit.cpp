#include "fitting/algebraic_fit.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>
#include <optional>

#include "pipeline/parallel.hpp"
namespace hedgefit::fitting {

namespace {

using Matrix5d = Eigen::Matrix<double, 5, 5>;
using Vector5d = Eigen::Matrix<double, 5, 1>;

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Runs fn(begin, end, &partial) on fixed slices of [0, n) and returns the partial results in
// slice order, so their sum does not depend on timing; small inputs stay on one slice.
template <class Acc, class Fn>
std::vector<Acc> Slices(std::size_t n, Fn fn) {
  constexpr std::size_t kSlice = 100000;
  const std::size_t slices = n >= 2 * kSlice ? (n + kSlice - 1) / kSlice : 1;
  const std::size_t grain = (n + slices - 1) / std::max<std::size_t>(1, slices);
  std::vector<Acc> acc(slices);
  pipeline::ParallelFor(n, 0, std::max<std::size_t>(1, grain),
                     [&](std::size_t b, std::size_t e) { fn(b, e, &acc[b / std::max<std::size_t>(1, grain)]); });
  return acc;
}

// Centred moments of the points, in one pass after the mean: everything the four fits,
// the degeneracy check and the radius need. q = p - mean, z = |q|^2.
struct Moments {
  std::size_t n = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d qq = Eigen::Matrix3d::Zero();  // mean(q q^T)
  Eigen::Vector3d qz = Eigen::Vector3d::Zero();  // mean(q z)
  double z = 0;                                   // mean(z)
  double zz = 0;                                  // mean(z^2)
  bool finite = true;
};

Moments ComputeMoments(const std::vector<Eigen::Vector3d>& pts) {
  Moments m;
  m.n = pts.size();
  const auto sums = Slices<Eigen::Vector3d>(pts.size(), [&](std::size_t b, std::size_t e, Eigen::Vector3d* out) {
    Eigen::Vector3d s = Eigen::Vector3d::Zero();
    for (std::size_t i = b; i < e; ++i) s += pts[i];
    *out = s;
  });
  for (const auto& s : sums) m.mean += s;
  m.mean /= double(pts.size());
  if (!m.mean.allFinite()) {
    m.finite = false;
    return m;
  }
  struct Acc {
    double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz_ = 0, x3 = 0, y3 = 0, z3 = 0, z = 0, z2 = 0;
  };
  const Eigen::Vector3d c = m.mean;
  const auto accs = Slices<Acc>(pts.size(), [&](std::size_t b, std::size_t e, Acc* out) {
    Acc a;
    for (std::size_t i = b; i < e; ++i) {
      const double x = pts[i].x() - c.x(), y = pts[i].y() - c.y(), w = pts[i].z() - c.z();
      const double q2 = x * x + y * y + w * w;
      a.xx += x * x;
      a.xy += x * y;
      a.xz += x * w;
      a.yy += y * y;
      a.yz += y * w;
      a.zz_ += w * w;
      a.x3 += x * q2;
      a.y3 += y * q2;
      a.z3 += w * q2;
      a.z += q2;
      a.z2 += q2 * q2;
    }
    *out = a;
  });
  Acc t;
  for (const auto& a : accs) {
    t.xx += a.xx, t.xy += a.xy, t.xz += a.xz, t.yy += a.yy, t.yz += a.yz, t.zz_ += a.zz_;
    t.x3 += a.x3, t.y3 += a.y3, t.z3 += a.z3, t.z += a.z, t.z2 += a.z2;
  }
  const double inv = 1.0 / double(pts.size());
  m.qq << t.xx, t.xy, t.xz, t.xy, t.yy, t.yz, t.xz, t.yz, t.zz_;
  m.qq *= inv;
  m.qz = Eigen::Vector3d(t.x3, t.y3, t.z3) * inv;
  m.z = t.z * inv;
  m.zz = t.z2 * inv;
  m.finite = m.qq.allFinite() && m.qz.allFinite() && std::isfinite(m.zz);
  return m;
}

// METHOD.md's corrected Kasa equations on centred data q = p - mean (so mean(q) = 0):
//   Cov(q) c = 1/2 mean(q |q|^2),   r^2 = mean(|q|^2) + |c|^2.
bool Kasa(const Moments& m, Sphere* out) {
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(m.qq);
  if (ldlt.info() != Eigen::Success) return false;
  const Eigen::Vector3d c = ldlt.solve(0.5 * m.qz);
  out->center_mm = c + m.mean;
  out->radius_mm = std::sqrt(m.z + c.squaredNorm());
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
bool GeneralisedFit(const Moments& mo, AlgebraicMethod method, Sphere* out) {
  // Scale so that mean |q|^2 = 1: M's entries in the scaled frame follow from the moments.
  const double s = std::sqrt(mo.z);
  const double s2 = mo.z, s3 = s2 * s, s4 = s2 * s2;
  Matrix5d m = Matrix5d::Zero();  // mean(u u^T), u = (z, qx, qy, qz, 1) in the scaled frame
  m(0, 0) = mo.zz / s4;
  m.block<1, 3>(0, 1) = (mo.qz / s3).transpose();
  m(0, 4) = mo.z / s2;  // = 1
  m.block<3, 3>(1, 1) = mo.qq / s2;
  m(4, 4) = 1.0;
  m = m.selfadjointView<Eigen::Upper>();

  const Eigen::SelfAdjointEigenSolver<Matrix5d> eig(m);
  const Vector5d lambda = eig.eigenvalues();
  const Matrix5d v = eig.eigenvectors();
  Vector5d a;
  if (lambda[0] <= 1e-14 * lambda[4]) {
    a = v.col(0);  // the points satisfy the sphere equation exactly
  } else {
    const Vector5d inv_sqrt = lambda.cwiseSqrt().cwiseInverse();
    const Matrix5d y_inv = v * inv_sqrt.asDiagonal() * v.transpose();
    const Matrix5d k = y_inv * Constraint(method) * y_inv;
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
  out->center_mm = c * s + mo.mean;
  out->radius_mm = std::sqrt(r2) * s;
  return out->center_mm.allFinite() && std::isfinite(out->radius_mm);
}

double ParallelRms(const std::vector<Eigen::Vector3d>& pts, const Sphere& sphere) {
  const auto parts = Slices<double>(pts.size(), [&](std::size_t b, std::size_t e, double* out) {
    double ss = 0;
    for (std::size_t i = b; i < e; ++i) {
      const double r = (pts[i] - sphere.center_mm).norm() - sphere.radius_mm;
      ss += r * r;
    }
    *out = ss;
  });
  double ss = 0;
  for (double p : parts) ss += p;
  return std::sqrt(ss / double(pts.size()));
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
  std::optional<std::string> reason;
  Moments m;
  if (points_mm.size() < 4) {
    reason = "need at least 4 points to fit a sphere, got " + std::to_string(points_mm.size());
  } else {
    m = ComputeMoments(points_mm);
    reason = DegeneracyFromMoments(m.n, m.finite, m.mean, m.qq);
  }
  if (reason) {
    r.message = *reason;
    r.wall_ms = MsSince(t0);
    return r;
  }
  const bool ok = options.method == AlgebraicMethod::kKasa ? Kasa(m, &r.sphere)
                                                           : GeneralisedFit(m, options.method, &r.sphere);
  if (!ok) {
    r.message = "the points fit a plane better than any sphere (infinite radius)";
    r.wall_ms = MsSince(t0);
    return r;
  }
  r.converged = true;
  r.inliers = points_mm.size();
  r.rms_mm = ParallelRms(points_mm, r.sphere);
  r.wall_ms = MsSince(t0);
  return r;
}

}  // namespace hedgefit::fitting
