// FitClippedShape: a ball, a spheroid and an ellipsoid with a vertical axis fitted by robust
// Gauss-Newton on the radial distance, and one chosen by BIC; measured, its height refitted on the
// distance along the normal (shape_fit.hpp).

#include "fitting/shape_fit.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "fitting/log_erfc.hpp"

namespace hedgefit::fitting {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The measured fit's trim, in robust deviations (1.4826 MAD) of the residuals. Chosen on the
// simulated topiary beds' tuning seeds 1-3 (bench find --beds 3 --gardens 0, aerial and
// photogrammetry): the worst semi-axis error 3.2 % untrimmed, 2.9 % at 4, 2.4 % at 3, 1.8 % at 2.5,
// 1.9 % at 2; reported on the held-back seeds in docs/accuracy.md.
constexpr double kTrimDeviations = 2.5;
// A prism's robust spread over the chosen quadric's, at most, for the prism to be chosen
// (ChooseFamily).
constexpr double kPrismSpreadShare = 0.6;
// The share of a prism's walls that must hold points (WallCover), at least: half of its sides. A
// box in a bed may hide a side or two behind its neighbours; a slab hides all of them.
constexpr double kMinWallCover = 0.5;

double MedianOf(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double RobustSpread(const std::vector<double>& e) {
  const double med = MedianOf(e);
  std::vector<double> dev(e.size());
  for (std::size_t i = 0; i < e.size(); ++i) dev[i] = std::abs(e[i] - med);
  return 1.4826 * MedianOf(dev);
}


// The shape family: which of the seven parameters (cx, cy, cz, a, b, c, heading) are free. The
// quadrics' are their own; a prism (a drum, a box, a cone) stands on the ground, so its free parameters are
// its top's height in place of cz and c: cz = (top + ground) / 2, c = (top - ground) / 2.
// A cone stands on the ground as a drum does (centre, base radius, apex height), its side slanting
// from the base's rim to the apex on the axis.
enum class Family { kBall = 0, kSpheroid = 1, kEllipsoid = 2, kCylinder = 3, kCuboid = 4, kCone = 5 };
int FreeCount(Family f) {
  switch (f) {
    case Family::kBall: return 4;
    case Family::kSpheroid: return 5;
    case Family::kCylinder: return 4;
    case Family::kCone: return 4;
    case Family::kCuboid: return 6;
    default: return 7;
  }
}
// A shape standing on the ground, fitted on its signed distance: a drum, a box or a cone.
bool Prism(Family f) { return f == Family::kCylinder || f == Family::kCuboid || f == Family::kCone; }
// The free parameter that is a heading (radians), or -1.
int HeadingIndex(Family f) { return f == Family::kEllipsoid ? 6 : f == Family::kCuboid ? 5 : -1; }

using Full = Eigen::Matrix<double, 7, 1>;

Full Expand(const Eigen::VectorXd& x, Family f, double heading, double ground) {
  Full q;
  q.head<3>() = x.head<3>();
  if (f == Family::kBall) {
    q(3) = q(4) = q(5) = x(3), q(6) = heading;
  } else if (f == Family::kSpheroid) {
    q(3) = q(4) = x(3), q(5) = x(4), q(6) = heading;
  } else if (f == Family::kEllipsoid) {
    q.tail<4>() = x.tail<4>();
  } else {
    const double top = x(2);
    q(2) = 0.5 * (top + ground), q(5) = std::max(1.0, 0.5 * (top - ground));
    q(3) = x(3), q(4) = f == Family::kCuboid ? x(4) : x(3), q(6) = f == Family::kCuboid ? x(5) : heading;
  }
  return q;
}

Eigen::VectorXd Reduce(const Full& q, Family f) {
  Eigen::VectorXd x(FreeCount(f));
  x.head<3>() = q.head<3>();
  if (f == Family::kBall) {
    x(3) = std::cbrt(q(3) * q(4) * q(5));
  } else if (f == Family::kSpheroid) {
    x(3) = std::sqrt(q(3) * q(4)), x(4) = q(5);
  } else if (f == Family::kEllipsoid) {
    x.tail<4>() = q.tail<4>();
  } else {
    x(2) = q(2) + q(5);
    if (f != Family::kCuboid) {
      x(3) = std::sqrt(q(3) * q(4));
    } else {
      x(3) = q(3), x(4) = q(4), x(5) = q(6);
    }
  }
  return x;
}

// The point of the ellipsoid with semi-axes `e` (its own frame) nearest to `y`: Eberly's
// bisection ("Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid", Geometric
// Tools), its root found by Newton's method. With the axes sorted longest first and y in the first
// octant, the nearest point is x_i = r_i y_i / (s + r_i), r_i = (e_i / e_min)^2, at the root s of
// F(s) = sum (r_i z_i / (s + r_i))^2 - 1, z = y / e, which lies in [z_min - 1, |r z| - 1] outside
// and [z_min - 1, 0] inside. A coordinate exactly 0 is nudged off its plane, where the root's
// limit is the nearest point.
Eigen::Vector3d NearestOnEllipsoid(const Eigen::Vector3d& e, const Eigen::Vector3d& y) {
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int i, int j) { return e(i) > e(j); });
  double es[3], ys[3], r[3], z[3], n[3];
  for (int k = 0; k < 3; ++k) {
    es[k] = e(order[k]);
    ys[k] = std::max(std::abs(y(order[k])), 1e-9 * es[k]);
  }
  double g = -1;
  for (int k = 0; k < 3; ++k) {
    z[k] = ys[k] / es[k], r[k] = (es[k] / es[2]) * (es[k] / es[2]), n[k] = r[k] * z[k];
    g += z[k] * z[k];
  }
  double x[3] = {ys[0], ys[1], ys[2]};
  if (g != 0) {
    // F is convex and falls with s, so Newton's steps from the bracket's left end (F >= 0 there)
    // climb to the root without passing it; a step past the right end is halved back into it.
    const double s1 = g < 0 ? 0 : std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) - 1;
    double sm = z[2] - 1;
    for (int it = 0; it < 100; ++it) {
      double f = -1, df = 0;
      for (int k = 0; k < 3; ++k) {
        const double t = n[k] / (sm + r[k]);
        f += t * t, df -= 2 * t * t / (sm + r[k]);
      }
      if (!(f > 0) || !(df < 0)) break;
      double next = sm - f / df;
      if (!(next < s1)) next = 0.5 * (sm + s1);
      if (!(next - sm > 1e-14 * (1 + std::abs(sm)))) break;
      sm = next;
    }
    for (int k = 0; k < 3; ++k) x[k] = r[k] * ys[k] / (sm + r[k]);
  }
  Eigen::Vector3d out;
  for (int k = 0; k < 3; ++k) out(order[k]) = std::copysign(x[k], y(order[k]));
  return out;
}

// The radial distance from the surface: along the ray from the centre through the point, the
// point's distance less the surface's (exact for a ball, first order for flattened shapes). The
// fits choose the class and place the footprint on the radial distance; the measured fit's height
// is refitted on the exact distance along the normal (Normal, MeasureEnvelope says why), and
// DistanceOutside is that distance.
class Surface {
 public:
  // The heading's sine and cosine and the axes' inverse squares once per shape, not per point: a
  // fit's numerical Jacobian asks for every point's distance eight times an iteration.
  explicit Surface(const Full& q, Family f = Family::kEllipsoid)
      : c_(q.head<3>()), cs_(std::cos(q(6))), sn_(std::sin(q(6))),
        inv2_(1 / (q(3) * q(3)), 1 / (q(4) * q(4)), 1 / (q(5) * q(5))), smallest_(std::min({q(3), q(4), q(5)})),
        axes_(q.segment<3>(3)), family_(f) {}

  double Radial(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d d = p - c_;
    const Eigen::Vector3d uvw(d.x() * cs_ + d.y() * sn_, -d.x() * sn_ + d.y() * cs_, d.z());
    if (Prism(family_)) return Signed(uvw);
    const double s = std::sqrt(uvw.cwiseAbs2().dot(inv2_));
    const double n = d.norm();
    if (s < 1e-12) return -smallest_;
    return n * (1 - 1 / s);
  }

