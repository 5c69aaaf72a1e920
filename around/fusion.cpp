#include "around/fusion.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <optional>

#include "around/gicp.hpp"
#include "around/poses.hpp"
#include "pipeline/error.hpp"
#include "pipeline/print.hpp"

namespace hedgefit::around {

namespace {

constexpr double kDeg = M_PI / 180;

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Matrix3d Exp(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

Eigen::Vector3d Log(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// One capture's sighting of a fused hedge.
struct Sighting {
  int view = 0;
  std::size_t hedge = 0;  // index into views[view].hedges
  int cluster = 0;
};

Eigen::Vector3d CentreOf(const ViewHedge& h) { return h.fit.sphere.center_mm; }

// The centre's covariance in the camera frame: its standard errors (at least 0.5 mm: what a
// capture's centre is good to at best), as independent.
Eigen::Matrix3d CentreCovariance(const ViewHedge& h) {
  Eigen::Vector3d se(2, 2, 2);
  if (h.fit.std_error_mm.has_value()) se = h.fit.std_error_mm->head<3>();
  for (int k = 0; k < 3; ++k) se[k] = std::max(0.5, std::isfinite(se[k]) ? se[k] : 5.0);
  return se.cwiseAbs2().asDiagonal();
}

// Greedy matching in the world frame through the current poses: each hedge joins the nearest
// cluster within the gate that holds none of its capture's hedges yet, else starts one.
std::vector<Sighting> Match(const std::vector<View>& views, const std::vector<Eigen::Isometry3d>& poses,
                            const std::vector<bool>& used, double gate_radii, int* clusters) {
  std::vector<Sighting> out;
  std::vector<Eigen::Vector3d> sum;
  std::vector<double> radius;
  std::vector<int> count;
  std::vector<std::vector<int>> members;  // views per cluster
  for (int v = 0; v < int(views.size()); ++v) {
    if (!used[std::size_t(v)]) continue;
    for (std::size_t k = 0; k < views[std::size_t(v)].hedges.size(); ++k) {
      const ViewHedge& h = views[std::size_t(v)].hedges[k];
      if (!h.fit.converged) continue;
      const Eigen::Vector3d c = poses[std::size_t(v)] * CentreOf(h);
      int best = -1;
      double best_d = 1e300;
      for (int j = 0; j < int(sum.size()); ++j) {
        const auto& m = members[std::size_t(j)];
        if (std::find(m.begin(), m.end(), v) != m.end()) continue;
        const double d = (sum[std::size_t(j)] / count[std::size_t(j)] - c).norm();
        if (d < gate_radii * std::max(radius[std::size_t(j)], h.fit.sphere.radius_mm) && d < best_d) best = j, best_d = d;
      }
      if (best < 0) {
        best = int(sum.size());
        sum.push_back(Eigen::Vector3d::Zero()), radius.push_back(0), count.push_back(0), members.emplace_back();
      }
      sum[std::size_t(best)] += c, radius[std::size_t(best)] = std::max(radius[std::size_t(best)], h.fit.sphere.radius_mm);
      ++count[std::size_t(best)];
      members[std::size_t(best)].push_back(v);
      out.push_back(Sighting{v, k, best});
    }
  }
  *clusters = int(sum.size());
  return out;
}

struct Registration {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<Eigen::Vector3d> centres;   // per cluster
  std::vector<Eigen::Matrix<double, 6, 6>> covariance;  // per view: rotation (rad), translation (mm); what the hedges and the prior pin
  // Per cluster, its centre's (mm^2), the first capture held: what the captures' centres and the
  // given poses' prior pin of where the hedge stands in the first capture's frame. A hedge the
  // first capture does not see stands where the others' poses put it, and what no hedge pins of
  // those poses (a row seen across an arc: their turn about a hedge the first capture sees) only
  // the prior holds. Empty without registration.
  std::vector<Eigen::Matrix3d> centre_covariance;
};

// The given poses' steps as an odometry measures them: each used capture's pose relative to the
// previous used one along `path` (PathOrder), held to `o.step_translation_share` of the step's
// length and `o.step_rotation_deg` (a between-factor, as in a pose graph). An odometry's error accumulates
// along the path, so neighbouring poses are far better known relative to each other than each is
// on its own (the prior above). Residuals in the world frame, with the corrections' left
// perturbations: the turn's phi = Log(R_b Z^T R_a^T), d/d(a) -I, d/d(b) +I; the position's
// u = t_b - (R_a z + t_a), d/d(turn a) Skew(R_a z), d/d(move a) -I, d/d(move b) +I.
void AddStepFactors(const std::vector<Eigen::Isometry3d>& given, const std::vector<Eigen::Isometry3d>& poses,
                    const std::vector<int>& slot, const std::vector<int>& path, const FuseOptions& o,
                    Eigen::MatrixXd* H, Eigen::VectorXd* g) {
  if (!(o.step_rotation_deg > 0) || !(o.step_translation_share > 0)) return;
  for (std::size_t k = 1; k < path.size(); ++k) {
    const int a = path[k - 1], b = path[k];
    const Eigen::Isometry3d step = given[std::size_t(a)].inverse() * given[std::size_t(b)];
    const Eigen::Isometry3d& Ta = poses[std::size_t(a)];
    const Eigen::Isometry3d& Tb = poses[std::size_t(b)];
    const Eigen::Vector3d z_world = Ta.linear() * step.translation();
    Eigen::Matrix<double, 6, 1> e;
    e << Log(Tb.linear() * step.linear().transpose() * Ta.linear().transpose()), Tb.translation() - (z_world + Ta.translation());
    // A floor of a centimetre: a capture taken where the last one stood is not known to a micron.
    const double st = std::max(10.0, o.step_translation_share * step.translation().norm());
    const double sr = o.step_rotation_deg * kDeg;
    Eigen::Matrix<double, 6, 1> w;
    w << Eigen::Vector3d::Constant(1 / (sr * sr)), Eigen::Vector3d::Constant(1 / (st * st));
    const int pa = slot[std::size_t(a)], pb = slot[std::size_t(b)];
    Eigen::Matrix<double, 6, 6> Ja = Eigen::Matrix<double, 6, 6>::Zero(), Jb = Eigen::Matrix<double, 6, 6>::Identity();
    Ja.topLeftCorner<3, 3>() = -Eigen::Matrix3d::Identity();
    Ja.bottomLeftCorner<3, 3>() = Skew(z_world);
    Ja.bottomRightCorner<3, 3>() = -Eigen::Matrix3d::Identity();
    const auto add = [&](int pi, const Eigen::Matrix<double, 6, 6>& Ji, int pj, const Eigen::Matrix<double, 6, 6>& Jj) {
      if (pi < 0 || pj < 0) return;
      H->block<6, 6>(6 * pi, 6 * pj) += Ji.transpose() * w.asDiagonal() * Jj;
    };
    add(pa, Ja, pa, Ja), add(pa, Ja, pb, Jb), add(pb, Jb, pa, Ja), add(pb, Jb, pb, Jb);
    if (pa >= 0) g->segment<6>(6 * pa) += Ja.transpose() * w.asDiagonal() * e;
    if (pb >= 0) g->segment<6>(6 * pb) += Jb.transpose() * w.asDiagonal() * e;
  }
}

// The used captures in the order an odometry went through them: by time when every one has a
// time (a manifest need not list them so), else as given.
std::vector<int> PathOrder(const std::vector<View>& views, const std::vector<bool>& used) {
  std::vector<int> path;
  bool timed = true;
  for (int v = 0; v < int(views.size()); ++v) {
    if (!used[std::size_t(v)]) continue;
    path.push_back(v);
    timed = timed && views[std::size_t(v)].time_s.has_value();
  }
  if (timed) {
    std::stable_sort(path.begin(), path.end(),
                     [&](int a, int b) { return *views[std::size_t(a)].time_s < *views[std::size_t(b)].time_s; });
  }
  return path;
}

// Gauss-Newton over the captures' pose corrections (`anchor`'s held where given) and the hedges' centres:
// each sighting's centre, through its capture's pose, on its hedge's centre (weighted by its
// covariance), and each correction drawn to the given pose by the prior.
Registration RegisterByCentres(const std::vector<View>& views, const std::vector<Eigen::Isometry3d>& given,
                               const std::vector<bool>& used, const std::vector<Sighting>& sightings, int clusters,
                               int anchor, const FuseOptions& o,
                               const std::set<std::pair<int, std::size_t>>& odd) {
  const int V = int(views.size());
  std::vector<int> slot(std::size_t(V), -1);
  int n_views = 0;
  for (int v = 0; v < V; ++v) {
    if (used[std::size_t(v)] && v != anchor) slot[std::size_t(v)] = n_views++;
  }
  const int n = 6 * n_views + 3 * clusters;
  Registration r;
  r.poses = given;
  r.centres.assign(std::size_t(clusters), Eigen::Vector3d::Zero());
  std::vector<int> count(std::size_t(clusters), 0);
  for (const Sighting& s : sightings) {
    r.centres[std::size_t(s.cluster)] += given[std::size_t(s.view)] * CentreOf(views[std::size_t(s.view)].hedges[s.hedge]);
    ++count[std::size_t(s.cluster)];
  }
  for (int j = 0; j < clusters; ++j) r.centres[std::size_t(j)] /= std::max(1, count[std::size_t(j)]);
  const double wr = 1 / (o.prior_rotation_deg * kDeg), wt = 1 / o.prior_translation_mm;
  const std::vector<int> path = PathOrder(views, used);
  Eigen::MatrixXd H(n, n), Hs(n, n);  // the hedges' and the prior's; the steps'
  for (int iteration = 0; iteration < 10; ++iteration) {
    H.setZero();
    Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
    for (const Sighting& s : sightings) {
      const ViewHedge& h = views[std::size_t(s.view)].hedges[s.hedge];
      const Eigen::Isometry3d& T = r.poses[std::size_t(s.view)];
      const Eigen::Vector3d p = T * CentreOf(h), e = p - r.centres[std::size_t(s.cluster)];
      const Eigen::Matrix3d cov = T.linear() * CentreCovariance(h) * T.linear().transpose();
      // An odd sighting barely counts: its capture stays where its prior holds it.
      const Eigen::Matrix3d info = cov.inverse() * (odd.count({s.view, s.hedge}) ? 1e-6 : 1.0);
      Eigen::Matrix<double, 3, Eigen::Dynamic> J = Eigen::MatrixXd::Zero(3, n);
      const int pv = slot[std::size_t(s.view)];
      if (pv >= 0) {
        J.block<3, 3>(0, 6 * pv) = -Skew(p - T.translation());
        J.block<3, 3>(0, 6 * pv + 3) = Eigen::Matrix3d::Identity();
      }
      J.block<3, 3>(0, 6 * n_views + 3 * s.cluster) = -Eigen::Matrix3d::Identity();
      H += J.transpose() * info * J;
      g += J.transpose() * info * e;
    }
    for (int v = 0; v < V; ++v) {
      const int pv = slot[std::size_t(v)];
      if (pv < 0) continue;
      const Eigen::Vector3d phi = Log(r.poses[std::size_t(v)].linear() * given[std::size_t(v)].linear().transpose());
      const Eigen::Vector3d u = r.poses[std::size_t(v)].translation() - given[std::size_t(v)].translation();
      H.block<3, 3>(6 * pv, 6 * pv) += wr * wr * Eigen::Matrix3d::Identity();
      H.block<3, 3>(6 * pv + 3, 6 * pv + 3) += wt * wt * Eigen::Matrix3d::Identity();
      g.segment<3>(6 * pv) += wr * wr * phi;
      g.segment<3>(6 * pv + 3) += wt * wt * u;
    }
    // A hedge seen once has nothing to agree with: a tiny prior keeps its centre defined.
    for (int j = 0; j < clusters; ++j) H.block<3, 3>(6 * n_views + 3 * j, 6 * n_views + 3 * j) += 1e-9 * Eigen::Matrix3d::Identity();
    Hs.setZero();
    AddStepFactors(given, r.poses, slot, path, o, &Hs, &g);
    const Eigen::VectorXd step = (H + Hs).ldlt().solve(-g);
    if (!step.allFinite()) break;
    for (int v = 0; v < V; ++v) {
      const int pv = slot[std::size_t(v)];
      if (pv < 0) continue;
      Eigen::Isometry3d& T = r.poses[std::size_t(v)];
      T.linear() = Exp(step.segment<3>(6 * pv)) * T.linear();
      T.translation() += step.segment<3>(6 * pv + 3);
    }
    for (int j = 0; j < clusters; ++j) r.centres[std::size_t(j)] += step.segment<3>(6 * n_views + 3 * j);
    if (step.cwiseAbs().maxCoeff() < 1e-6) break;
  }
  // The covariance with the anchor held (the frame is the first capture's: see
  // RegisterAndLeaveOut), so it holds what the hedges pin between the captures, not the frame's drift.
  // A pose's covariance is what the hedges (and the prior) pin, without the steps: JudgePose
  // counts the degrees of freedom the hedges determined. The centres' is everything's.
  const Eigen::MatrixXd pose_cov = H.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  const Eigen::MatrixXd cov = (H + Hs).ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  r.covariance.assign(std::size_t(V), Eigen::Matrix<double, 6, 6>::Zero());
  for (int v = 0; v < V; ++v) {
    const int pv = slot[std::size_t(v)];
    if (pv >= 0) r.covariance[std::size_t(v)] = pose_cov.block<6, 6>(6 * pv, 6 * pv);
  }
  for (int j = 0; j < clusters; ++j) r.centre_covariance.push_back(cov.block<3, 3>(6 * n_views + 3 * j, 6 * n_views + 3 * j));
  return r;
}

}  // namespace

void FuseOptions::Check() const {
  Table().Validate(*this);
  if (registration != "none" && registration != "centres" && registration != "centres+gicp") {
    throw Error("option 'registration' must be none, centres or centres+gicp, not '" + registration + "'");
  }
}

const pipeline::OptionTable<FuseOptions>& FuseOptions::Table() {
  using O = FuseOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("registration", &O::registration,
               "how the given poses are corrected: none, centres (the hedges' centres agree), centres+gicp (then "
               "generalized ICP on the hedges' surfaces)")
          .Choices({"none", "centres", "centres+gicp"})
          .Add("match_gate", &O::match_gate_radii, "captures' hedges with centres this many radii apart are one hedge", "")
          .Range(0.01, 10)
          .Add("prior_translation", &O::prior_translation_mm, "the given poses' position error, 1 sigma", "mm").Min(0.01)
          .Add("prior_rotation", &O::prior_rotation_deg, "the given poses' orientation error, 1 sigma", "deg").Min(0.001)
          .Add("step_translation", &O::step_translation_share,
               "each step between consecutive captures' given poses (in time when every capture has one, else as "
               "listed) is good to this share of its length, 1 sigma (odometry's error accumulates; 0: not used)", "")
          .Range(0, 1)
          .Add("step_rotation", &O::step_rotation_deg,
               "each step between consecutive captures' given poses turns to within this, 1 sigma (0: not used)", "deg")
          .Min(0)
          .Add("max_correction", &O::max_correction_mm, "a capture whose pose moves further is left out", "mm").Min(0)
          .Add("max_correction_deg", &O::max_correction_deg, "a capture whose pose turns further is left out", "deg").Min(0)
          .Add("max_centre_residual", &O::max_centre_residual_mm,
               "a capture whose hedge centre stays further from the fused one is left out", "mm")
          .Min(0)
          .Add("gicp_distance", &O::gicp_max_distance_mm, "generalized ICP's correspondence distance", "mm").Min(0.1)
          .Add("fit_points", &O::fit_points, "points of a hedge the fused fit uses at most", "points").Range(100, 1e8)
          .Add("cell", &O::cell_deg, "coverage cells about this wide", "deg").Range(1, 45)
          .Add("cell_points", &O::cell_min_points, "a coverage cell with fewer points is not covered", "points").Range(1, 1e6)
          .Add("jackknife", &O::jackknife, "standard errors also from leaving out each capture in turn")
          .Add("confirm_captures", &O::confirm_captures,
               "a hedge fewer captures saw, when more were used, is reported as unconfirmed", "captures")
          .Range(1, 1000)
          .Add("confirm_coverage", &O::confirm_coverage,
               "a hedge whose sphere the captures cover less of is reported as unconfirmed", "")
          .Range(0, 1)
          .Add("confirm_min_radius", &O::confirm_min_radius_mm, "a hedge of a smaller radius is reported as unconfirmed", "mm").Min(0)
          .Add("confirm_max_radius", &O::confirm_max_radius_mm, "a hedge of a larger radius is reported as unconfirmed", "mm").Min(1);
  return table;
}

double CoveredShare(const std::vector<Eigen::Vector3d>& points_mm, const Eigen::Vector3d& center, const Eigen::Vector3d& up,
                    double cell_deg, int min_points) {
  const Eigen::Vector3d z = up.normalized(), x = z.unitOrthogonal(), y = z.cross(x);
  // Equal-area cells: rings of equal height in cos(theta), each cut into equal sectors.
  const int rings = std::max(2, int(std::lround(180 / cell_deg)));
  const int sectors = std::max(4, int(std::lround(360 / cell_deg)));
  std::vector<int> count(std::size_t(rings * sectors), 0);
  for (const auto& p : points_mm) {
    const Eigen::Vector3d d = (p - center).normalized();
    if (!d.allFinite()) continue;
    const int ring = std::clamp(int((d.dot(z) + 1) / 2 * rings), 0, rings - 1);
    double phi = std::atan2(d.dot(y), d.dot(x));
    if (phi < 0) phi += 2 * M_PI;
    const int sector = std::clamp(int(phi / (2 * M_PI) * sectors), 0, sectors - 1);
    ++count[std::size_t(ring * sectors + sector)];
  }
  const auto covered = std::count_if(count.begin(), count.end(), [&](int c) { return c >= min_points; });
  return double(covered) / double(count.size());
}

namespace {

// The fused envelope of one hedge from the sightings `members` (indices into `sightings`);
// `leave_out` a capture to leave out (-1: none).
fitting::EnvelopeFit FitTogether(const std::vector<View>& views, const std::vector<Eigen::Isometry3d>& poses,
                                 const std::vector<Sighting>& sightings, const std::vector<std::size_t>& members,
                                 int leave_out, const FuseOptions& o, const fitting::Sphere& start) {
  std::size_t total = 0;
  for (std::size_t m : members) total += views[std::size_t(sightings[m].view)].hedges[sightings[m].hedge].points_mm.size();
  const std::size_t step = std::max<std::size_t>(1, (total + std::size_t(o.fit_points) - 1) / std::size_t(o.fit_points));
  std::vector<Eigen::Vector3d> pts, from;
  std::vector<double> pixel;
  std::vector<cloud::TangentRay> outline;
  bool all_pixel = true;
  for (std::size_t m : members) {
    const Sighting& s = sightings[m];
    if (s.view == leave_out) continue;
    const ViewHedge& h = views[std::size_t(s.view)].hedges[s.hedge];
    const Eigen::Isometry3d& T = poses[std::size_t(s.view)];
    all_pixel = all_pixel && h.pixel_mm.size() == h.points_mm.size();
    for (std::size_t i = 0; i < h.points_mm.size(); i += step) {
      pts.push_back(T * h.points_mm[i]);
      from.push_back(T.translation());
      pixel.push_back(h.pixel_mm.size() == h.points_mm.size() ? h.pixel_mm[i] : 0.0);
    }
    for (cloud::TangentRay ray : h.outline) {
      ray.origin_mm = T * ray.origin_mm;
      ray.direction = T.linear() * ray.direction;
      outline.push_back(ray);
    }
  }
  fitting::EnvelopeFitOptions eo;
  eo.max_points = 0;  // thinned above, capture by capture
  return fitting::FitEnvelope(pts, eo, &start, all_pixel ? &pixel : nullptr, outline.empty() ? nullptr : &outline, &from);
}

}  // namespace

namespace {

// Where registration stands: the captures in use, their poses, the sightings and the hedges.
struct State {
  std::vector<Eigen::Isometry3d> given, poses;
  std::vector<bool> used;
  /// (capture, hedge) whose own sphere disagrees with the others' (a bulge, a neighbour taken in):
  /// it does not move its capture's pose until it has been fitted again with the fused radius.
  std::set<std::pair<int, std::size_t>> odd;
  std::vector<Sighting> sightings;
  int clusters = 0;
  Registration reg;
  int FirstUsed() const {
    for (std::size_t v = 0; v < used.size(); ++v) {
      if (used[v]) return int(v);
    }
    return -1;
  }
};

// Each sighting's hedge centre through the given poses, averaged per hedge: registration "none".
Registration AsGiven(const std::vector<View>& views, const State& s) {
  Registration reg;
  reg.poses = s.given;
  reg.covariance.assign(s.given.size(), Eigen::Matrix<double, 6, 6>::Zero());
  reg.centres.assign(static_cast<std::size_t>(s.clusters), Eigen::Vector3d::Zero());
  std::vector<int> count(static_cast<std::size_t>(s.clusters), 0);
  for (const Sighting& x : s.sightings) {
    reg.centres[std::size_t(x.cluster)] += s.given[std::size_t(x.view)] * CentreOf(views[std::size_t(x.view)].hedges[x.hedge]);
    ++count[std::size_t(x.cluster)];
  }
  for (int j = 0; j < s.clusters; ++j) reg.centres[std::size_t(j)] /= std::max(1, count[std::size_t(j)]);
  return reg;
}

// Fills capture v's PoseResult from the registration; returns why it must be left out ("" = keep).
std::string JudgePose(const std::vector<View>& views, const State& s, const std::vector<int>& seen_by, int v, int anchor,
                      const FuseOptions& o, PoseResult* p) {
  p->refined = s.reg.poses[std::size_t(v)];
  p->correction_deg = RotationDeg(p->refined * p->given.inverse());
  p->correction_mm = (p->refined.translation() - p->given.translation()).norm();
  // How well it is determined: in units of the prior, directions the hedges pinned have shrunk
  // far below 1; those left near 1 (one ball: the turn about it) are held at the given pose.
  const Eigen::Matrix<double, 6, 6>& c = s.reg.covariance[std::size_t(v)];
  Eigen::Matrix<double, 6, 1> prior;
  prior << Eigen::Vector3d::Constant(o.prior_rotation_deg * kDeg), Eigen::Vector3d::Constant(o.prior_translation_mm);
  const Eigen::Matrix<double, 6, 6> white = prior.cwiseInverse().asDiagonal() * c * prior.cwiseInverse().asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(white);
  Eigen::Matrix<double, 6, 6> pinned = Eigen::Matrix<double, 6, 6>::Zero();
  p->determined_dof = 0;
  for (int k = 0; k < 6; ++k) {
    if (eig.eigenvalues()[k] > 0.25) continue;  // a standard deviation over half the prior's: not pinned
    ++p->determined_dof;
    pinned += eig.eigenvalues()[k] * eig.eigenvectors().col(k) * eig.eigenvectors().col(k).transpose();
  }
  if (o.registration == "none") p->determined_dof = 0;
  pinned = prior.asDiagonal() * pinned * prior.asDiagonal();
  const auto largest = [](const Eigen::Matrix3d& m) {
    return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(m).eigenvalues().maxCoeff()));
  };
  p->sigma_deg = largest(pinned.topLeftCorner<3, 3>()) / kDeg;
  p->sigma_mm = largest(pinned.bottomRightCorner<3, 3>());
  p->centre_residual_mm = 0;
  p->hedges = 0;
  bool shared = false;
  for (const Sighting& x : s.sightings) {
    if (x.view != v) continue;
    ++p->hedges;
    shared = shared || seen_by[std::size_t(x.cluster)] > 1;
    if (s.odd.count({x.view, x.hedge})) continue;  // judged once fitted again (RefitWithFusedRadius)
    const Eigen::Vector3d c_world = p->refined * CentreOf(views[std::size_t(v)].hedges[x.hedge]);
    p->centre_residual_mm = std::max(p->centre_residual_mm, (c_world - s.reg.centres[std::size_t(x.cluster)]).norm());
  }
  if (v != anchor && !shared && views.size() > 1) {
    return "none of its hedges is within " + pipeline::Format("%g", o.match_gate_radii) +
           " radii of another capture's through the given pose (a pose far off, or another place)";
  }
  if (p->correction_mm > o.max_correction_mm || p->correction_deg > o.max_correction_deg) {
    return pipeline::Format("its pose would move %.0f mm and turn %.1f deg (limits %g mm, %g deg)", p->correction_mm,
                            p->correction_deg, o.max_correction_mm, o.max_correction_deg);
  }
  if (o.registration != "none" && p->centre_residual_mm > o.max_centre_residual_mm) {
    return pipeline::Format("its hedge centre stays %.1f mm from the others' after registration (limit %g mm)",
                            p->centre_residual_mm, o.max_centre_residual_mm);
  }
  return "";
}

// Matches and registers, leaving out the captures that do not fit, until none more is left out.
void RegisterAndLeaveOut(const std::vector<View>& views, const FuseOptions& o, State* s, std::vector<PoseResult>* poses) {
  const int V = int(views.size());
  for (int round = 0; round < 4; ++round) {
    const int anchor = s->FirstUsed();
    s->sightings = Match(views, s->given, s->used, o.match_gate_radii, &s->clusters);
    // The first capture is held where it was given: odometry starts there, and a world frame is
    // the first capture's in a robot's map. Each other capture's given pose is its prior. (Held
    // free and the whole moved back onto the first capture afterwards, every other pose took the
    // first one's own correction: exact poses moved 0.3-2.8 mm on the hedgefit renderer's arcs
    // and rings, and 0.0-0.1 mm held; the fused centres were 0.17-1.78 mm off, and are 0.16-0.74.)
    s->reg = o.registration == "none" ? AsGiven(views, *s)
                                      : RegisterByCentres(views, s->given, s->used, s->sightings, s->clusters, anchor, o, s->odd);
    std::vector<int> seen_by(static_cast<std::size_t>(s->clusters), 0);
    for (const Sighting& x : s->sightings) ++seen_by[std::size_t(x.cluster)];
    bool dropped = false;
    for (int v = 0; v < V; ++v) {
      if (!s->used[std::size_t(v)]) continue;
      PoseResult& p = (*poses)[std::size_t(v)];
      const std::string why = JudgePose(views, *s, seen_by, v, anchor, o, &p);
      if (why.empty()) continue;
      s->used[std::size_t(v)] = false, p.used = false, p.left_out = why, p.refined = p.given;
      p.correction_mm = p.correction_deg = 0;
      dropped = true;
    }
    if (!dropped) break;
  }
  s->poses = s->reg.poses;
}

std::vector<std::vector<std::size_t>> Members(const std::vector<Sighting>& sightings, int clusters) {
  std::vector<std::vector<std::size_t>> members(static_cast<std::size_t>(clusters));
  for (std::size_t k = 0; k < sightings.size(); ++k) members[std::size_t(sightings[k].cluster)].push_back(k);
  return members;
}

// The mean of the sightings' own spheres in the world: a start for the fused fit.
fitting::Sphere StartOf(const std::vector<View>& views, const State& s, const std::vector<std::size_t>& mem) {
  fitting::Sphere start{Eigen::Vector3d::Zero(), 0};
  for (std::size_t m : mem) {
    const Sighting& x = s.sightings[m];
    const ViewHedge& h = views[std::size_t(x.view)].hedges[x.hedge];
    start.center_mm += s.poses[std::size_t(x.view)] * CentreOf(h) / double(mem.size());
    start.radius_mm += h.fit.sphere.radius_mm / double(mem.size());
  }
  return start;
}

// Each capture's hedges fitted again with the fused radius as a prior: alone, a cap's radius
// trades against its centre's depth, so a one-sided fit's centre sits a few millimetres off along
// the view; with the radius known, its centre is what the capture says.
void RefitWithFusedRadius(State* s, const FuseOptions& o, std::vector<View>* views) {
  const auto members = Members(s->sightings, s->clusters);
  for (const auto& all : members) {
    if (all.size() < 2) continue;
    std::vector<std::size_t> mem;  // the joint fit without the odd ones
    for (std::size_t m : all) {
      if (!s->odd.count({s->sightings[m].view, s->sightings[m].hedge})) mem.push_back(m);
    }
    if (mem.empty()) continue;
    const fitting::EnvelopeFit joint = FitTogether(*views, s->poses, s->sightings, mem, -1, o, StartOf(*views, *s, mem));
    if (!joint.fit.converged) continue;
    const double sd = std::max(0.3, joint.std_error_mm ? (*joint.std_error_mm)[3] : 1.0);
    for (std::size_t m : all) {
      const Sighting& x = s->sightings[m];
      ViewHedge& h = (*views)[std::size_t(x.view)].hedges[x.hedge];
      fitting::EnvelopeFitOptions eo;
      eo.radius_prior_mm = joint.fit.sphere.radius_mm;
      eo.radius_prior_sd_mm = sd;
      eo.shape_prior = joint.shape;  // the leaves as all captures see them: one capture's own trade against its depth
      // With the radius and the leaves known, a bulge or a neighbour's leaves past the envelope
      // are not this sphere's: a larger outlier share lets them go rather than pull the centre.
      eo.outlier_share = 0.2;
      // An odd one starts where the others put the hedge (through its capture's pose), not from
      // its own wrong sphere.
      const bool odd = s->odd.count({x.view, x.hedge}) > 0;
      const Eigen::Vector3d from = odd ? Eigen::Vector3d(s->poses[std::size_t(x.view)].inverse() * joint.fit.sphere.center_mm)
                                       : h.fit.sphere.center_mm;
      const fitting::Sphere start{from, joint.fit.sphere.radius_mm};
      const fitting::EnvelopeFit e = fitting::FitEnvelope(h.points_mm, eo, &start,
                                                          h.pixel_mm.size() == h.points_mm.size() ? &h.pixel_mm : nullptr,
                                                          h.outline.empty() ? nullptr : &h.outline);
      if (!e.fit.converged) continue;
      h.fit.sphere = e.fit.sphere;
      if (e.std_error_mm) h.fit.std_error_mm = e.std_error_mm;
      // An odd one that now agrees with the others (its centre through its pose within 10 mm of
      // theirs: what the odometry's error leaves before it is registered) counts from now on.
      const Eigen::Vector3d seen = s->poses[std::size_t(x.view)] * e.fit.sphere.center_mm;
      if (odd && (seen - joint.fit.sphere.center_mm).norm() < 10) s->odd.erase({x.view, x.hedge});
    }
  }
}

// Marks the sightings whose own radius is more than 2 % from the median of their hedge's
// sightings: a capture that took a bulge or a neighbour in with the ball (one capture's own radius
// is good to 0.2-3 mm on both renderers' gardens; a row's far ball peeking round the near one made
// it 13 mm large, a bulge 47 mm small). Its own standard error is no guide: such a fit is poor, and
// its wide interval would excuse it.
void MarkOdd(const std::vector<View>& views, State* s) {
  for (const auto& mem : Members(s->sightings, s->clusters)) {
    if (mem.size() < 3) continue;
    std::vector<double> radii;
    for (std::size_t m : mem) radii.push_back(views[std::size_t(s->sightings[m].view)].hedges[s->sightings[m].hedge].fit.sphere.radius_mm);
    std::nth_element(radii.begin(), radii.begin() + std::ptrdiff_t(radii.size() / 2), radii.end());
    const double median = radii[radii.size() / 2];
    for (std::size_t m : mem) {
      const ViewHedge& h = views[std::size_t(s->sightings[m].view)].hedges[s->sightings[m].hedge];
      if (std::abs(h.fit.sphere.radius_mm - median) > 0.02 * median) s->odd.insert({s->sightings[m].view, s->sightings[m].hedge});
    }
  }
}

// The fused fit of one hedge, its standard errors (the likelihood's and leaving each capture
// out), and its coverage per capture and together.
std::optional<FusedHedge> FuseHedge(const std::vector<View>& views, const State& s, const std::vector<std::size_t>& mem,
                                    const Eigen::Vector3d& up, const FuseOptions& o, std::vector<std::string>* warnings) {
  FusedHedge f;
  const fitting::Sphere start = StartOf(views, s, mem);
  for (std::size_t m : mem) {
    const Sighting& x = s.sightings[m];
    const ViewHedge& h = views[std::size_t(x.view)].hedges[x.hedge];
    f.views.push_back(x.view);
    f.view_centres_mm.push_back(s.poses[std::size_t(x.view)] * CentreOf(h));
    f.view_radii_mm.push_back(h.fit.sphere.radius_mm);
  }
  f.fit = FitTogether(views, s.poses, s.sightings, mem, -1, o, start);
  if (!f.fit.fit.converged) {
    warnings->push_back(pipeline::Format("hedge near (%.0f, %.0f, %.0f) mm: the fused fit did not converge (%s)",
                                         start.center_mm.x(), start.center_mm.y(), start.center_mm.z(),
                                         f.fit.fit.message.c_str()));
    return std::nullopt;
  }
  if (f.fit.std_error_mm) f.likelihood_se_mm = *f.fit.std_error_mm;
  // Leave each capture out in turn: the spread of those fits is the views' disagreement.
  if (o.jackknife && mem.size() >= 3) {
    std::vector<Eigen::Vector4d> loo;
    for (std::size_t m : mem) {
      const fitting::EnvelopeFit e = FitTogether(views, s.poses, s.sightings, mem, s.sightings[m].view, o, f.fit.fit.sphere);
      const fitting::Sphere& q = e.fit.sphere;
      if (e.fit.converged) loo.emplace_back(q.center_mm.x(), q.center_mm.y(), q.center_mm.z(), q.radius_mm);
    }
    if (loo.size() >= 3) {
      Eigen::Vector4d mean = Eigen::Vector4d::Zero(), ss = Eigen::Vector4d::Zero();
      for (const auto& x : loo) mean += x / double(loo.size());
      for (const auto& x : loo) ss += (x - mean).cwiseAbs2();
      f.jackknife_se_mm = (ss * double(loo.size() - 1) / double(loo.size())).cwiseSqrt();
    }
  }
  const int cluster = s.sightings[mem.front()].cluster;
  if (std::size_t(cluster) < s.reg.centre_covariance.size()) {
    f.registration_se_mm = s.reg.centre_covariance[std::size_t(cluster)].diagonal().cwiseMax(0).cwiseSqrt();
  }
  for (int k = 0; k < 4; ++k) {
    // The larger of what is known: the fit's, the views' disagreement, and (the centre) where the
    // registration could put the hedge.
    double se = NAN;
    for (double x : {f.likelihood_se_mm[k], f.jackknife_se_mm[k], k < 3 ? f.registration_se_mm[k] : NAN}) {
      if (std::isfinite(x)) se = std::isfinite(se) ? std::max(se, x) : x;
    }
    f.std_error_mm[k] = se;
  }
  f.fit.fit.std_error_mm = f.std_error_mm;
  f.fit.fit.std_error_own = true;
  std::vector<Eigen::Vector3d> all;
  for (std::size_t m : mem) {
    const Sighting& x = s.sightings[m];
    std::vector<Eigen::Vector3d> pts;
    for (const auto& p : views[std::size_t(x.view)].hedges[x.hedge].points_mm) pts.push_back(s.poses[std::size_t(x.view)] * p);
    f.view_coverage.push_back(CoveredShare(pts, f.fit.fit.sphere.center_mm, up, o.cell_deg, o.cell_min_points));
    all.insert(all.end(), pts.begin(), pts.end());
  }
  f.points = all.size();
  f.coverage = CoveredShare(all, f.fit.fit.sphere.center_mm, up, o.cell_deg, o.cell_min_points);
  return f;
}

// Why a fused hedge is not one to act on (FuseOptions::min_captures ...), or "".
std::string Unconfirmed(const FusedHedge& h, int used_captures, const FuseOptions& o) {
  const double r = h.fit.fit.sphere.radius_mm;
  if (int(h.views.size()) < o.confirm_captures && used_captures > int(h.views.size())) {
    return pipeline::Format("seen by %d of the %d captures used (at least %d must see a hedge: confirm_captures)",
                            int(h.views.size()), used_captures, o.confirm_captures);
  }
  if (h.coverage < o.confirm_coverage) {
    return pipeline::Format("the captures cover %.1f %% of its sphere (at least %.0f %%: confirm_coverage)", 100 * h.coverage,
                            100 * o.confirm_coverage);
  }
  if (!(r >= o.confirm_min_radius_mm && r <= o.confirm_max_radius_mm)) {
    return pipeline::Format("its radius %.0f mm is outside %.0f-%.0f mm (confirm_min_radius, confirm_max_radius)", r, o.confirm_min_radius_mm,
                            o.confirm_max_radius_mm);
  }
  if (!h.std_error_mm.allFinite()) return "its interval could not be computed";
  return "";
}

// All used captures' hedge points in the world, with their fused hedge, capture and viewpoint.
cloud::PointCloud FusedCloud(const std::vector<View>& views, const State& s, const std::vector<int>& id_of_cluster) {
  cloud::PointCloud c;
  std::vector<float>& hid = c.fields[cloud::kHedgeIdField];
  std::vector<float>& cap = c.fields["capture"];
  std::vector<float>& pix = c.fields[cloud::kPixelSizeField];
  std::vector<float>& vx = c.fields["view_x_mm"];
  std::vector<float>& vy = c.fields["view_y_mm"];
  std::vector<float>& vz = c.fields["view_z_mm"];
  for (const Sighting& x : s.sightings) {
    const int id = id_of_cluster[std::size_t(x.cluster)];
    if (id <= 0) continue;
    const ViewHedge& h = views[std::size_t(x.view)].hedges[x.hedge];
    const Eigen::Isometry3d& T = s.poses[std::size_t(x.view)];
    for (std::size_t i = 0; i < h.points_mm.size(); ++i) {
      c.points_mm.push_back((T * h.points_mm[i]).cast<float>());
      hid.push_back(float(id));
      cap.push_back(float(x.view + 1));
      pix.push_back(h.pixel_mm.size() == h.points_mm.size() ? float(h.pixel_mm[i]) : NAN);
      vx.push_back(float(T.translation().x())), vy.push_back(float(T.translation().y())), vz.push_back(float(T.translation().z()));
    }
  }
  c.Flatten();
  return c;
}

}  // namespace

FuseResult Fuse(const std::vector<View>& input, const FuseOptions& o) {
  o.Check();
  FuseResult out;
  std::vector<View> views = input;  // their hedges' own fits are refined below
  const int V = int(views.size());
  State s;
  s.given.resize(std::size_t(V));
  s.used.assign(std::size_t(V), true);
  out.poses.resize(std::size_t(V));
  for (int v = 0; v < V; ++v) {
    s.given[std::size_t(v)] = views[std::size_t(v)].world_from_camera;
    PoseResult& p = out.poses[std::size_t(v)];
    p.name = views[std::size_t(v)].name;
    p.given = p.refined = s.given[std::size_t(v)];
    const bool any = std::any_of(views[std::size_t(v)].hedges.begin(), views[std::size_t(v)].hedges.end(),
                                 [](const ViewHedge& h) { return h.fit.converged; });
    if (!any) {
      s.used[std::size_t(v)] = false, p.used = false;
      p.left_out = views[std::size_t(v)].failed.empty() ? "no hedge measured in it" : views[std::size_t(v)].failed;
    }
  }
  if (s.FirstUsed() < 0) throw Error("no capture gave a hedge: nothing to fuse");
  s.sightings = Match(views, s.given, s.used, o.match_gate_radii, &s.clusters);
  MarkOdd(views, &s);
  RegisterAndLeaveOut(views, o, &s, &out.poses);
  if (o.registration != "none") {
    for (int pass = 0; pass < 2; ++pass) {
      RefitWithFusedRadius(&s, o, &views);
      RegisterAndLeaveOut(views, o, &s, &out.poses);
    }
  }
  if (o.registration == "centres+gicp") {
    std::vector<double> rms(std::size_t(V), 0.0);
    RefineByGicp(views, s.used, s.FirstUsed(), o, &s.poses, &rms);
    for (int v = 0; v < V; ++v) {
      if (!s.used[std::size_t(v)]) continue;
      PoseResult& p = out.poses[std::size_t(v)];
      p.refined = s.poses[std::size_t(v)];
      p.gicp_rms_mm = rms[std::size_t(v)];
      p.correction_deg = RotationDeg(p.refined * p.given.inverse());
      p.correction_mm = (p.refined.translation() - p.given.translation()).norm();
    }
  }
  for (int v = 0; v < V; ++v) {
    if (!s.used[std::size_t(v)]) out.warnings.push_back("capture " + views[std::size_t(v)].name + " left out: " + out.poses[std::size_t(v)].left_out);
  }
  // The vertical: the cameras are held upright (their -y), pitched about as much up as down.
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  for (int v = 0; v < V; ++v) {
    if (s.used[std::size_t(v)]) up += s.poses[std::size_t(v)].linear() * -Eigen::Vector3d::UnitY();
  }
  out.up = up.normalized();
  // The fused hedges (matched again through the refined poses), numbered along the world's x.
  s.sightings = Match(views, s.poses, s.used, o.match_gate_radii, &s.clusters);
  // A capture's view of a hedge that still disagrees after it was refitted (a neighbour merged
  // with the ball in its segmentation) is left out of the fit, and said so; a capture with no other
  // view is left out.
  auto members = Members(s.sightings, s.clusters);
  for (auto& mem : members) {
    std::vector<std::size_t> kept;
    for (std::size_t m : mem) {
      const Sighting& x = s.sightings[m];
      if (!s.odd.count({x.view, x.hedge})) {
        kept.push_back(m);
        continue;
      }
      const ViewHedge& h = views[std::size_t(x.view)].hedges[x.hedge];
      const Eigen::Vector3d c = s.poses[std::size_t(x.view)] * CentreOf(h);
      out.warnings.push_back(pipeline::Format(
          "capture %s: its view of the hedge near (%.0f, %.0f, %.0f) mm is left out: its own sphere (r %.1f mm) "
          "disagrees with the other captures' (a neighbour or a bulge taken in with the ball)",
          views[std::size_t(x.view)].name.c_str(), c.x(), c.y(), c.z(), h.fit.sphere.radius_mm));
    }
    if (!kept.empty()) mem = kept;
  }
  for (int v = 0; v < V; ++v) {
    if (!s.used[std::size_t(v)]) continue;
    bool any = false;
    for (const auto& mem : members) {
      for (std::size_t m : mem) any = any || s.sightings[m].view == v;
    }
    if (!any) {
      s.used[std::size_t(v)] = false;
      PoseResult& p = out.poses[std::size_t(v)];
      p.used = false, p.refined = p.given, p.correction_mm = p.correction_deg = 0;
      p.left_out = "its views of the hedges disagree with the other captures'";
    }
  }
  std::vector<std::pair<int, FusedHedge>> fused;
  for (int j = 0; j < s.clusters; ++j) {
    if (auto f = FuseHedge(views, s, members[std::size_t(j)], out.up, o, &out.warnings)) fused.emplace_back(j, *f);
  }
  std::sort(fused.begin(), fused.end(), [](const auto& a, const auto& b) {
    return a.second.fit.fit.sphere.center_mm.x() < b.second.fit.fit.sphere.center_mm.x();
  });
  std::vector<int> id_of_cluster(std::size_t(s.clusters), 0);
  for (std::size_t k = 0; k < fused.size(); ++k) {
    id_of_cluster[std::size_t(fused[k].first)] = int(k) + 1;
    out.hedges.push_back(fused[k].second);
    out.hedges.back().id = int(k) + 1;
    out.hedges.back().fit.fit.hedge_id = int(k) + 1;
  }
  out.cloud = FusedCloud(views, s, id_of_cluster);
  const int used = int(std::count(s.used.begin(), s.used.end(), true));
  for (FusedHedge& h : out.hedges) {
    h.unconfirmed = Unconfirmed(h, used, o);
    if (h.unconfirmed.empty()) continue;
    const Eigen::Vector3d& c = h.fit.fit.sphere.center_mm;
    out.warnings.push_back(pipeline::Format("hedge %d near (%.0f, %.0f, %.0f) mm is unconfirmed: %s", h.id, c.x(), c.y(),
                                            c.z(), h.unconfirmed.c_str()));
  }
  return out;
}

}  // namespace hedgefit::around
