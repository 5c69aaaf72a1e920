#include "fitting/ray_fit.hpp"

#include <Eigen/Dense>

#include <chrono>
#include <cmath>

namespace hedgefit::fitting {

namespace {

struct Normal {
  Eigen::Matrix4d h = Eigen::Matrix4d::Zero();
  Eigen::Vector4d g = Eigen::Vector4d::Zero();
  double ssr = 0;
  std::size_t n = 0;
};

// The residuals' normal equations at sphere (c, r), all relative to the origin: for a ray that
// meets the sphere well inside its outline, e = t - t0 with t0 = b - s, b = u.c,
// s = sqrt(b^2 - |c|^2 + r^2), so de/dc = -(u - (b u - c) / s) and de/dr = r / s; for the
// others e = (|q - c| - r) / min_chord, de/dc = -(q - c) / (|q - c| min_chord), de/dr = -1 / min_chord.
// `along` says per point which form it takes. Empty: decided here (and stored) by where the ray
// passes at this sphere. Given: kept, so that a step's sum of squares is compared with the same
// forms, the problem smooth within one Gauss-Newton iteration (a point switching form mid-search
// puts a kink in it, where the steps stall); a ray the sphere moves off keeps a smooth residual.
Normal Accumulate(const std::vector<Eigen::Vector3d>& q, const Eigen::Vector3d& c, double r, double min_chord,
                  std::vector<char>* along) {
  Normal out;
  const double c2 = c.squaredNorm(), floor2 = min_chord * min_chord * r * r;
  const bool decide = along->size() != q.size();
  if (decide) along->assign(q.size(), 0);
  for (std::size_t i = 0; i < q.size(); ++i) {
    const Eigen::Vector3d& p = q[i];
    const double t = p.norm();
    if (!(t > 0)) continue;
    const Eigen::Vector3d u = p / t;
    const double b = u.dot(c), disc = b * b - c2 + r * r;
    if (decide) (*along)[i] = disc > floor2;
    Eigen::Vector4d j;
    double e;
    if ((*along)[i]) {
      // s = sqrt(disc), the half-chord; below half the band's edge it continues along its tangent
      // (in disc), so a ray the sphere moves off keeps a smooth residual instead of none.
      const double s0 = 0.5 * min_chord * r, d0 = s0 * s0;
      const double s = disc >= d0 ? std::sqrt(disc) : s0 + (disc - d0) / (2 * s0);
      const double ds = disc >= d0 ? 1 / (2 * s) : 1 / (2 * s0);  // ds / d(disc)
      e = t - (b - s);
      // d(disc)/dc = 2 (b u - c), d(disc)/dr = 2 r; t0 = b - s.
      j << -(u - 2 * ds * (b * u - c)), 2 * ds * r;
    } else {
      const Eigen::Vector3d d = p - c;
      const double n = d.norm();
      if (!(n > 0)) continue;
      // Divided by min_chord, the cosine of incidence at the band's edge (half-chord / r): there a
      // range error moves the orthogonal distance by that cosine, so the two forms meet and the
      // sum of squares stays continuous as a ray crosses from one to the other.
      e = (n - r) / min_chord;
      j << -d / (n * min_chord), -1.0 / min_chord;
    }
    out.h.noalias() += j * j.transpose();
    out.g += j * e;
    out.ssr += e * e;
    ++out.n;
  }
  return out;
}

}  // namespace

SphereFitResult FitSphereAlongRays(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& start,
                                   const RayFitOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  SphereFitResult r;
  r.method = "ray";
  r.points_used = points_mm.size();
  auto finish = [&](const std::string& message) {
    r.message = message;
    r.wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return r;
  };
  if (points_mm.size() < 4) return finish("fewer than 4 points");
  std::vector<Eigen::Vector3d> q;
  q.reserve(points_mm.size());
  for (const auto& p : points_mm) q.push_back(p - options.origin_mm);
  Eigen::Vector3d c = start.center_mm - options.origin_mm;
  double radius = start.radius_mm;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : q) mean += p;
  if (c.dot(mean) <= 0) return finish("the sphere is behind the sensor's origin; give the cloud's origin");
  // Which form each point takes is decided where the sphere is, then kept while Gauss-Newton
  // settles (its sum of squares is then smooth: a point switching form mid-search can jump it when
  // the point is far off the sphere, and the steps cycle); decided again at the answer, until no
  // point changes form (or for at most kRounds rounds: the last answer is a least-squares sphere
  // with its points' forms fixed).
  constexpr int kRounds = 5;
  std::vector<char> along;
  Normal ne = Accumulate(q, c, radius, options.min_chord, &along);
  bool settled = false;
  int iterations = 0;
  for (int round = 0; round < kRounds; ++round) {
    settled = false;
    for (int it = 0; it < options.max_iterations && !settled; ++it, ++iterations) {
      if (c.norm() <= radius) return finish("the sensor's origin lies inside the sphere; give the cloud's origin");
      const Eigen::LDLT<Eigen::Matrix4d> ldlt(ne.h);
      if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return finish("singular system");
      const Eigen::Vector4d step = -ldlt.solve(ne.g);
      if (!step.allFinite()) return finish("singular system");
      // Halving a step that raises the sum of squares.
      double scale = 1.0;
      Normal next;
      for (int halve = 0; halve < 20; ++halve, scale *= 0.5) {
        next = Accumulate(q, c + scale * step.head<3>(), radius + scale * step[3], options.min_chord, &along);
        if (next.ssr <= ne.ssr * (1 + 1e-12)) break;
      }
      c += scale * step.head<3>();
      radius += scale * step[3];
      ne = next;
      // A nanometre: far below any fit's uncertainty, as RefitSphereGeometric.
      settled = (scale * step).cwiseAbs().maxCoeff() < 1e-6;
    }
    if (!settled) break;
    std::vector<char> decided;
    const Normal fresh = Accumulate(q, c, radius, options.min_chord, &decided);
    if (decided == along) break;
    along = std::move(decided);
    ne = fresh;
  }
  r.iterations = iterations;
  if (!settled) return finish("no settling within " + std::to_string(options.max_iterations) + " iterations");
  if (c.norm() <= radius) return finish("the sensor's origin lies inside the sphere; give the cloud's origin");
  r.sphere.center_mm = c + options.origin_mm;
  r.sphere.radius_mm = radius;
  r.converged = radius > 0;
  if (!r.converged) return finish("the radius went to zero");
  r.inliers = ne.n;
  r.rms_mm = RmsResidual(points_mm, r.sphere);
  if (ne.n > 4) {
    const Eigen::Matrix4d cov = ne.h.inverse() * (ne.ssr / double(ne.n - 4));
    r.std_error_mm = cov.diagonal().cwiseMax(0).cwiseSqrt();
  }
  return finish("");
}

}  // namespace hedgefit::fitting