  // Radial(p) and its derivatives by the seven parameters (cx, cy, cz, a, b, c, heading), in
  // closed form: the fit's Jacobian in one pass over the points, not one per parameter.
  double RadialWithGradient(const Eigen::Vector3d& p, Eigen::Matrix<double, 1, 7>* g) const {
    const Eigen::Vector3d d = p - c_;
    const Eigen::Vector3d uvw(d.x() * cs_ + d.y() * sn_, -d.x() * sn_ + d.y() * cs_, d.z());
    // d(uvw)/d(heading); d(uvw)/d(centre) is minus the rotation.
    const Eigen::Vector3d uvw_heading(uvw.y(), -uvw.x(), 0);
    Eigen::Vector3d by_uvw, by_axes;  // the distance's derivatives by uvw and by the semi-axes
    double r = 0;
    if (Prism(family_)) {
      r = SignedWithGradient(uvw, &by_uvw, &by_axes);
    } else {
      const double s = std::sqrt(uvw.cwiseAbs2().dot(inv2_)), n = d.norm();
      if (s < 1e-12 || n < 1e-12) {
        g->setZero();
        return -smallest_;
      }
      r = n * (1 - 1 / s);
      // r = n - n / s: by d through n (d / n) and by uvw through s (D uvw / s), n / s^2 the latter.
      const double k = n / (s * s);
      const Eigen::Vector3d s_by_uvw = uvw.cwiseProduct(inv2_) / s;
      by_uvw = k * s_by_uvw;
      by_axes = -k * uvw.cwiseAbs2().cwiseProduct(inv2_).cwiseProduct(axes_.cwiseInverse()) / s;
      // n's own part, by d: carried into uvw's frame so one rotation serves both.
      by_uvw += (1 - 1 / s) * uvw / n;
    }
    // by d = R^T by_uvw; by centre = -by d.
    const Eigen::Vector3d by_d(by_uvw.x() * cs_ - by_uvw.y() * sn_, by_uvw.x() * sn_ + by_uvw.y() * cs_, by_uvw.z());
    g->segment<3>(0) = -by_d.transpose();
    g->segment<3>(3) = by_axes.transpose();
    (*g)(6) = by_uvw.dot(uvw_heading);
    return r;
  }

  // The signed distance along the surface's normal (outside +), exact for the quadrics (the
  // nearest point, NearestOnEllipsoid), and its derivatives by the seven parameters: the surface
  // G = sum (u_i / e_i)^2 - 1 = 0 moved by a parameter moves the distance by dG/dq / |dG/dx| at the
  // nearest point. A prism's is Signed's. Unlike the radial distance, noise along the normal
  // leaves it unbiased: on a flat spheroid seen from above, whose vertical semi-axis only the
  // curvature of its sides pins, the radial fit reads that semi-axis 3 % long under 6 mm of noise,
  // 20 % under 12.
  double Normal(const Eigen::Vector3d& p, Eigen::Matrix<double, 1, 7>* g = nullptr) const {
    if (Prism(family_)) {
      if (g) return RadialWithGradient(p, g);
      return Radial(p);
    }
    const Eigen::Vector3d d = p - c_;
    const Eigen::Vector3d uvw(d.x() * cs_ + d.y() * sn_, -d.x() * sn_ + d.y() * cs_, d.z());
    const Eigen::Vector3d x = NearestOnEllipsoid(axes_, uvw);
    const Eigen::Vector3d m = x.cwiseProduct(inv2_);  // half of dG/du at x
    const double mn = m.norm();
    if (!(mn > 0)) {
      if (g) g->setZero();
      return -smallest_;
    }
    const Eigen::Vector3d normal = m / mn;
    const double dist = normal.dot(uvw - x);
    if (g) {
      const Eigen::Vector3d world(normal.x() * cs_ - normal.y() * sn_, normal.x() * sn_ + normal.y() * cs_, normal.z());
      g->segment<3>(0) = -world.transpose();
      g->segment<3>(3) = (-x.cwiseAbs2().cwiseProduct(inv2_).cwiseProduct(axes_.cwiseInverse()) / mn).transpose();
      (*g)(6) = x.x() * x.y() * (inv2_.x() - inv2_.y()) / mn;
    }
    return dist;
  }

 private:
  // Signed(uvw) and its derivatives by uvw and by the semi-axes.
  double SignedWithGradient(const Eigen::Vector3d& uvw, Eigen::Vector3d* by_uvw, Eigen::Vector3d* by_axes) const {
    Eigen::Vector3d e, de_duvw_sign = uvw.cwiseSign();
    by_uvw->setZero(), by_axes->setZero();
    double rho = 0;
    if (family_ == Family::kCone) return ConeWithGradient(uvw, by_uvw, by_axes);
    if (family_ == Family::kCylinder) {
      rho = std::hypot(uvw.x(), uvw.y());
      e << rho - axes_.x(), -1e300, std::abs(uvw.z()) - axes_.z();
    } else {
      e = uvw.cwiseAbs() - axes_;
    }
    Eigen::Vector3d by_e = Eigen::Vector3d::Zero();
    const Eigen::Vector3d out = e.cwiseMax(0.0);
    const double outside = out.norm();
    if (outside > 0) {
      by_e = out / outside;
    } else {
      Eigen::Index k = 0;
      e.maxCoeff(&k);
      by_e(k) = 1;
    }
    if (family_ == Family::kCylinder) {
      if (rho > 1e-12) by_uvw->head<2>() = by_e.x() * uvw.head<2>() / rho;
      (*by_uvw)(2) = by_e.z() * de_duvw_sign.z();
      // The drum's radius is both a and b (the family ties them); its derivative goes to a.
      (*by_axes)(0) = -by_e.x(), (*by_axes)(2) = -by_e.z();
    } else {
      *by_uvw = by_e.cwiseProduct(de_duvw_sign);
      *by_axes = -by_e;
    }
    return outside + std::min(e.maxCoeff(), 0.0);
  }

  // A cone's two faces in its meridian plane (rho from the axis, w up from mid-height; base radius
  // a at w = -c, the apex at w = +c): the slanted side's signed distance, and the base's.
  Eigen::Vector2d ConeFaces(const Eigen::Vector3d& uvw, double* rho, double* slant) const {
    const double a = axes_.x(), c = axes_.z();
    *rho = std::hypot(uvw.x(), uvw.y());
    *slant = std::sqrt(4 * c * c + a * a);
    return Eigen::Vector2d((2 * c * *rho + a * (uvw.z() - c)) / *slant, -c - uvw.z());
  }

  // Signed() for a cone, and its derivatives by uvw and by the semi-axes (a, c).
  double ConeWithGradient(const Eigen::Vector3d& uvw, Eigen::Vector3d* by_uvw, Eigen::Vector3d* by_axes) const {
    double rho = 0, L = 1;
    const Eigen::Vector2d e = ConeFaces(uvw, &rho, &L);
    const double a = axes_.x(), c = axes_.z(), w = uvw.z();
    const Eigen::Vector2d out = e.cwiseMax(0.0);
    const double outside = out.norm();
    Eigen::Vector2d by_e = Eigen::Vector2d::Zero();
    if (outside > 0) {
      by_e = out / outside;
    } else {
      by_e(e(0) >= e(1) ? 0 : 1) = 1;
    }
    // The side: d = (2 c rho + a (w - c)) / L, L = sqrt(4 c^2 + a^2); the base: -c - w.
    const double side_rho = 2 * c / L, side_w = a / L;
    const double side_a = (w - c) / L - e(0) * a / (L * L), side_c = (2 * rho - a) / L - e(0) * 4 * c / (L * L);
    if (rho > 1e-12) by_uvw->head<2>() = by_e(0) * side_rho * uvw.head<2>() / rho;
    (*by_uvw)(2) = by_e(0) * side_w - by_e(1);
    (*by_axes)(0) = by_e(0) * side_a, (*by_axes)(2) = by_e(0) * side_c - by_e(1);
    return outside + std::min(e.maxCoeff(), 0.0);
  }

