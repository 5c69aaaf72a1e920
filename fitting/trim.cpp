#include "fitting/trim.hpp"

#include "fitting/shape_fit.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <nlohmann/json.hpp>

#include <cstdio>

#include "pipeline/error.hpp"
#include "pipeline/print.hpp"

namespace hedgefit::fitting {

namespace {

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(std::floor(q * double(v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
  return v[k];
}

// The directions no point came from, on a 15-degree grid about the pole: [elevation, azimuth] of
// each cell none of whose bins was seen (elevation from the pole's equator towards the pole,
// azimuth about it from the grid's x, PlanTrim's frame).
nlohmann::json UnseenDirections(const TrimPlan& t) {
  constexpr int kBands = 12, kSectors = 24;
  std::vector<int> seen(kBands * kSectors, 0), any(kBands * kSectors, 0);
  const Eigen::Vector3d z = t.pole.normalized(), x = z.unitOrthogonal(), y = z.cross(x);
  for (const TrimBin& b : t.bins) {
    const double el = std::asin(std::clamp(b.direction.dot(z), -1.0, 1.0)) * 180 / M_PI;
    double az = std::atan2(b.direction.dot(y), b.direction.dot(x)) * 180 / M_PI;
    if (az < 0) az += 360;
    const int band = std::clamp(int((el + 90) / 15), 0, kBands - 1), sector = std::clamp(int(az / 15), 0, kSectors - 1);
    any[band * kSectors + sector] = 1;
    seen[band * kSectors + sector] |= b.seen ? 1 : 0;
  }
  nlohmann::json out = nlohmann::json::array();
  for (int k = 0; k < kBands * kSectors; ++k) {
    if (any[k] && !seen[k]) out.push_back({-90 + 15 * (k / kSectors) + 7.5, 15 * (k % kSectors) + 7.5});
  }
  return out;
}

}  // namespace

namespace {

// The target's radius along a unit direction: the sphere's, or the shape's (its semi-axes along
// the heading, across it and the pole). Each shape is the unit ball of a gauge of (a, b, c), the
// direction's components over the semi-axes: the ellipsoid's Euclidean, the box's largest, the
// drum's the larger of its radial and its vertical share.
struct TargetRadius {
  bool shaped;
  double radius_mm;
  Eigen::Vector3d axes_mm, along, across, pole;
  std::string shape;
  double operator()(const Eigen::Vector3d& u) const {
    if (!shaped) return radius_mm;
    const double a = u.dot(along) / axes_mm.x(), b = u.dot(across) / axes_mm.y(), c = u.dot(pole) / axes_mm.z();
    if (shape == "cuboid") return 1 / std::max({std::abs(a), std::abs(b), std::abs(c)});
    if (shape == "cylinder") return 1 / std::max(std::hypot(a, b), std::abs(c));
    // A cone (base radius A at -C, apex at +C on the axis): in units of the semi-axes its side is
    // rho + w / 2 = 1 / 2 and its base w = -1, so a ray meets them at the scale 1 / (2 rho + w)
    // and 1 / -w, whichever comes first.
    if (shape == "cone") return 1 / std::max(2 * std::hypot(a, b) + c, -c);
    return 1 / std::sqrt(a * a + b * b + c * c);
  }
};

// A point seen from the target centre: about the pole, and how far.
struct Direction {
  double cos_theta, phi, r;
};

// Equal-area grid of about bin x bin radians at the equator.
struct Grid {
  int rings, sectors;
  double cell_sr;
  explicit Grid(double bin) {
    sectors = std::max(4, static_cast<int>(std::lround(2 * M_PI / bin)));
    rings = std::max(2, static_cast<int>(std::lround(2.0 / bin)));  // cos(theta) steps of ~bin at the equator
    cell_sr = 4 * M_PI / (double(rings) * double(sectors));
  }
  long Cell(const Direction& d) const {
    const int ring = std::min(rings - 1, static_cast<int>((d.cos_theta + 1) / 2 * rings));
    const int sector = std::min(sectors - 1, static_cast<int>(d.phi / (2 * M_PI) * sectors));
    return long(ring) * sectors + sector;
  }
};

// A direction within a cell of `grid`: at (ring + u, sector + v), u and v in [0, 1] (0.5, 0.5
// its centre), in the frame whose z is the grid's pole.
Eigen::Vector3d CellDirection(const Grid& grid, int ring, int sector, double u, double v, const Eigen::Vector3d& x,
                              const Eigen::Vector3d& y, const Eigen::Vector3d& z) {
  const double ct = -1 + (ring + u) * 2.0 / grid.rings, st = std::sqrt(std::max(0.0, 1 - ct * ct));
  const double phi = (sector + v) * 2 * M_PI / grid.sectors - M_PI;
  return ct * z + st * (std::cos(phi) * x + std::sin(phi) * y);
}

// The radius of a shaped target's volume: an ellipsoid's (4/3 pi abc), a drum's (2 pi R^2 h), a
// box's (8 abc), a cone's (2/3 pi R^2 h).
double VolumeRadius(const TrimOptions& o) {
  const double volume = o.shape == "cuboid" ? 8 * o.axes_mm.prod()
                        : o.shape == "cylinder" ? 2 * M_PI * o.axes_mm.prod()
                        : o.shape == "cone"     ? 2 * M_PI / 3 * o.axes_mm.prod()
                                                : 4 * M_PI / 3 * o.axes_mm.prod();
  return std::cbrt(volume * 3 / (4 * M_PI));
}

// The options' checks, each naming the option and what would fix it.
void CheckTrim(const Sphere& target, const TrimOptions& o, const Eigen::Vector3d& pole) {
  if (!(target.radius_mm > 0) || !std::isfinite(target.radius_mm) || !target.center_mm.allFinite()) {
    throw Error("trim: the target needs a finite centre and a radius > 0 mm");
  }
  if (!(o.bin_deg == 0 || (o.bin_deg >= 0.1 && o.bin_deg <= 90))) {
    throw Error("trim: option 'bin_deg' must be 0 (automatic) or in [0.1, 90] degrees");
  }
  if (!(o.tolerance_mm >= 0) || !std::isfinite(o.tolerance_mm)) throw Error("trim: option 'tolerance' must be >= 0 mm");
  if (o.min_bin_points < 1) throw Error("trim: option 'min_bin_points' must be >= 1");
  if (!pole.allFinite() || pole.norm() == 0) throw Error("trim: the grid's pole must be a non-zero vector");
  if (!(o.clipped_share > 0 && o.clipped_share <= 1)) throw Error("trim: option 'clipped_share' must be in (0, 1]");
  if (o.axes_mm != Eigen::Vector3d::Zero() && !(o.axes_mm.minCoeff() > 0 && o.axes_mm.allFinite())) {
    throw Error("trim: option 'axes' needs three semi-axes > 0 mm (along the heading, across it, vertical)");
  }
  if (!std::isfinite(o.heading_deg)) throw Error("trim: option 'heading' must be finite");
  if (o.shape != "ellipsoid" && o.shape != "cylinder" && o.shape != "cuboid" && o.shape != "cone") {
    throw Error("trim: option 'shape' is '" + o.shape + "'; give ellipsoid, cylinder, cuboid or cone");
  }
  if ((o.shape == "cylinder" || o.shape == "cone") && o.axes_mm.x() != o.axes_mm.y()) {
    throw Error("trim: a " + o.shape + "'s 'axes' are its (base) radius twice and its half-height (R, R, H/2)");
  }
}

}  // namespace

TrimPlan PlanTrim(const std::vector<Eigen::Vector3d>& points_mm, const Sphere& target, const TrimOptions& o,
                  const Eigen::Vector3d& pole) {
  CheckTrim(target, o, pole);
  const bool shaped = o.axes_mm != Eigen::Vector3d::Zero();
  TrimPlan plan;
  plan.pole = pole.normalized();
  plan.target = target;
  // An orthonormal frame with z along the pole: rings of equal cos(theta) about it.
  const Eigen::Vector3d z = pole.normalized();
  const Eigen::Vector3d x = z.unitOrthogonal(), y = z.cross(x);
  const Eigen::Matrix3d axes = ShapeAxes(z, o.heading_deg);
  const Eigen::Vector3d along = axes.col(0), across = axes.col(1);
  if (shaped) {
    plan.target_axes_mm = o.axes_mm;
    plan.target_heading_deg = o.heading_deg;
    plan.target_shape = o.shape;
    plan.target.radius_mm = VolumeRadius(o);
  }
  const TargetRadius radius_along{shaped, target.radius_mm, o.axes_mm, along, across, z, o.shape};
  std::vector<Direction> dirs;
  dirs.reserve(points_mm.size());
  std::vector<double> cut;
  plan.depth_mm.assign(points_mm.size(), std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = 0; i < points_mm.size(); ++i) {
    const Eigen::Vector3d d = points_mm[i] - target.center_mm;
    if (!d.allFinite()) continue;
    const double r = d.norm();
    ++plan.points;
    const double R = r > 0 ? radius_along(d / r) : radius_along(z);
    plan.depth_mm[i] = static_cast<float>(r - R);
    if (r - R > o.tolerance_mm) cut.push_back(r - R), ++plan.points_to_cut;
    if (r > 0) dirs.push_back({std::clamp(d.dot(z) / r, -1.0, 1.0), std::atan2(d.dot(y), d.dot(x)) + M_PI, r});
  }
  double bin = o.bin_deg * M_PI / 180;
  if (o.bin_deg == 0 && !dirs.empty()) {
    // Automatic: about 20 points per bin over the part seen (estimated on a 10-degree grid),
    // so the median radius of a bin is steady; between 0.5 and 15 degrees.
    const Grid coarse(10 * M_PI / 180);
    std::map<long, int> seen_coarse;
    for (const Direction& d : dirs) ++seen_coarse[coarse.Cell(d)];
    const double seen_sr = double(seen_coarse.size()) * coarse.cell_sr;
    bin = std::clamp(std::sqrt(seen_sr * 20.0 / double(dirs.size())), 0.5 * M_PI / 180, 15 * M_PI / 180);
  }
  const Grid grid(bin);
  plan.bin_deg = bin * 180 / M_PI;
  std::map<long, std::vector<double>> bins;  // radius samples per bin
  for (const Direction& d : dirs) bins[grid.Cell(d)].push_back(d.r);
  auto is_seen = [&](long cell) {
    const auto it = bins.find(cell);
    return it != bins.end() && int(it->second.size()) >= o.min_bin_points;
  };
  double seen = 0, cut_angle = 0, volume_mm3 = 0, r_max = 0, binning_mm3 = 0;
  // Every cell, seen or not, with its centre's direction.
  plan.bins.resize(std::size_t(grid.rings) * std::size_t(grid.sectors));
  for (int ring = 0; ring < grid.rings; ++ring) {
    for (int sector = 0; sector < grid.sectors; ++sector) {
      TrimBin& b = plan.bins[std::size_t(ring) * std::size_t(grid.sectors) + std::size_t(sector)];
      b.direction = CellDirection(grid, ring, sector, 0.5, 0.5, x, y, z);
      b.solid_angle_sr = grid.cell_sr;
    }
  }
  for (auto& [cell, radii] : bins) {
    TrimBin& b = plan.bins[std::size_t(cell)];
    b.points = int(radii.size());
    if (int(radii.size()) < o.min_bin_points) continue;
    // A bin on the edge of the seen part (a neighbour unseen) is on average half covered.
    const int ring = int(cell / grid.sectors), sector = int(cell % grid.sectors);
    const long left = long(ring) * grid.sectors + (sector + grid.sectors - 1) % grid.sectors;
    const long right = long(ring) * grid.sectors + (sector + 1) % grid.sectors;
    bool edge = !is_seen(left) || !is_seen(right);
    if (ring > 0) edge = edge || !is_seen(cell - grid.sectors);
    if (ring + 1 < grid.rings) edge = edge || !is_seen(cell + grid.sectors);
    const double sr = grid.cell_sr * (edge ? 0.5 : 1.0);
    b.weight = edge ? 0.5 : 1.0;
    seen += sr;
    const double r = Percentile(radii, 1 - o.clipped_share / 2);
    const double R = radius_along(b.direction);
    b.seen = true;
    b.radius_mm = r;
    r_max = std::max(r_max, r);
    // Only bins that need cutting: counting every r > R would add the noise of the bins on the
    // target (half of them read a little outside) as volume.
    if (r - R > o.tolerance_mm) {
      cut_angle += sr, volume_mm3 += sr * (r * r * r - R * R * R) / 3;
      // The bin reads the target's radius at its centre. Across a shape's edge, rim or apex
      // the target's cube averaged over the cell (3 x 3 directions) differs from it: that
      // difference's volume is what the bin's size leaves unread.
      double mean_cube = 0;
      for (int k = 0; k < 9; ++k) {
        mean_cube += std::pow(radius_along(CellDirection(grid, ring, sector, (2 * (k / 3) + 1) / 6.0, (2 * (k % 3) + 1) / 6.0, x, y, z)), 3) / 9;
      }
      binning_mm3 += sr * std::abs(mean_cube - R * R * R) / 3;
    }
  }
  plan.seen_share = seen / (4 * M_PI);
  plan.cut_share = seen > 0 ? cut_angle / seen : 0;
  plan.volume_seen_l = volume_mm3 * 1e-6;
  plan.volume_binning_l = binning_mm3 * 1e-6;
  if (binning_mm3 > 0.1 * volume_mm3 && binning_mm3 * 1e-6 > 0.01) {
    plan.warnings.push_back(pipeline::Format(
        "bins of %.1f deg read the %s target's radius coarsely across its edges, rim or apex: the volume seen (%.2f L) may be off "
        "by %.2f L; smaller bins (trim's --bin-deg, the stage's bin_deg) resolve it where the points are dense enough",
        plan.bin_deg, o.shape.c_str(), plan.volume_seen_l, plan.volume_binning_l));
  }
  plan.volume_all_round_l = plan.seen_share > 0 ? plan.volume_seen_l / plan.seen_share : 0;
  // Every unseen direction (and the uncounted half of the seen part's edge) as far out as the
  // farthest seen bin.
  double unseen_mm3 = 0;
  for (const TrimBin& b : plan.bins) {
    const double R = radius_along(b.direction);
    if (r_max - R > o.tolerance_mm) unseen_mm3 += (1 - b.weight) * b.solid_angle_sr * (r_max * r_max * r_max - R * R * R) / 3;
  }
  plan.volume_unseen_max_l = unseen_mm3 * 1e-6;
  plan.cut_p50_mm = Percentile(cut, 0.5);
  plan.cut_p90_mm = Percentile(cut, 0.9);
  plan.cut_p99_mm = Percentile(cut, 0.99);
  plan.cut_max_mm = cut.empty() ? 0 : *std::max_element(cut.begin(), cut.end());
  return plan;
}

std::string TrimPlansJson(const std::string& cloud, const std::vector<TrimPlan>& plans) {
  using json = nlohmann::ordered_json;
  auto r3 = [](double v) { return std::round(v * 1000) / 1000; };
  json out = {{"cloud", cloud}, {"hedges", json::array()}};
  for (const auto& t : plans) {
    const auto& c = t.target.center_mm;
    out["hedges"].push_back({{"hedge", t.hedge_id ? t.hedge_id : 1},
                             {"target_center_mm", {r3(c.x()), r3(c.y()), r3(c.z())}},
                             {"target_radius_mm", t.target.radius_mm},
                             {"points", t.points},
                             {"points_to_cut", t.points_to_cut},
                             {"cut_share", r3(t.cut_share)},
                             {"cut_p50_mm", r3(t.cut_p50_mm)},
                             {"cut_p90_mm", r3(t.cut_p90_mm)},
                             {"cut_p99_mm", r3(t.cut_p99_mm)},
                             {"cut_max_mm", r3(t.cut_max_mm)},
                             {"seen_share", r3(t.seen_share)},
                             {"volume_seen_l", r3(t.volume_seen_l)},
                             {"volume_all_round_l", r3(t.volume_all_round_l)},
                             {"volume_unseen_max_l", r3(t.volume_unseen_max_l)},
                             {"volume_binning_l", r3(t.volume_binning_l)},
                             {"warnings", t.warnings},
                             {"unseen", UnseenDirections(t)}});
    if (t.target_axes_mm != Eigen::Vector3d::Zero()) {
      out["hedges"].back()["target_axes_mm"] = {r3(t.target_axes_mm.x()), r3(t.target_axes_mm.y()), r3(t.target_axes_mm.z())};
      out["hedges"].back()["target_heading_deg"] = r3(t.target_heading_deg);
      out["hedges"].back()["target_shape"] = t.target_shape;
    }
  }
  return out.dump(2);
}

void PrintTrimTable(std::ostream& out, const std::vector<TrimPlan>& plans) {
  char line[256];
  std::snprintf(line, sizeof(line), "%-5s %-28s %7s %8s %6s %6s %6s %7s %6s %9s %10s %11s\n", "hedge",
                "target centre (x, y, z) mm", "R mm", "cut %", "p50", "p90", "p99", "max mm", "seen %", "volume L",
                "all round", "unseen <= L");
  out << line;
  for (const auto& t : plans) {
    char centre[64];
    std::snprintf(centre, sizeof(centre), "(%.0f, %.0f, %.0f)", t.target.center_mm.x(), t.target.center_mm.y(),
                  t.target.center_mm.z());
    std::snprintf(line, sizeof(line), "%-5d %-28s %7.1f %7.1f%% %6.1f %6.1f %6.1f %7.1f %5.1f%% %9.2f %10.2f %11.2f\n",
                  t.hedge_id ? t.hedge_id : 1, centre, t.target.radius_mm, 100 * t.cut_share, t.cut_p50_mm,
                  t.cut_p90_mm, t.cut_p99_mm, t.cut_max_mm, 100 * t.seen_share, t.volume_seen_l,
                  t.volume_all_round_l, t.volume_unseen_max_l);
    out << line;
  }
}

}  // namespace hedgefit::fitting
