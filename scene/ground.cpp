// The ground model: cell minima, a progressive morphological opening, then a robust local
// quadratic surface through the cells that are ground (see ground.hpp).

#include "scene/ground.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

#include "pipeline/error.hpp"

namespace hedgefit::scene {

namespace {

constexpr float kEmpty = std::numeric_limits<float>::quiet_NaN();

// Grey-scale erosion (take_min) or dilation over a (2h+1)^2 window, ignoring empty cells; separable.
std::vector<float> MinMaxFilter(const std::vector<float>& in, int nx, int ny, int h, bool take_min) {
  auto pick = [take_min](float a, float b) {
    if (std::isnan(a)) return b;
    if (std::isnan(b)) return a;
    return take_min ? std::min(a, b) : std::max(a, b);
  };
  std::vector<float> rows(in.size(), kEmpty), out(in.size(), kEmpty);
  for (int y = 0; y < ny; ++y) {
    for (int x = 0; x < nx; ++x) {
      float v = kEmpty;
      for (int k = std::max(0, x - h); k <= std::min(nx - 1, x + h); ++k) v = pick(v, in[std::size_t(y) * nx + k]);
      rows[std::size_t(y) * nx + x] = v;
    }
  }
  for (int y = 0; y < ny; ++y) {
    for (int x = 0; x < nx; ++x) {
      float v = kEmpty;
      for (int k = std::max(0, y - h); k <= std::min(ny - 1, y + h); ++k) v = pick(v, rows[std::size_t(k) * nx + x]);
      out[std::size_t(y) * nx + x] = v;
    }
  }
  return out;
}

// The height at the cells near ground cells (`height` where `use`), from a weighted local quadratic
// over a window of 2 radius + 1 cells (a plane, or a mean, where fewer cells are in it); NaN where
// no ground cell is in the window.
std::vector<float> LocalSurface(const std::vector<float>& height, const std::vector<std::uint8_t>& use, int nx, int ny,
                                int radius) {
  std::vector<float> out(height.size(), kEmpty);
  const double s2 = 0.5 * radius * radius;
  // Only at ground cells and their neighbours: the rest is filled from them (HarmonicFill).
  std::vector<std::uint8_t> want(height.size(), 0);
  for (int y = 0; y < ny; ++y) {
    for (int x = 0; x < nx; ++x) {
      if (!use[std::size_t(y) * nx + x]) continue;
      for (int v = std::max(0, y - 1); v <= std::min(ny - 1, y + 1); ++v) {
        for (int u = std::max(0, x - 1); u <= std::min(nx - 1, x + 1); ++u) want[std::size_t(v) * nx + u] = 1;
      }
    }
  }
  // The weighted sums the quadratic's normal equations need, sum of w(du) w(dv) du^a dv^b over
  // the ground cells (and times their height), are separable: rows first (per power of du), then
  // each wanted cell's column.
  const int n1 = 2 * radius + 1;
  std::vector<double> kernel[5];
  for (int a = 0; a < 5; ++a) {
    for (int d = -radius; d <= radius; ++d) kernel[a].push_back(std::exp(-d * d / s2) * std::pow(double(d), a));
  }
  const std::size_t cells = height.size();
  std::vector<double> rows_use[5], rows_h[3];
  for (int a = 0; a < 5; ++a) rows_use[a].assign(cells, 0.0);
  for (int a = 0; a < 3; ++a) rows_h[a].assign(cells, 0.0);
  // Scattered from each ground cell along its row; and a summed-area table of the ground cells,
  // to count them per window.
  std::vector<int> sat(std::size_t(nx + 1) * (ny + 1), 0);
  for (int y = 0; y < ny; ++y) {
    for (int u = 0; u < nx; ++u) {
      const std::size_t src = std::size_t(y) * nx + u;
      sat[std::size_t(y + 1) * (nx + 1) + u + 1] = sat[std::size_t(y) * (nx + 1) + u + 1] +
                                                   sat[std::size_t(y + 1) * (nx + 1) + u] -
                                                   sat[std::size_t(y) * (nx + 1) + u] + (use[src] ? 1 : 0);
      if (!use[src]) continue;
      const double hv = height[src];
      for (int k = 0; k < n1; ++k) {
        const int x = u - (k - radius);  // the cell whose window holds u at offset k - radius
        if (x < 0 || x >= nx) continue;
        const std::size_t c = std::size_t(y) * nx + x;
        for (int a = 0; a < 5; ++a) rows_use[a][c] += kernel[a][k];
        for (int a = 0; a < 3; ++a) rows_h[a][c] += kernel[a][k] * hv;
      }
    }
  }
  static constexpr int kPow[6][2] = {{0, 0}, {1, 0}, {0, 1}, {2, 0}, {1, 1}, {0, 2}};
  for (int y = 0; y < ny; ++y) {
    for (int x = 0; x < nx; ++x) {
      if (!want[std::size_t(y) * nx + x]) continue;
      double m[5][5] = {};  // m[a][b]: sum of w du^a dv^b over ground cells
      double mh[3][3] = {};
      int n = 0;
      for (int k = 0; k < n1; ++k) {
        const int v = y + k - radius;
        if (v < 0 || v >= ny) continue;
        const std::size_t c = std::size_t(v) * nx + x;
        for (int a = 0; a < 5; ++a) {
          for (int b = 0; a + b < 5; ++b) m[a][b] += kernel[b][k] * rows_use[a][c];
        }
        for (int a = 0; a < 3; ++a) {
          for (int b = 0; a + b < 3; ++b) mh[a][b] += kernel[b][k] * rows_h[a][c];
        }
      }
      {
        const int x0 = std::max(0, x - radius), x1 = std::min(nx - 1, x + radius) + 1;
        const int y0 = std::max(0, y - radius), y1 = std::min(ny - 1, y + radius) + 1;
        auto at = [&](int yy, int xx) { return sat[std::size_t(yy) * (nx + 1) + xx]; };
        n = at(y1, x1) - at(y0, x1) - at(y1, x0) + at(y0, x0);
      }
      if (n == 0 || !(m[0][0] > 0)) continue;
      Eigen::Matrix<double, 6, 6> a;
      Eigen::Matrix<double, 6, 1> b;
      for (int i = 0; i < 6; ++i) {
        b[i] = mh[kPow[i][0]][kPow[i][1]];
        for (int j = 0; j < 6; ++j) a(i, j) = m[kPow[i][0] + kPow[j][0]][kPow[i][1] + kPow[j][1]];
      }
      const double mean = b[0] / a(0, 0);
      double value = mean;
      if (n >= 12) {
        const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(a);
        const Eigen::Matrix<double, 6, 1> coef = ldlt.solve(b);
        if (ldlt.info() == Eigen::Success && coef.allFinite()) value = coef[0];
      } else if (n >= 4) {
        const Eigen::LDLT<Eigen::Matrix3d> ldlt(a.topLeftCorner<3, 3>());
        const Eigen::Vector3d coef = ldlt.solve(b.head<3>());
        if (ldlt.info() == Eigen::Success && coef.allFinite()) value = coef[0];
      }
      // A fit that leaves the range of the cells it saw (all on one side) falls back to their mean.
      if (std::abs(value - mean) > 1000) value = mean;
      out[std::size_t(y) * nx + x] = static_cast<float>(value);
    }
  }
  return out;
}

// Fills the NaN cells of `h` with the harmonic interpolation of the rest (Laplace's equation,
// Gauss-Seidel from a breadth-first first guess): exact on a sloped plane, smooth on bumps, so
// the ground under and behind a hedge follows the ground around it.
void HarmonicFill(std::vector<float>& h, int nx, int ny, const std::vector<float>& data) {
  std::vector<std::size_t> unknown;
  for (std::size_t c = 0; c < h.size(); ++c) if (std::isnan(h[c])) unknown.push_back(c);
  if (unknown.size() == h.size()) return;
  std::vector<float> cur = h;
  std::vector<std::size_t> pending = unknown;
  while (!pending.empty()) {
    std::vector<std::size_t> next;
    std::vector<std::pair<std::size_t, float>> set;
    for (std::size_t c : pending) {
      const int x = int(c % nx), y = int(c / nx);
      double sum = 0;
      int n = 0;
      for (int v = std::max(0, y - 1); v <= std::min(ny - 1, y + 1); ++v) {
        for (int u = std::max(0, x - 1); u <= std::min(nx - 1, x + 1); ++u) {
          const float f = cur[std::size_t(v) * nx + u];
          if (!std::isnan(f)) sum += f, ++n;
        }
      }
      if (n) set.emplace_back(c, float(sum / n)); else next.push_back(c);
    }
    if (set.empty()) break;
    for (const auto& [c, f] : set) cur[c] = f;
    pending.swap(next);
  }
  // Gauss-Seidel only where it matters: holes narrower than ~20 cells settle in 150 sweeps, and
  // far from any ground the first guess is as good as any.
  // Only cells that hold points, or touch one (bilinear reads them), are relaxed.
  std::vector<std::size_t> relax;
  for (std::size_t c : unknown) {
    const int x = int(c % nx), y = int(c / nx);
    bool near = false;
    for (int v = std::max(0, y - 1); v <= std::min(ny - 1, y + 1) && !near; ++v) {
      for (int u = std::max(0, x - 1); u <= std::min(nx - 1, x + 1) && !near; ++u) near = !std::isnan(data[std::size_t(v) * nx + u]);
    }
    if (near) relax.push_back(c);
  }
  for (int it = 0; it < 150; ++it) {
    for (std::size_t c : relax) {
      const int x = int(c % nx), y = int(c / nx);
      double sum = 0;
      int n = 0;
      if (x > 0) sum += cur[c - 1], ++n;
      if (x + 1 < nx) sum += cur[c + 1], ++n;
      if (y > 0) sum += cur[c - nx], ++n;
      if (y + 1 < ny) sum += cur[c + nx], ++n;
      cur[c] = float(sum / n);
    }
  }
  h.swap(cur);
}

// The progressive opening (Zhang et al. 2003) on the cells' lows: windows doubling up to
// max_window; a cell is not ground when it stands above the opened surface by more than the slope
// allows over the window's growth. 1 for the ground cells.
std::vector<std::uint8_t> ProgressiveOpening(const std::vector<float>& low, int nx, int ny, const GroundOptions& options,
                                             double cell) {
  const std::size_t cells = low.size();
  std::vector<std::uint8_t> ground(cells, 0);
  for (std::size_t c = 0; c < cells; ++c) ground[c] = !std::isnan(low[c]);
  std::vector<float> surface = low;
  int previous_w = 1;
  for (int h = 1;; h *= 2) {
    const int w = 2 * h + 1;
    const std::vector<float> opened = MinMaxFilter(MinMaxFilter(surface, nx, ny, h, true), nx, ny, h, false);
    const double dh = options.step_mm + options.slope * (w - previous_w) * cell;
    for (std::size_t c = 0; c < cells; ++c) {
      if (ground[c] && low[c] - opened[c] > dh) ground[c] = 0;
    }
    surface = opened;
    previous_w = w;
    if ((2 * h + 1) * cell >= options.max_window_mm || h > std::max(nx, ny)) break;
  }
  return ground;
}

// Ground spreads beyond what stands on it: a patch of ground cells under 1.5 m^2 (cells joined
// across a one-cell gap, as a sparse scanner's rings are) is the underside of an object with no
// lawn about it (a segmented capture's hedges), not ground.
void DropSmallPatches(std::vector<std::uint8_t>* ground, int nx, int ny, double cell) {
  const std::size_t min_cells = std::size_t(std::ceil(1.5e6 / (cell * cell)));
  std::vector<int> label(ground->size(), -1);
  std::vector<std::size_t> stack, patch;
  for (std::size_t start = 0; start < ground->size(); ++start) {
    if (!(*ground)[start] || label[start] >= 0) continue;
    patch.clear();
    stack.assign(1, start);
    label[start] = int(start);
    while (!stack.empty()) {
      const std::size_t c = stack.back();
      stack.pop_back();
      patch.push_back(c);
      const int x = int(c % nx), y = int(c / nx);
      for (int v = std::max(0, y - 2); v <= std::min(ny - 1, y + 2); ++v) {
        for (int u = std::max(0, x - 2); u <= std::min(nx - 1, x + 2); ++u) {
          const std::size_t n = std::size_t(v) * nx + u;
          if ((*ground)[n] && label[n] < 0) label[n] = int(start), stack.push_back(n);
        }
      }
    }
    if (patch.size() < min_cells) {
      for (std::size_t c : patch) (*ground)[c] = 0;
    }
  }
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

const pipeline::OptionTable<GroundOptions>& GroundOptions::Table() {
  using O = GroundOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("ground_cell", &O::cell_mm, "ground grid cell: the terrain's finest detail", "mm").Range(10, 1e6)
          .Add("ground_window", &O::max_window_mm, "widest object the ground filter clears (wider than any hedge)", "mm")
          .Range(100, 1e7)
          .Add("ground_slope", &O::slope, "steepest ground, rise over run", "").Range(0, 10)
          .Add("ground_step", &O::step_mm, "a cell this far above the opened surface is never ground", "mm")
          .Range(1, 1e6);
  return table;
}

void GroundOptions::Check() const {
  Table().Validate(*this);
  if (max_window_mm < cell_mm) throw Error("option 'ground_window' must be at least 'ground_cell'");
}

double GroundModel::HeightAt(double x, double y) const {
  if (empty()) return std::numeric_limits<double>::quiet_NaN();
  const double fx = std::clamp((x - origin_mm.x()) / cell_mm - 0.5, 0.0, double(nx - 1));
  const double fy = std::clamp((y - origin_mm.y()) / cell_mm - 0.5, 0.0, double(ny - 1));
  const int x0 = std::min(int(fx), nx - 1), y0 = std::min(int(fy), ny - 1);
  const int x1 = std::min(x0 + 1, nx - 1), y1 = std::min(y0 + 1, ny - 1);
  const double tx = fx - x0, ty = fy - y0;
  auto h = [this](int cx, int cy) { return double(height_mm[std::size_t(cy) * nx + cx]); };
  return (1 - ty) * ((1 - tx) * h(x0, y0) + tx * h(x1, y0)) + ty * ((1 - tx) * h(x0, y1) + tx * h(x1, y1));
}

bool GroundModel::ObservedNear(double x, double y, double radius_mm) const {
  if (empty()) return false;
  const int r = int(std::ceil(radius_mm / cell_mm));
  const int cx = int(std::floor((x - origin_mm.x()) / cell_mm)), cy = int(std::floor((y - origin_mm.y()) / cell_mm));
  for (int v = std::max(0, cy - r); v <= std::min(ny - 1, cy + r); ++v) {
    for (int u = std::max(0, cx - r); u <= std::min(nx - 1, cx + r); ++u) {
      if (observed[std::size_t(v) * nx + u]) return true;
    }
  }
  return false;
}

double GroundBand(const GroundModel& ground) { return std::max(40.0, 3.0 * ground.noise_mm); }

GroundModel FitGround(const std::vector<Eigen::Vector3f>& points, const GroundOptions& options,
                      std::vector<std::uint8_t>* is_ground) {
  options.Check();
  GroundModel g;
  if (is_ground) is_ground->assign(points.size(), 0);
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
  std::size_t finite = 0;
  for (const auto& p : points) {
    if (!p.allFinite()) continue;
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p), ++finite;
  }
  if (finite == 0) return g;
  // At most ~4 million cells: a larger scene gets coarser cells.
  double cell = options.cell_mm;
  while (((hi.x() - lo.x()) / cell + 1) * ((hi.y() - lo.y()) / cell + 1) > 4e6) cell *= 1.5;
  g.cell_mm = cell;
  g.origin_mm = Eigen::Vector2d(lo.x(), lo.y());
  g.nx = int((hi.x() - lo.x()) / cell) + 1, g.ny = int((hi.y() - lo.y()) / cell) + 1;
  const std::size_t cells = std::size_t(g.nx) * g.ny;
  auto cell_of = [&](const Eigen::Vector3f& p) {
    const int cx = std::min(g.nx - 1, int((p.x() - lo.x()) / cell)), cy = std::min(g.ny - 1, int((p.y() - lo.y()) / cell));
    return std::size_t(cy) * g.nx + cx;
  };
  // Heights bucketed by cell (a counting sort), then each cell's 2 % low: the ground's lowest
  // return, not one stray point below it.
  std::vector<std::uint32_t> start(cells + 1, 0);
  for (const auto& p : points) if (p.allFinite()) ++start[cell_of(p) + 1];
  for (std::size_t c = 0; c < cells; ++c) start[c + 1] += start[c];
  std::vector<float> z(finite);
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (const auto& p : points) if (p.allFinite()) z[fill[cell_of(p)]++] = p.z();
  }
  std::vector<float> low(cells, kEmpty);
  for (std::size_t c = 0; c < cells; ++c) {
    const std::size_t n = start[c + 1] - start[c];
    if (n == 0) continue;
    auto b = z.begin() + start[c], e = z.begin() + start[c + 1];
    std::nth_element(b, b + std::size_t(0.02 * n), e);
    low[c] = *(b + std::size_t(0.02 * n));
  }
  std::vector<std::uint8_t> ground = ProgressiveOpening(low, g.nx, g.ny, options, cell);
  if (options.drop_small_patches) DropSmallPatches(&ground, g.nx, g.ny, cell);
  // Each ground cell's height: the median of its points near its low (the lawn's returns, with
  // their noise, not its lowest one).
  std::vector<float> height(cells, kEmpty);
  for (std::size_t c = 0; c < cells; ++c) {
    if (!ground[c]) continue;
    std::vector<double> near;
    for (std::size_t i = start[c]; i < start[c + 1]; ++i) if (z[i] <= low[c] + 100.f) near.push_back(z[i]);
    height[c] = static_cast<float>(Median(std::move(near)));
  }
  // A robust surface through them: cells that stand out of their neighbourhood's quadratic (the
  // foot of a hedge, a low bench) are dropped and the surface refitted.
  constexpr int kRadius = 3;
  std::vector<float> smooth = LocalSurface(height, ground, g.nx, g.ny, kRadius);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<double> res;
    for (std::size_t c = 0; c < cells; ++c) if (ground[c]) res.push_back(std::abs(height[c] - smooth[c]));
    const double limit = std::max(60.0, 4.0 * 1.4826 * Median(res));
    bool changed = false;
    for (std::size_t c = 0; c < cells; ++c) {
      if (ground[c] && std::abs(height[c] - smooth[c]) > limit) ground[c] = 0, changed = true;
    }
    if (!changed) break;
    smooth = LocalSurface(height, ground, g.nx, g.ny, kRadius);
  }
  bool any = false;
  for (std::size_t c = 0; c < cells; ++c) any = any || ground[c];
  g.observed = ground;
  if (!any) {
    g.nx = g.ny = 0;
    g.height_mm.clear(), g.observed.clear();
    return g;
  }
  // Cells far from any ground (under a wide hedge, behind it, beyond the scan) from around them.
  for (std::size_t c = 0; c < cells; ++c) {
    bool near = false;
    const int x = int(c % g.nx), y = int(c / g.nx);
    for (int v = std::max(0, y - 1); v <= std::min(g.ny - 1, y + 1) && !near; ++v) {
      for (int u = std::max(0, x - 1); u <= std::min(g.nx - 1, x + 1) && !near; ++u) near = ground[std::size_t(v) * g.nx + u];
    }
    if (!near) smooth[c] = kEmpty;
  }
  HarmonicFill(smooth, g.nx, g.ny, low);
  g.height_mm = smooth;
  // The ground's noise: the scatter of the ground cells' points about the surface.
  std::vector<double> dev;
  for (const auto& p : points) {
    if (!p.allFinite() || !ground[cell_of(p)]) continue;
    const double d = p.z() - g.HeightAt(p.x(), p.y());
    if (std::abs(d) < 150) dev.push_back(std::abs(d));
  }
  g.noise_mm = 1.4826 * Median(dev);
  const double band = GroundBand(g);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    if (!p.allFinite()) continue;
    const bool on = std::abs(p.z() - g.HeightAt(p.x(), p.y())) <= band;
    g.ground_points += on;
    if (is_ground) (*is_ground)[i] = on;
  }
  return g;
}

}  // namespace hedgefit::scene