  // A prism's signed distance (exact: the distance to its nearest face, edge or corner outside,
  // to its nearest face inside): a drum's side is round, a box's flat; a cone's, to first order
  // about its apex and its base's rim.
  double Signed(const Eigen::Vector3d& uvw) const {
    Eigen::Vector3d e;
    if (family_ == Family::kCone) {
      double rho = 0, L = 1;
      const Eigen::Vector2d f = ConeFaces(uvw, &rho, &L);
      return f.cwiseMax(0.0).norm() + std::min(f.maxCoeff(), 0.0);
    }
    if (family_ == Family::kCylinder) {
      const double r = std::hypot(uvw.x(), uvw.y()) - axes_.x();
      e << r, -1e300, std::abs(uvw.z()) - axes_.z();
    } else {
      e = uvw.cwiseAbs() - axes_;
    }
    return e.cwiseMax(0.0).norm() + std::min(e.maxCoeff(), 0.0);
  }

 private:
  Eigen::Vector3d c_;
  double cs_, sn_;
  Eigen::Vector3d inv2_;
  double smallest_;
  Eigen::Vector3d axes_;
  Family family_;
};

struct Bounds {
  Full lo, hi;
  double ground = 0;
  // A shape sunk more than a quarter of its height into the ground is no clipped shape standing
  // on it; without this, a shallow cap of a far larger shape fits a squat top as well (its
  // footprint then lies beyond the points, which the horizontal bounds forbid too).
  void Apply(Full* q) const {
    for (int k = 0; k < 6; ++k) (*q)(k) = std::clamp((*q)(k), lo(k), hi(k));
    (*q)(2) = std::max((*q)(2), ground - 0.25 * (*q)(5));
  }
};

struct FamilyFit {
  Full q;
  Eigen::VectorXd x;
  Eigen::MatrixXd cov;  // of the free parameters (sandwich)
  std::vector<double> residuals;
  bool ok = false;
};

// A damped step x - Ad^-1 g that the bounds cut short (`clamped`, from `free`): the parameters the
// bounds stopped are held where the bounds put them and the others solved for again, so a shape
// pressed against a bound slides along it. Clamping alone leaves the others' step aimed past the
// bound: it fails, the damping grows, and the fit creeps (0.1 mm an iteration, a quarter of the
// real garden half's fits stopped by the iteration cap).
void ProjectStep(const Eigen::MatrixXd& Ad, const Eigen::VectorXd& g, const Eigen::VectorXd& x, const Eigen::VectorXd& free,
                 Eigen::VectorXd* clamped) {
  const Eigen::Index m = x.size();
  std::vector<Eigen::Index> stopped;
  for (Eigen::Index j = 0; j < m; ++j) {
    if (std::abs((*clamped)(j) - free(j)) > 1e-9 * (1 + std::abs(free(j)))) stopped.push_back(j);
  }
  if (stopped.empty() || Eigen::Index(stopped.size()) == m) return;
  Eigen::MatrixXd A = Ad;
  Eigen::VectorXd rhs = g;
  for (const Eigen::Index j : stopped) {
    const double y = x(j) - (*clamped)(j);  // x_new = x - y
    rhs -= A.col(j) * y;
    A.row(j).setZero(), A.col(j).setZero(), A(j, j) = 1, rhs(j) = y;
  }
  *clamped = x - A.ldlt().solve(rhs);
}

// The sandwich covariance of a Huber fit (FitFamily's weights) with Jacobian J and residuals e:
// robust to residuals that are not all alike (a leaf layer on top, clutter at the foot). The
// `held` parameters' rows and columns are left out (zero).
Eigen::MatrixXd SandwichCovariance(const Eigen::MatrixXd& J, const Eigen::VectorXd& e, const std::vector<bool>& held) {
  const Eigen::Index n = e.size(), m = J.cols();
  const double sigma = std::max(1.0, RobustSpread(std::vector<double>(e.data(), e.data() + n))), k = 1.5 * sigma;
  Eigen::VectorXd w(n), psi(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    w(i) = std::abs(e(i)) <= k ? 1.0 : k / std::abs(e(i));
    psi(i) = w(i) * e(i);
  }
  Eigen::MatrixXd A = J.transpose() * w.asDiagonal() * J;
  Eigen::MatrixXd B = J.transpose() * psi.array().square().matrix().asDiagonal() * J;
  for (Eigen::Index j = 0; j < m; ++j) {
    if (!held[std::size_t(j)]) continue;
    A.row(j).setZero(), A.col(j).setZero(), A(j, j) = 1;
    B.row(j).setZero(), B.col(j).setZero();
  }
  const Eigen::MatrixXd Ainv = A.ldlt().solve(Eigen::MatrixXd::Identity(m, m));
  return Ainv * B * Ainv;
}

// Robust (Huber, scale from the residuals' own spread) Levenberg-Marquardt on the radial
// residuals (with `normal`, on the distance along the normal, Surface::Normal), plus `shift`: a
// few thousand points and at most seven parameters. The Jacobian in closed form.
FamilyFit FitFamily(const std::vector<Eigen::Vector3d>& p, Family f, const Full& start, const Bounds& bounds,
                    bool normal = false, double shift = 0, bool vertical_only = false) {
  FamilyFit out;
  const int m = FreeCount(f);
  // With `vertical_only`, a quadric's centre height and vertical semi-axis move, the rest held.
  std::vector<bool> held(std::size_t(m), false);
  if (vertical_only && !Prism(f)) {
    const int c_index = f == Family::kBall ? 3 : f == Family::kSpheroid ? 4 : 5;
    for (int j = 0; j < m; ++j) held[std::size_t(j)] = j != 2 && j != c_index;
  }
  auto hold = [&](Eigen::MatrixXd* A, Eigen::VectorXd* g) {
    for (int j = 0; j < m; ++j) {
      if (!held[std::size_t(j)]) continue;
      A->row(j).setZero(), A->col(j).setZero(), (*A)(j, j) = 1;
      if (g) (*g)(j) = 0;
    }
  };
  const double heading = start(6);
  Eigen::VectorXd x = Reduce(start, f);
  auto residuals = [&](const Eigen::VectorXd& xv, Eigen::VectorXd* e) {
    const Surface surface(Expand(xv, f, heading, bounds.ground), f);
    e->resize(Eigen::Index(p.size()));
    for (std::size_t i = 0; i < p.size(); ++i) {
      (*e)(Eigen::Index(i)) = (normal ? surface.Normal(p[i]) : surface.Radial(p[i])) + shift;
    }
  };
  // The Jacobian by the free parameters: each point's closed-form derivatives by the seven, times
  // Expand's (linear but for a prism's least height; by differences, as it reads no point).
  auto jacobian = [&](const Eigen::VectorXd& xv, Eigen::MatrixXd* jac) {
    const Full q0 = Expand(xv, f, heading, bounds.ground);
    Eigen::Matrix<double, 7, Eigen::Dynamic> dq(7, m);
    for (int j = 0; j < m; ++j) {
      Eigen::VectorXd xp = xv;
      xp(j) += 1e-3;
      dq.col(j) = (Expand(xp, f, heading, bounds.ground) - q0) / 1e-3;
    }
    const Surface surface(q0, f);
    Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor> by_q(Eigen::Index(p.size()), 7);
    Eigen::Matrix<double, 1, 7> g;
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (normal) {
        surface.Normal(p[i], &g);
      } else {
        surface.RadialWithGradient(p[i], &g);
      }
      by_q.row(Eigen::Index(i)) = g;
    }
    jac->noalias() = by_q * dq;
  };
  auto clamp = [&](Eigen::VectorXd* xv) {
    Full q = Expand(*xv, f, heading, bounds.ground);
    bounds.Apply(&q);
    *xv = Reduce(q, f);
  };
  clamp(&x);
  Eigen::VectorXd e, e_try;
  residuals(x, &e);
  const Eigen::Index n = e.size();
  Eigen::VectorXd w(n);
  Eigen::MatrixXd J(n, m);
  double lambda = 1e-3;
  for (int it = 0; it < 60; ++it) {
    std::vector<double> ev(e.data(), e.data() + n);
    const double sigma = std::max(1.0, RobustSpread(ev));
    const double k = 1.5 * sigma;
    for (Eigen::Index i = 0; i < n; ++i) w(i) = std::abs(e(i)) <= k ? 1.0 : k / std::abs(e(i));
    jacobian(x, &J);
    const Eigen::MatrixXd JtW = J.transpose() * w.asDiagonal();
    Eigen::MatrixXd A = JtW * J;
    Eigen::VectorXd g = JtW * e;
    hold(&A, &g);
    const double cost = (w.array() * e.array().square()).sum();
    // Each free parameter's standard error (the Gauss-Newton covariance at this scale): a fit
    // need not settle far below it. A sub-millimetre stop on every fit held a rough or sparse
    // part's fit creeping along a flat valley for tens of iterations (the real garden half: 12,200
    // iterations in place of 20,700, its fits moving by under a tenth of their intervals).
    const Eigen::VectorXd sd = (sigma * sigma * A.ldlt().solve(Eigen::MatrixXd::Identity(m, m)).diagonal()).cwiseMax(0).cwiseSqrt();
    bool stepped = false;
    for (int tries = 0; tries < 8 && !stepped; ++tries) {
      Eigen::MatrixXd Ad = A;
      Ad.diagonal() += lambda * A.diagonal().cwiseMax(1e-9);
      const Eigen::VectorXd x_free = x - Ad.ldlt().solve(g);
      Eigen::VectorXd x_try = x_free;
      clamp(&x_try);
      ProjectStep(Ad, g, x, x_free, &x_try);
      clamp(&x_try);
      residuals(x_try, &e_try);
      if ((w.array() * e_try.array().square()).sum() < cost) {
        // The step against what each parameter is known to: at most 1 % of its standard error
        // plus 1e-3 (mm or radians) is converged.
        const double moved = ((x_try - x).cwiseAbs().array() / (1e-3 + 0.01 * sd.array())).maxCoeff();
        x = x_try, e = e_try, lambda = std::max(1e-7, lambda / 3), stepped = true;
        if (moved < 1) it = 1000;
      } else {
        lambda *= 4;
      }
    }
    if (!stepped) break;
  }
  out.x = x;
  out.q = Expand(x, f, heading, bounds.ground);
  out.residuals.assign(e.data(), e.data() + n);
  out.cov = SandwichCovariance(J, e, held);
  out.ok = out.q.allFinite();
  return out;
}

// A leaf layer's residuals along the fitted surface's normal (mm, outward +) and the vertical
// part of that normal at each, |n_z| (0 on a side, 1 on the top).
struct LayerSample {
  std::vector<double> r, nz;
  std::vector<double> ray;  // with the stations (Beams): RayShare at each, else empty
  double lawn_share = 0;    // ... and at the lawn under the shape, straight up
};

// Where the sensor stood (the shape's frame, mm; empty: not known), and the share of a beam's
// travel the lawn under the shape shows straight up (RayShare; 0 when not known).
struct Beams {
  std::vector<Eigen::Vector3d> viewpoints;
  double lawn_share = 0;
};

// The leaf layer's model (envelope_fit.hpp's, along the surface's normal): a residual r (outward
// +) is delta - D + N(0, sigma^2), the leaf's depth D below the envelope 0 for a share w (the
// shears' cut) and exponential (mean mu) for the rest; 2 % uniform outliers. Mean negative
// log-likelihood at x = (delta, logit w, log mu, log s), s the noise.
// The noise along the normal: with the sensor's `vertical` noise given (> 0: the lawn's, which
// is the noise's vertical part wherever the sensor stands), the noise is taken as axisymmetric
// about the vertical, s its horizontal part, and the normal at a point with vertical part n_z
// reads sqrt(vertical^2 n_z^2 + s^2 (1 - n_z^2)), s at most `vertical`. A sensor's noise lies
// along its rays: a drone's rays are steep, and a shape's sides, whose normals are level, see
// little of it. Held at the lawn's all round, the drone's leaf layer read its envelope 1.8-2.2 mm
// inside the truth's (numpy on held-back bed 402, against the true shapes), 0.3-1.1 mm with s
// free. Why s may fall below the lawn's noise but not rise above it: points lying tighter on the
// sides than that noise allows cannot be leaves, but more scatter there is leaves as much as
// noise, and the two cannot be told apart. On the real garden half (lawn noise 21 mm) a free s
// read 48-113 mm on the sides' ragged leaves and took 10-50 mm off every topiary's envelope; a
// ring of cameras looking along the level (simulated, s 5-7 against the lawn's 4 mm) would gain
// from it, but no cloud says which it is. Without `vertical` (0) the noise is one number, s,
// fitted with the rest.
// Where the stations are known (`l.ray`), it is told: a beam's range noise and how deep it goes
// among the leaves before it stops on one (Beer-Lambert: exponential along the ray) both lie
// along the ray, and the normal sees the share c = |n . u| of each, so at each point the noise
// is s c and the depth's mean mu c, s then the range noise itself. Nothing is held at the lawn's
// but s's upper end: the lawn shows the noise's share at its own c (RayShare straight up), plus
// its grass, so s is at most `vertical` / that. On the simulated truth's own surfaces (tuning
// beds 2-3, numpy) this reads the range noise as the simulator's (LiDAR 9-12 mm against 10,
// terrestrial 2.4-3.2 against 3) and the envelope within 1 mm for all four sensors, where the
// axisymmetric noise put the LiDAR's 0.2-3.5 mm out and the terrestrial scanner's 1-2.4 mm in:
// a scanner looking along the level sees its noise on the sides and its rays graze the top.
double LeafLayerNll(const LayerSample& l, const Eigen::Vector4d& x, double vertical) {
  // The share, the depth and the noise held to where they still mean something (w 0.25 % to
  // 99.75 %, mu 0.5 mm to 20 noise widths, the noise at least 0.5 mm): beyond, the likelihood is
  // flat and the search would wander.
  const double s = std::max(0.5, std::exp(vertical > 0 ? std::min(x(3), std::log(vertical)) : x(3)));
  const double width = vertical > 0 ? vertical : s;
  const double delta = x(0), w = 1 / (1 + std::exp(-std::clamp(x(1), -6.0, 6.0)));
  const double mu = 0.5 + std::exp(std::min(x(2), std::log(20 * width))), lambda = 1 / mu;
  const double lw0 = std::log(0.98 * w) - std::log(std::sqrt(2 * M_PI)), l1w = std::log(0.98 * (1 - w) * lambda / 2);
  // Told the stations: the range noise, at most what the lawn allows.
  const double range_s = std::exp(std::min(x(3), std::log(vertical > 0 && l.lawn_share > 0 ? vertical / l.lawn_share : 20 * width)));
  double total = 0;
  for (std::size_t i = 0; i < l.r.size(); ++i) {
    double sigma = s, mu_i = mu, lambda_i = lambda, l1w_i = l1w;
    if (!l.ray.empty()) {
      sigma = std::max(0.5, range_s * l.ray[i]);
      mu_i = std::max(0.5, mu * l.ray[i]), lambda_i = 1 / mu_i, l1w_i = std::log(0.98 * (1 - w) * lambda_i / 2);
    } else if (vertical > 0) {
      const double nz2 = l.nz[i] * l.nz[i];
      sigma = std::max(0.5, std::sqrt(vertical * vertical * nz2 + s * s * (1 - nz2)));
    }
    const double out = std::log(0.02 / (20 * sigma + 10 * mu_i));
    const double t = l.r[i] - delta;
    const double a = lw0 - std::log(sigma) - 0.5 * t * t / (sigma * sigma);
    const double b = l1w_i + lambda_i * t + 0.5 * lambda_i * lambda_i * sigma * sigma +
                     LogErfc((t + lambda_i * sigma * sigma) / (std::sqrt(2.0) * sigma));
    const double m = std::max({a, b, out});
    total -= m + std::log(std::exp(a - m) + std::exp(b - m) + std::exp(out - m));
  }
  return total / double(std::max<std::size_t>(1, l.r.size()));
}

// Nelder-Mead on LeafLayerNll from the residuals' median: delta is the envelope's offset from the
// fitted surface (mm, outward +). With the sensor's `vertical` noise (> 0, from the lawn) the
// noise's horizontal part (told the stations, the range noise) is fitted with the rest, starting
// from it; without (0), the noise
// is one number estimated from the residuals' own spread. Returns the whole solution (delta,
// logit w, log mu, log s). `start`: a solution on much the same residuals (the jackknife's),
// which the simplex leaves in small steps.
Eigen::Vector4d FitLeafLayer(const LayerSample& l, double vertical, const Eigen::Vector4d* start) {
  const std::vector<double>& r = l.r;
  const double sigma = vertical > 0 ? vertical : std::max(0.5, 0.5 * RobustSpread(r));
  constexpr int n = 4;  // the simplex moves every coordinate
  std::vector<Eigen::Vector4d> v = {Eigen::Vector4d(MedianOf(r) + sigma, -1, std::log(std::max(1.0, 2 * sigma)), std::log(sigma))};
  if (start) v[0] = *start;
  const Eigen::Vector4d steps = Eigen::Vector4d(sigma, 1.5, 0.7, 0.5) * (start ? 0.25 : 1.0);
  for (int k = 0; k < n; ++k) v.push_back(v[0] + steps(k) * Eigen::Vector4d::Unit(k));
  std::vector<double> f;
  for (const auto& x : v) f.push_back(LeafLayerNll(l, x, vertical));
  std::vector<int> o(std::size_t(n + 1));
  for (int it = 0; it < 300; ++it) {
    for (int k = 0; k <= n; ++k) o[std::size_t(k)] = k;
    std::sort(o.begin(), o.end(), [&](int i, int j) { return f[std::size_t(i)] < f[std::size_t(j)]; });
    const int best = o.front(), worst = o.back(), second = o[std::size_t(n - 1)];
    if (f[std::size_t(worst)] - f[std::size_t(best)] < 1e-5) break;
    Eigen::Vector4d c = Eigen::Vector4d::Zero();
    for (int k = 0; k < n; ++k) c += v[std::size_t(o[std::size_t(k)])] / double(n);
    auto at = [&](double k) {
      const Eigen::Vector4d x = c + k * (v[std::size_t(worst)] - c);
      return std::make_pair(x, LeafLayerNll(l, x, vertical));
    };
    auto [xr, fr] = at(-1);
    if (fr < f[std::size_t(best)]) {
      auto [xe, fe] = at(-2);
      if (fe < fr) xr = xe, fr = fe;
      v[std::size_t(worst)] = xr, f[std::size_t(worst)] = fr;
    } else if (fr < f[std::size_t(second)]) {
      v[std::size_t(worst)] = xr, f[std::size_t(worst)] = fr;
    } else if (auto [xc, fc] = at(0.5); fc < f[std::size_t(worst)]) {
      v[std::size_t(worst)] = xc, f[std::size_t(worst)] = fc;
    } else {
      for (int k = 1; k <= n; ++k) {
        auto& x = v[std::size_t(o[std::size_t(k)])];
        x = 0.5 * (x + v[std::size_t(best)]);
        f[std::size_t(o[std::size_t(k)])] = LeafLayerNll(l, x, vertical);
      }
    }
  }
  return v[std::size_t(std::min_element(f.begin(), f.end()) - f.begin())];
}

// The share of a beam's travel a surface's normal `n` (outward, unit) at `x` sees, |n . u| for
// the ray u from the station that saw the point, at least 0.1. Which station saw it is not known:
// each facing one samples the surface at a density of |n . u| over its squared distance, and the
// share is the mean over the facing stations weighted by that (at most 256 of `viewpoints`,
// evenly spread); with none facing, the nearest's.
double RayShare(const Eigen::Vector3d& x, const Eigen::Vector3d& n, const std::vector<Eigen::Vector3d>& viewpoints) {
  const std::size_t every = viewpoints.size() / 256 + 1;
  double sum = 0, weight = 0, nearest = 0, nearest_d2 = std::numeric_limits<double>::infinity();
  for (std::size_t j = 0; j < viewpoints.size(); j += every) {
    const Eigen::Vector3d to = viewpoints[j] - x;
    const double d2 = std::max(1.0, to.squaredNorm()), c = to.dot(n) / std::sqrt(d2);
    if (d2 < nearest_d2) nearest_d2 = d2, nearest = std::abs(c);
    if (c <= 0) continue;
    sum += c * c / d2, weight += c / d2;
  }
  return std::max(0.1, weight > 0 ? sum / weight : nearest);
}

// The residuals FitLeafLayer reads: about `count` of `p`'s distances from `surface` along its
// normal, plus `shift` (an envelope's offset: then they are the distances from the surface that
// far inside it, as FitLeafLayer's model reads them), with the normal's vertical part at each.
LayerSample LayerResiduals(const std::vector<Eigen::Vector3d>& p, const Surface& surface, std::size_t count,
                           double shift = 0, const Beams& beams = {}) {
  const std::vector<Eigen::Vector3d>& viewpoints = beams.viewpoints;
  LayerSample l;
  const std::size_t every = p.size() / count + 1;
  Eigen::Matrix<double, 1, 7> g;
  for (std::size_t i = 0; i < p.size(); i += every) {
    l.r.push_back(surface.Normal(p[i], &g) + shift);
    // The distance's gradient by the centre is minus the normal (a unit vector for a quadric and
    // a prism's sides and top alike).
    const double gn = g.head<3>().norm();
    l.nz.push_back(gn > 0 ? std::min(1.0, std::abs(g(2)) / gn) : 1.0);
    if (!viewpoints.empty()) l.ray.push_back(gn > 0 ? RayShare(p[i], -g.head<3>() / gn, viewpoints) : 1.0);
  }
  if (!viewpoints.empty()) l.lawn_share = beams.lawn_share;
  return l;
}

// Residuals are not independent: a leaf layer, a reconstruction's patches and a lower half no
// sensor saw move whole parts of the surface together. A block jackknife over 16 patches (8
// sectors about the axis, above and below the centre) refits `family` from `q` without each, on
// at most 800 of `p`: the 95 % half-widths of its free parameters, or an empty vector when fewer
// than 4 patches could be left out. With the leaf `layer` (FitLeafLayer's solution on all of
// `p`), each refit's semi-axes carry their own envelope offset (noise `noise_mm`), so the axes'
// intervals hold the offset's uncertainty too: a leaf layer seen thicker on one side moves it.
// With `radial`, `q` is a quadric's envelope (MeasureEnvelope), its points `envelope_offset`
// inside it, and `radial` the radial fit it started from.
Eigen::VectorXd JackknifeCi95(const std::vector<Eigen::Vector3d>& p, Family family, const Full& q, const Bounds& bounds,
                              const Eigen::Vector4d* layer, double noise_mm, const Full* radial, double envelope_offset,
                              const Beams& beams) {
  std::vector<Eigen::Vector3d> q_pts;
  const std::size_t q_step = p.size() / 800 + 1;
  for (std::size_t i = 0; i < p.size(); i += q_step) q_pts.push_back(p[i]);
  auto block = [&](const Eigen::Vector3d& v) {
    const Eigen::Vector3d d = v - q.head<3>();
    const int sector = std::clamp(int((std::atan2(d.y(), d.x()) + M_PI) / (2 * M_PI) * 8), 0, 7);
    return sector * 2 + (d.z() >= 0 ? 1 : 0);
  };
  const bool envelope = layer && radial;
  std::vector<Eigen::VectorXd> refits;
  for (int b = 0; b < 16; ++b) {
    std::vector<Eigen::Vector3d> kept;
    for (const auto& v : q_pts) if (block(v) != b) kept.push_back(v);
    if (kept.size() == q_pts.size() || kept.size() < 20) continue;  // an empty patch says nothing
    // The surface through the points; an envelope's is radial, its height then refitted with
    // the offset held (MeasureEnvelope's steps, the offset's own fit left to the layer below).
    FamilyFit f = FitFamily(kept, family, envelope ? *radial : q, bounds);
    if (envelope && f.ok) {
      Full start = f.q;
      start.segment<3>(3).array() += envelope_offset;
      f = FitFamily(kept, family, start, bounds, true, envelope_offset, true);
    }
    if (!f.ok) continue;
    if (layer) {
      // 300 residuals: the offset to a millimetre or two, 16 times over. An envelope's moves by
      // what this patch's residuals say less what it holds (to first order in a few millimetres).
      const LayerSample r = LayerResiduals(kept, Surface(f.q, family), 300, envelope ? envelope_offset : 0, beams);
      const double offset = std::max(0.0, FitLeafLayer(r, noise_mm > 0 ? std::max(1.0, noise_mm) : 0.0, layer)(0));
      // The semi-axes among the free parameters (and a prism's top) move out by the offset.
      const int first = Prism(family) ? 2 : 3;
      const int axes = family == Family::kBall ? 1 : family == Family::kSpheroid ? 2 : family == Family::kEllipsoid ? 3
                       : family == Family::kCylinder || family == Family::kCone ? 2 : 3;
      f.x.segment(first, axes).array() += envelope ? offset - envelope_offset : offset;
    }
    refits.push_back(f.x);
  }
  if (refits.size() < 4) return {};
  Eigen::VectorXd centre = Eigen::VectorXd::Zero(refits[0].size());
  for (const auto& x : refits) centre += x;
  centre /= double(refits.size());
  Eigen::VectorXd var = Eigen::VectorXd::Zero(centre.size());
  for (const auto& x : refits) var += (x - centre).cwiseAbs2();
  const double n = double(refits.size());
  return (var * (n - 1) / n).cwiseSqrt() * 1.96;
}

// How much of a prism's walls its points show: the share of 16 sectors about its axis whose wall
// holds a point between a quarter and three quarters of its height (within 2.5 robust spreads of
// the wall, at least 10 mm). A clipped drum or box is leafy to the ground, and a sensor above or
// beside it sees its sides; a bench's seat or a table's top shows a flat top and an edge a few
// centimetres deep, with nothing on the walls a prism standing on the ground would have.
double WallCover(const std::vector<Eigen::Vector3d>& p, const FamilyFit& prism, Family f) {
  const Full& q = prism.q;
  const double band = std::max(10.0, 2.5 * RobustSpread(prism.residuals));
  const double cs = std::cos(q(6)), sn = std::sin(q(6));
  constexpr int kSectors = 16;
  std::vector<char> seen(kSectors, 0);
  for (const auto& v : p) {
    const Eigen::Vector3d d = v - q.head<3>();
    const double u = d.x() * cs + d.y() * sn, w = -d.x() * sn + d.y() * cs;
    const double height = (d.z() + q(5)) / (2 * q(5));  // 0 at the ground, 1 at the top
    if (height < 0.25 || height > 0.75) continue;
    const double side = f == Family::kCylinder ? std::hypot(u, w) - q(3)
                         : f == Family::kCone   ? std::hypot(u, w) - q(3) * (1 - height)
                                                : std::max(std::abs(u) - q(3), std::abs(w) - q(4));
    if (std::abs(side) > band) continue;
    const int sector = std::clamp(int((std::atan2(w, u) + M_PI) / (2 * M_PI) * kSectors), 0, kSectors - 1);
    seen[std::size_t(sector)] = 1;
  }
  return double(std::count(seen.begin(), seen.end(), 1)) / kSectors;
}

// The family the criterion chooses (shape_fit.hpp), with each one's BIC written into `s`.
// `cylinder` and `cuboid` may be absent (not fitted, or not converged); with `round`, the
// ellipsoid and the cuboid are not candidates.
const FamilyFit* ChooseFamily(const std::vector<Eigen::Vector3d>& p, const FamilyFit& ball, const FamilyFit& spheroid,
                              const FamilyFit& ellipsoid, const FamilyFit* cylinder, const FamilyFit* cuboid,
                              const FamilyFit* cone, double noise_mm, double max_spread_mm, bool round, ClippedShape* s,
                              Family* family) {
  // One scale for all: the most flexible quadric's robust spread; residuals beyond 2.5 of it
  // (strays, a neighbour's leaves) count as 2.5.
  const double sigma = std::max({1.0, 0.5 * noise_mm, RobustSpread(ellipsoid.residuals)});
  const double clip = 2.5 * sigma;
  auto bic = [&](const FamilyFit& fit, int k) {
    double sum = 0;
    for (double r : fit.residuals) sum += std::min(r * r, clip * clip);
    const double n = double(fit.residuals.size());
    return n * std::log(sum / n) + k * std::log(n);
  };
  s->bic_ball = bic(ball, 4), s->bic_spheroid = bic(spheroid, 5), s->bic_ellipsoid = bic(ellipsoid, 7);
  // A family with more parameters wins when the criterion says so and its axes differ by more
  // than 5 % (below that a gardener clips it as the simpler shape, and thousands of points make
  // any difference "significant").
  auto differ = [](double x, double y) { return std::abs(x - y) > 0.05 * std::max(x, y); };
  // With `max_spread_mm`, only the quadrics whose points lie that close are candidates, when one
  // does: the criterion weighs the tails (a neighbour's leaves beyond the clip) and the spread the
  // core, and on a rough top the two can prefer different families of one shape.
  auto smooth = [&](const FamilyFit& f) { return max_spread_mm <= 0 || RobustSpread(f.residuals) <= max_spread_mm; };
  const bool smooth_ball = smooth(ball), smooth_spheroid = smooth(spheroid), smooth_ellipsoid = !round && smooth(ellipsoid);
  const bool any_smooth = smooth_ball || smooth_spheroid || smooth_ellipsoid;
  const FamilyFit* best = nullptr;
  double best_bic = std::numeric_limits<double>::infinity();
  if (!any_smooth || smooth_ball) best = &ball, *family = Family::kBall, best_bic = s->bic_ball;
  if ((!any_smooth || smooth_spheroid) && (!best || (s->bic_spheroid < best_bic && differ(spheroid.q(3), spheroid.q(5))))) {
    best = &spheroid, *family = Family::kSpheroid, best_bic = s->bic_spheroid;
  }
  const Full& e = ellipsoid.q;
  if (!round && (!any_smooth || smooth_ellipsoid) &&
      (!best || (s->bic_ellipsoid < best_bic &&
                 (differ(e(3), e(4)) || (*family == Family::kBall && differ(std::max(e(3), e(4)), e(5))))))) {
    best = &ellipsoid, *family = Family::kEllipsoid, best_bic = s->bic_ellipsoid;
  }
  // A drum or a box is another shape, not a refinement of a quadric: it wins when the criterion
  // says so and its points lie clearly closer to it, within kPrismSpreadShare of their spread
  // about the quadric. On a rough real top (leaf clumps, a reconstruction's relief: residuals
  // that are not independent) the criterion takes a box's extra parameters for significant;
  // clipped domes of the real garden lie 0.8-1.1 times as far from a box as from their quadric,
  // a drum's or a box's simulated points 0.1-0.2 times.
  // And its walls must show (WallCover): a slab's top fits a box as closely as a box's does.
  const double quadric_spread = RobustSpread(best->residuals);
  auto clearly_closer = [&](const FamilyFit& prism) { return RobustSpread(prism.residuals) <= kPrismSpreadShare * quadric_spread; };
  if (cylinder && cylinder->ok) {
    s->bic_cylinder = bic(*cylinder, 4), s->walls_cylinder = WallCover(p, *cylinder, Family::kCylinder);
    if (s->bic_cylinder < best_bic && clearly_closer(*cylinder) && s->walls_cylinder >= kMinWallCover) {
      best = cylinder, *family = Family::kCylinder, best_bic = s->bic_cylinder;
    }
  }
  if (cuboid && cuboid->ok && !round) {
    s->bic_cuboid = bic(*cuboid, 6), s->walls_cuboid = WallCover(p, *cuboid, Family::kCuboid);
    if (s->bic_cuboid < best_bic && clearly_closer(*cuboid) && s->walls_cuboid >= kMinWallCover) {
      best = cuboid, *family = Family::kCuboid, best_bic = s->bic_cuboid;
    }
  }
  if (cone && cone->ok) {
    s->bic_cone = bic(*cone, 4), s->walls_cone = WallCover(p, *cone, Family::kCone);
    if (s->bic_cone < best_bic && clearly_closer(*cone) && s->walls_cone >= kMinWallCover) {
      best = cone, *family = Family::kCone, best_bic = s->bic_cone;
    }
  }
  return best;
}

// The measured fit (FitClippedShape's `envelope`): the chosen family fitted again without the
// points beyond kTrimDeviations robust deviations of the median residual (a touching neighbour's
// leaves that the watershed left on this side of the cut, and the deepest leaves, pull a Huber
// fit still), and the envelope's offset outside it.
// A quadric's centre height and vertical semi-axis are then fitted again on the distance along
// its normal (Surface::Normal), its footprint held, and the envelope itself is fitted last: the
// quadric whose points lie the leaf layer's offset inside it along its normal (`shift`), so the
// offset is not simply added to semi-axes that the points' parallel surface does not share.
// Why only the height: seen from above, a squat shape's footprint is pinned at first order by
// where its points end, and the radial fit reads it within 0.3 % under noise; its vertical
// semi-axis only at second order, by the curvature of its sides, where the radial distance's
// bias under noise (growing as its square) dominates: 3 % long at 6 mm of noise, 20 % at 12
// (276 x 144 mm, synthetic, 20 draws). Fitted on the normal distance in all parameters, the
// real garden's topiary (wageningen_west), whose reconstructed points fill a layer 40-60 mm
// deep, turned into lenses 400-600 mm wide and 80-140 mm tall: a thin shape puts every point
// inside it near one of its two faces. A prism is fitted on its exact distance already; its
// sides and top move out by the offset.
struct Measured {
  FamilyFit refit;                    // ok = false: none (too few points left; a prism's: none trimmed)
  std::vector<Eigen::Vector3d> kept;  // the points it was fitted to
  double offset_mm = 0;
  bool envelope_fitted = false;       // refit is the envelope (the offset is in its axes)
  std::optional<Full> radial_q;       // a quadric's radial fit on `kept`, whose footprint it holds
  Eigen::VectorXd radial_variance;    // ... and its parameters' variances (the held ones' intervals)
  std::optional<Eigen::Vector4d> layer;  // FitLeafLayer's solution, once measured
  Beams beams;                           // the stations it was measured with
};

Measured MeasureEnvelope(const std::vector<Eigen::Vector3d>& p, Family family, const FamilyFit& chosen, const Bounds& bounds,
                         double noise_mm, const std::vector<Eigen::Vector3d>& viewpoints) {
  Measured m;
  if (!viewpoints.empty()) {
    m.beams.viewpoints = viewpoints;
    m.beams.lawn_share = RayShare(Eigen::Vector3d(chosen.q(0), chosen.q(1), bounds.ground), Eigen::Vector3d::UnitZ(), viewpoints);
  }
  const double spread = std::max({1.0, 0.5 * noise_mm, RobustSpread(chosen.residuals)}), med = MedianOf(chosen.residuals);
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (std::abs(chosen.residuals[i] - med) <= kTrimDeviations * spread) m.kept.push_back(p[i]);
  }
  const bool quadric = !Prism(family);
  if (m.kept.size() >= 20 && (quadric || m.kept.size() < p.size())) {
    m.refit = m.kept.size() < p.size() ? FitFamily(m.kept, family, chosen.q, bounds) : chosen;
  }
  if (quadric && m.refit.ok) {
    m.radial_q = m.refit.q;
    m.radial_variance = m.refit.cov.diagonal();
    FamilyFit height = FitFamily(m.kept, family, m.refit.q, bounds, true, 0, true);
    if (height.ok) m.refit = std::move(height);
  }
  const Full& q = m.refit.ok ? m.refit.q : chosen.q;
  // 600 residuals settle three parameters to about a millimetre under 6 mm noise.
  const double sigma = noise_mm > 0 ? std::max(1.0, noise_mm) : 0.0;
  m.layer = FitLeafLayer(LayerResiduals(p, Surface(q, family), 600, 0, m.beams), sigma, nullptr);
  m.offset_mm = std::max(0.0, (*m.layer)(0));
  if (!m.radial_q) return m;
  Full start = q;
  start.segment<3>(3).array() += m.offset_mm;
  FamilyFit envelope = FitFamily(m.kept, family, start, bounds, true, m.offset_mm, true);
  if (envelope.ok) m.refit = std::move(envelope), m.envelope_fitted = true;
  return m;
}

// The prisms (FitClippedShape): a drum about the spheroid, a box about the ellipsoid, each with
// its top where theirs is and its sides a little inside (a prism's corners reach past an
// inscribed quadric's). A prism can only win where its points lie clearly closer to it than to
// the quadric (ChooseFamily), and none lies closer than the sensor's noise: where the
// ellipsoid's spread is within that, none is fitted. Each is tried on at most 300 of the points
// first, and fitted to all of them only where it lies clearly closer to those than the ellipsoid
// does (most shapes are quadrics); else it is left not ok.
void FitPrisms(const std::vector<Eigen::Vector3d>& p, const FamilyFit& spheroid, const FamilyFit& ellipsoid, const Bounds& bounds,
               double ground_mm, double noise_mm, FamilyFit* cylinder, FamilyFit* cuboid, FamilyFit* cone) {
  if (!(RobustSpread(ellipsoid.residuals) > std::max(1.0, noise_mm) / kPrismSpreadShare)) return;
  Full cyl_start = spheroid.q, box_start = ellipsoid.q;
  cyl_start(3) = cyl_start(4) = 0.9 * spheroid.q(3);
  box_start(3) *= 0.85, box_start(4) *= 0.85;
  const double cyl_top = spheroid.q(2) + spheroid.q(5), box_top = ellipsoid.q(2) + ellipsoid.q(5);
  cyl_start(2) = 0.5 * (cyl_top + ground_mm), cyl_start(5) = 0.5 * (cyl_top - ground_mm);
  box_start(2) = 0.5 * (box_top + ground_mm), box_start(5) = 0.5 * (box_top - ground_mm);
  std::vector<Eigen::Vector3d> few;
  std::vector<double> few_ellipsoid;
  for (std::size_t i = 0, every = p.size() / 300 + 1; i < p.size(); i += every) {
    few.push_back(p[i]), few_ellipsoid.push_back(ellipsoid.residuals[i]);
  }
  auto try_prism = [&](Family f, const Full& from) {
    const FamilyFit trial = FitFamily(few, f, from, bounds);
    if (!trial.ok || RobustSpread(trial.residuals) > kPrismSpreadShare * RobustSpread(few_ellipsoid)) return FamilyFit{};
    return FitFamily(p, f, trial.q, bounds);
  };
  *cylinder = try_prism(Family::kCylinder, cyl_start);
  *cuboid = try_prism(Family::kCuboid, box_start);
  // A cone: its base a little wider than the spheroid's widest section (a cone inscribed in
  // the same points reaches past it at the foot), its apex at the spheroid's top. Tried only
  // where that spheroid is prolate: a clipped cone stands taller than its base is wide, and its
  // points' spheroid does too (the squat domes and rough plants that make most objects are not
  // tried, a tenth of find's time on the real garden half).
  if (spheroid.q(5) >= spheroid.q(3)) {
    Full cone_start = cyl_start;
    cone_start(3) = cone_start(4) = 1.2 * spheroid.q(3);
    *cone = try_prism(Family::kCone, cone_start);
  }
}

}  // namespace

ClippedShape FitClippedShape(const std::vector<Eigen::Vector3d>& all, double ground_mm, double noise_mm, double widest_mm,
                             std::size_t max_points, bool jackknife, bool envelope, double max_spread_mm, bool round,
                             const std::vector<Eigen::Vector3d>& viewpoints) {
  ClippedShape s;
  s.points = all.size();
  if (all.size() < 20) return s;
  std::vector<Eigen::Vector3d> p;
  const std::size_t step = all.size() / std::max<std::size_t>(20, max_points) + 1;
  for (std::size_t i = 0; i < all.size(); i += step) p.push_back(all[i]);
  // A start from the points' spread: a disc's points spread a / 2 about its centre; the top at
  // the 98th percentile; the centre half the height below it.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& v : p) mean += v.head<2>();
  mean /= double(p.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  std::vector<double> z;
  for (const auto& v : p) {
    cov += (v.head<2>() - mean) * (v.head<2>() - mean).transpose();
    z.push_back(v.z());
  }
  cov /= double(p.size());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  const double a0 = std::max(10.0, 2 * std::sqrt(std::max(0.0, eig.eigenvalues()(1))));
  const double b0 = std::max(10.0, 2 * std::sqrt(std::max(0.0, eig.eigenvalues()(0))));
  const Eigen::Vector2d major = eig.eigenvectors().col(1);
  // How far the points reach from their centre in the top view (98th percentile): the footprint
  // ends where the points end, give or take a leaf layer.
  std::vector<double> reach_h;
  for (const auto& v : p) reach_h.push_back((v.head<2>() - mean).norm());
  std::nth_element(reach_h.begin(), reach_h.begin() + reach_h.size() * 98 / 100, reach_h.end());
  const double widest = widest_mm > 0 ? widest_mm : std::max(10.0, 1.3 * reach_h[reach_h.size() * 98 / 100]);
  std::nth_element(z.begin(), z.begin() + z.size() * 98 / 100, z.end());
  const double top = z[z.size() * 98 / 100];
  const double height = std::max(10.0, top - ground_mm);
  const double c0 = std::clamp(0.5 * height, 0.25 * (a0 + b0), std::max(0.25 * (a0 + b0), height));
  Full start;
  start << mean.x(), mean.y(), top - c0, a0, b0, c0, std::atan2(major.y(), major.x());
  Bounds bounds;
  const double reach = std::max(a0, b0);
  bounds.ground = ground_mm;
  bounds.lo << mean.x() - reach, mean.y() - reach, ground_mm - height, 0.4 * b0, 0.4 * b0, 0.1 * height, -1e9;
  bounds.hi << mean.x() + reach, mean.y() + reach, top, std::max(0.4 * b0, std::min(2 * a0, widest)),
      std::max(0.4 * b0, std::min(2 * a0, widest)), 2 * height, 1e9;
  Full ball_start = start;
  ball_start(3) = ball_start(4) = ball_start(5) = std::cbrt(a0 * b0 * c0);
  const FamilyFit ball = FitFamily(p, Family::kBall, ball_start, bounds);
  Full sph_start = start;
  sph_start(3) = sph_start(4) = std::sqrt(a0 * b0);
  const FamilyFit spheroid = FitFamily(p, Family::kSpheroid, sph_start, bounds);
  Full ell_start = spheroid.ok ? spheroid.q : start;
  ell_start(3) = std::max(ell_start(3), 1.0) * std::sqrt(a0 / b0), ell_start(4) = std::max(ell_start(4), 1.0) * std::sqrt(b0 / a0);
  ell_start(6) = start(6);
  const FamilyFit ellipsoid = FitFamily(p, Family::kEllipsoid, ell_start, bounds);
  if (!ball.ok || !spheroid.ok || !ellipsoid.ok) return s;
  FamilyFit cylinder, cuboid, cone;
  FitPrisms(p, spheroid, ellipsoid, bounds, ground_mm, noise_mm, &cylinder, &cuboid, &cone);
  Family family = Family::kBall;
  const FamilyFit* best =
      ChooseFamily(p, ball, spheroid, ellipsoid, &cylinder, &cuboid, &cone, noise_mm, max_spread_mm, round, &s, &family);
  s.roughness_mm = RobustSpread(best->residuals);
  Measured measured;
  if (envelope) measured = MeasureEnvelope(p, family, *best, bounds, noise_mm, viewpoints);
  if (measured.refit.ok) best = &measured.refit;
  const std::vector<Eigen::Vector3d>& fitted = measured.refit.ok ? measured.kept : p;
  s.envelope_offset_mm = measured.offset_mm;
  Full q = best->q;
  if (!measured.envelope_fitted) q.segment<3>(3).array() += s.envelope_offset_mm;
  // The first horizontal semi-axis is the longer one; heading in [0, 180).
  if (q(4) > q(3)) std::swap(q(3), q(4)), q(6) += M_PI / 2;
  double heading = std::fmod(q(6), M_PI);
  if (heading < 0) heading += M_PI;
  s.converged = true;
  static const char* const kFamilyNames[] = {"ball", "spheroid", "ellipsoid", "cylinder", "cuboid", "cone"};
  s.family = kFamilyNames[int(family)];
  s.center_mm = q.head<3>();
  s.axes_mm = q.segment<3>(3);
  s.heading_deg = HeadingIndex(family) >= 0 ? heading * 180 / M_PI : 0;
  // The sandwich covariance of the subsample, scaled to all the points (independent residuals).
  // An envelope holds its radial fit's footprint (MeasureEnvelope): the larger of the two fits'.
  const Eigen::VectorXd variance = measured.envelope_fitted && measured.radial_variance.size() == best->cov.rows()
                                       ? best->cov.diagonal().cwiseMax(measured.radial_variance).eval()
                                       : best->cov.diagonal().eval();
  Eigen::VectorXd sd = variance.cwiseMax(0).cwiseSqrt() * 1.96 * std::sqrt(double(p.size()) / double(all.size()));
  if (jackknife) {
    const Eigen::VectorXd jk = JackknifeCi95(fitted, family, best->q, bounds, measured.layer ? &*measured.layer : nullptr, noise_mm,
                                             measured.envelope_fitted ? &*measured.radial_q : nullptr, measured.offset_mm, measured.beams);
    if (jk.size() == sd.size()) sd = sd.cwiseMax(jk), s.jackknifed = true;
  }
  s.center_ci95_mm = sd.head<3>();
  if (family == Family::kBall) {
    s.axes_ci95_mm.setConstant(sd(3));
  } else if (family == Family::kSpheroid) {
    s.axes_ci95_mm << sd(3), sd(3), sd(4);
  } else if (family == Family::kEllipsoid) {
    s.axes_ci95_mm = sd.segment<3>(3);
    if (best->q(4) > best->q(3)) std::swap(s.axes_ci95_mm(0), s.axes_ci95_mm(1));
  } else {
    // A prism's free parameter is its top: its centre's height and half-height are half of it.
    s.center_ci95_mm(2) = 0.5 * sd(2);
    s.axes_ci95_mm << sd(3), family == Family::kCuboid ? sd(4) : sd(3), 0.5 * sd(2);
    if (family == Family::kCuboid && best->q(4) > best->q(3)) std::swap(s.axes_ci95_mm(0), s.axes_ci95_mm(1));
  }
  const double above = s.center_mm.z() - ground_mm, c = s.axes_mm.z();
  const bool cut = above < 0.8 * c;
  if (family == Family::kBall) {
    s.shape = cut ? "dome" : "ball";
  } else if (Prism(family)) {
    s.shape = s.family;
  } else {
    s.shape = family == Family::kSpheroid ? (cut ? "dome" : "spheroid") : "ellipsoid";
    s.form = c < 0.5 * (s.axes_mm.x() + s.axes_mm.y()) ? "oblate" : "prolate";
  }
  // Seen from above, the widest section above the ground.
  const double t = above >= 0 || Prism(family) ? 0.0 : std::min(1.0, -above / c);
  s.footprint_mm = s.axes_mm.head<2>() * std::sqrt(1 - t * t);
  s.top_mm = above + c;
  return s;
}


double DistanceOutside(const ClippedShape& s, const Eigen::Vector3d& p) {
  Full q;
  q << s.center_mm, s.axes_mm.cwiseMax(1e-6), s.heading_deg * M_PI / 180;
  const Family f = s.family == "cylinder" ? Family::kCylinder
                   : s.family == "cuboid" ? Family::kCuboid
                   : s.family == "cone"   ? Family::kCone
                                          : Family::kEllipsoid;
  return Surface(q, f).Normal(p);
}

Eigen::Matrix3d ShapeAxes(const Eigen::Vector3d& up, double heading_deg) {
  const Eigen::Vector3d z = up.normalized();
  Eigen::Vector3d flat = Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z;
  if (flat.norm() < 1e-6) flat = Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(z) * z;
  flat.normalize();
  const double h = heading_deg * M_PI / 180;
  Eigen::Matrix3d axes;
  axes.col(0) = std::cos(h) * flat + std::sin(h) * z.cross(flat);
  axes.col(1) = z.cross(axes.col(0));
  axes.col(2) = z;
  return axes;
}

}  // namespace hedgefit::fitting
