#include "stereo/depth_segmentation.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <queue>
#include <utility>

#include "pipeline/error.hpp"
#include "cloud/filters.hpp"
#include "stereo/matching.hpp"
#include "stereo/rectification.hpp"
#include "stereo/segmentation.hpp"
#include "stereo/image_io.hpp"

namespace hedgefit::stereo {

const pipeline::OptionTable<GardenSegmentOptions>& GardenSegmentOptions::Table() {
  using O = GardenSegmentOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("downscale", &O::downscale,
               "the coarse whole-frame match runs at 1/downscale resolution; 0 = its focal length ~230 px")
          .Range(0, 16)
          .Add("min_z", &O::min_z_mm, "working range, nearest", "mm").Min(1)
          .Add("max_z", &O::max_z_mm, "working range, farthest", "mm").Min(1)
          .Add("coarse_block_size", &O::block_size, "the coarse match's block, odd", "coarse px").Range(1, 31)
          .Add("ground_clearance", &O::ground_clearance_mm, "points lower than this above the ground are lawn", "mm")
          .Min(0)
          .Add("depth_jump", &O::depth_jump_mm, "neighbours further apart in depth are different objects", "mm").Min(1)
          .Add("min_radius", &O::min_radius_mm, "smallest hedge", "mm").Min(1)
          .Add("max_radius", &O::max_radius_mm, "largest hedge", "mm").Min(1)
          .Add("max_aspect", &O::max_aspect, "a hedge's width / height and height / width at most").Min(1)
          .Add("min_excess_green", &O::min_excess_green, "colour images: a hedge's mean 2G-R-B; 0 = colour not used")
          .Min(0)
          .Add("max_hedges", &O::max_hedges, "keep at most this many hedges (the largest)").Range(1, 1000)
          .Add("erode", &O::erode_px, "drop this many silhouette pixels beyond the coarse match's margin", "px")
          .Range(0, 200);
  return table;
}

void GardenSegmentOptions::Check() const {
  Table().Validate(*this);
  CheckDepthRange(min_z_mm, max_z_mm);
  if (!(max_radius_mm > min_radius_mm)) throw Error("option 'min_radius'/'max_radius': need min_radius < max_radius (mm)");
  if (block_size % 2 == 0) throw Error("option 'coarse_block_size': must be odd");
}

const pipeline::OptionTable<AutoSegmentOptions>& AutoSegmentOptions::Table() {
  using O = AutoSegmentOptions;
  static const auto table =
      pipeline::OptionTable<O>()
          .Nest(SegmentOptions::Table(), &O::colour)
          .Nest(GardenSegmentOptions::Table(), &O::garden, {"erode"})
          .Add("garden_above", &O::garden_above,
               "when the colour mask covers more than this share of the frame, find every hedge by depth instead; "
               "0 = never")
          .Range(0, 1);
  return table;
}

void AutoSegmentOptions::Check() const {
  Table().Validate(*this);
  colour.Check();
  garden.Check();
}

namespace detail {

// A stable radix sort (four passes of 8 bits) of each value's float bits made to order as the
// value does. The values are floats' (a distance transform's, a depth map's); 0 and -0 tie.
std::vector<int> HighestFirst(const std::vector<double>& values, const std::vector<std::uint8_t>& inside) {
  std::vector<std::uint32_t> key, next_key;
  std::vector<int> order, next_order;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!inside[i] || !std::isfinite(values[i])) continue;
    float v = float(values[i]);
    if (v == 0) v = 0;  // -0 as +0
    std::uint32_t b = 0;
    std::memcpy(&b, &v, sizeof b);
    b = (b & 0x80000000u) ? ~b : (b | 0x80000000u);  // ascending with the value
    key.push_back(~b);                                // descending
    order.push_back(int(i));
  }
  next_key.resize(key.size());
  next_order.resize(order.size());
  for (int shift = 0; shift < 32; shift += 8) {
    std::size_t count[257] = {};
    for (const std::uint32_t k : key) ++count[((k >> shift) & 0xffu) + 1];
    for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
    for (std::size_t i = 0; i < key.size(); ++i) {
      const std::size_t at = count[(key[i] >> shift) & 0xffu]++;
      next_key[at] = key[i];
      next_order[at] = order[i];
    }
    key.swap(next_key);
    order.swap(next_order);
  }
  return order;
}

}  // namespace detail

namespace {

constexpr double kCoarseFocalPx = 233;  // the paper's rig (f = 933 px) at 1/4
constexpr int kMinHedgePixels = 400;    // full resolution, after erosion

struct Blob {
  std::vector<int> pixels;  // coarse pixel indices
  double min_h = 1e18, max_h = -1e18, min_x = 1e18, max_x = -1e18, min_z = 1e18, max_z = -1e18;
  cv::Vec3d sum{0, 0, 0};
  int min_u = 1 << 30, max_u = -1, min_v = 1 << 30, max_v = -1;  // coarse columns and rows
};

std::string Where(const Blob& b, int downscale) {
  const cv::Vec3d c = b.sum * (1.0 / double(b.pixels.size()));
  char buf[96];
  std::snprintf(buf, sizeof(buf), "blob at columns %d-%d, %.1f m away", b.min_u * downscale, (b.max_u + 1) * downscale,
                c[2] / 1000);
  return buf;
}

// The prominent peaks of `value` (CV_32F; NaN = no value) over `inside` (CV_8U), and every pixel
// of `inside` given to one of them. Pixels are taken from the highest value down, joining the
// pieces they touch (a union-find merge tree); when two pieces meet, the one with the lower peak
// ends. A peak counts when its piece ended at least `rise(peak)` below it (or never ended) and
// `keep(peak, area)` holds, area being its piece's size down to `rise(peak)` below the peak: its
// core. Every pixel of `inside` then goes to a core by flooding from the cores, highest values
// first (a watershed), so the split runs along the valleys between them. Labels 1..n in `labels`
// (CV_32S, 0 off `inside`); returns n.
int PeakRegions(const cv::Mat& value, const cv::Mat& inside, const std::function<double(double peak)>& rise,
                const std::function<bool(double peak, int area)>& keep, cv::Mat* labels) {
  const int cols = value.cols, n_px = int(value.total());
  // Each pixel's value and whether it is inside, read once: the sort below compares them
  // n log n times.
  std::vector<double> values(static_cast<std::size_t>(n_px));
  std::vector<std::uint8_t> inside_px(static_cast<std::size_t>(n_px));
  for (int y = 0, i = 0; y < value.rows; ++y) {
    const float* vrow = value.ptr<float>(y);
    const std::uint8_t* irow = inside.ptr<std::uint8_t>(y);
    for (int x = 0; x < cols; ++x, ++i) {
      values[std::size_t(i)] = std::isfinite(vrow[x]) ? double(vrow[x]) : -std::numeric_limits<double>::infinity();
      inside_px[std::size_t(i)] = irow[x] != 0;
    }
  }
  auto at = [&](int i) { return values[std::size_t(i)]; };
  auto in = [&](int i) { return inside_px[std::size_t(i)] != 0; };
  auto neighbours = [&](int i, int* out) {
    const int x = i % cols, y = i / cols;
    int m = 0;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if ((dx != 0 || dy != 0) && x + dx >= 0 && y + dy >= 0 && x + dx < cols && y + dy < value.rows) {
          out[m++] = (y + dy) * cols + x + dx;
        }
      }
    }
    return m;
  };
  // Highest first, ties in pixel order.
  const std::vector<int> order = detail::HighestFirst(values, inside_px);
  struct Piece {
    double peak = 0;
    int peak_px = 0, area = 0, core_area = 0;
  };
  std::vector<int> parent(static_cast<std::size_t>(n_px), -1);
  std::vector<Piece> piece(static_cast<std::size_t>(n_px));
  auto find = [&](int i) {
    while (parent[std::size_t(i)] != i) i = parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
    return i;
  };
  std::vector<int> peaks;
  int nb[8];
  for (const int p : order) {
    const double v = at(p);
    parent[std::size_t(p)] = p;
    piece[std::size_t(p)] = {v, p, 1, 1};
    for (int k = 0, m = neighbours(p, nb); k < m; ++k) {
      if (parent[std::size_t(nb[k])] < 0) continue;
      int hi = find(p), lo = find(nb[k]);
      if (hi == lo) continue;
      if (piece[std::size_t(hi)].peak < piece[std::size_t(lo)].peak) std::swap(hi, lo);
      Piece& a = piece[std::size_t(hi)];
      const Piece& b = piece[std::size_t(lo)];
      if (b.peak - v >= rise(b.peak) && keep(b.peak, b.core_area)) peaks.push_back(b.peak_px);
      if (v >= a.peak - rise(a.peak)) a.core_area += b.area;  // still within the higher one's core
      a.area += b.area;
      parent[std::size_t(lo)] = hi;
    }
  }
  for (const int p : order) {
    const Piece& r = piece[std::size_t(p)];
    if (find(p) == p && keep(r.peak, r.core_area)) peaks.push_back(r.peak_px);
  }
  if (peaks.size() < 2) return 1;
  // The cores, then the flood from them.
  cv::Mat lab = cv::Mat::zeros(value.size(), CV_32S);
  using Item = std::pair<double, int>;
  std::priority_queue<Item> queue;
  for (std::size_t c = 0; c < peaks.size(); ++c) {
    const double floor = at(peaks[c]) - rise(at(peaks[c]));
    std::vector<int> stack{peaks[c]};
    lab.at<int>(peaks[c] / cols, peaks[c] % cols) = int(c) + 1;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      queue.emplace(at(i), i);
      for (int k = 0, m = neighbours(i, nb); k < m; ++k) {
        int& l = lab.at<int>(nb[k] / cols, nb[k] % cols);
        if (l == 0 && in(nb[k]) && at(nb[k]) >= floor) l = int(c) + 1, stack.push_back(nb[k]);
      }
    }
  }
  while (!queue.empty()) {
    const int i = queue.top().second;
    queue.pop();
    for (int k = 0, m = neighbours(i, nb); k < m; ++k) {
      int& l = lab.at<int>(nb[k] / cols, nb[k] % cols);
      if (l == 0 && in(nb[k])) l = lab.at<int>(i / cols, i % cols), queue.emplace(at(nb[k]), nb[k]);
    }
  }
  *labels = lab;
  return int(peaks.size());
}

// The balls one blob (`mask`, CV_8U, holes filled) holds, each pixel of it labelled 1..n in
// `labels`; returns n (1 = one ball, `labels` untouched). Two cues that fail apart; the one that
// sees more balls is taken.
//  - Outline. A ball's outline is convex, and the distance transform `dt` of a convex shape is
//    concave: it has one peak, whatever the shape's size or aspect (a dome, a clipped hedge
//    row). Balls side by side make a waist where it dips between their peaks. A peak counts when
//    it is a sizeable ball's inscribed radius (over kMinPeak of the largest) and the waist to a
//    higher one is at most kWaist of it. Touching balls, whose shadowed lawn the coarse match
//    fills with their own depth, keep a waist of 0.7-0.8.
//  - Depth. Each ball's front is a pit in the depth map `z` (mm; NaN = none): between two balls
//    the surface recedes to their limbs. A lumpy shrub against a ball leaves the outline no waist,
//    but its front is a pit of its own. A pit counts when it is at least kPitShare of the blob's
//    radius (`radius_mm`, half its height or width) deep below where it meets a nearer one and
//    covers kPitArea of the blob's largest inscribed disc down to that depth: coarse depth noise
//    makes deep pits too, but small ones.
// On both renderers' gardens (the standard, the hard and the paper's near outdoor balls) no single
// ball splits at any waist from 0.70 to 0.95 or any pit from 0.06 to 0.25 of its radius; touching
// rows split at every waist from 0.80 up, a shrub from the ball it touches at every pit tried.
int BallCores(const cv::Mat& mask, const cv::Mat& dt, const cv::Mat& z, double radius_mm, cv::Mat* labels) {
  constexpr double kWaist = 0.85, kMinPeak = 0.4, kPitShare = 0.12, kPitArea = 0.1;
  double dt_max = 0;
  cv::minMaxLoc(dt, nullptr, &dt_max);
  int best = PeakRegions(
      dt, mask, [&](double peak) { return (1 - kWaist) * peak; },
      [&](double peak, int) { return peak >= kMinPeak * dt_max; }, labels);
  const double pit = kPitShare * radius_mm;
  if (!(pit > 0)) return best;
  const double min_area = kPitArea * 3.14159265358979 * dt_max * dt_max;
  cv::Mat depth_labels;
  const int by_depth = PeakRegions(
      -z, mask, [&](double) { return pit; }, [&](double, int area) { return area >= min_area; }, &depth_labels);
  if (by_depth > best) {
    best = by_depth;
    *labels = depth_labels;
  }
  return best;
}

}  // namespace

namespace {

// The whole frame matched at 1/k, each coarse pixel in 3-D (rectified left frame), and the ground
// once found: what every later step of FindHedges reads.
struct CoarseScene {
  int k = 1;                 // the downscale
  double f = 0, cx = 0, cy = 0, fb = 0;
  int w = 0, h = 0;          // coarse size
  cv::Mat small_left;        // the left view at 1/k, for the colour test
  std::vector<cv::Vec3d> xyz;  // per coarse pixel; NaN z outside the working range
  std::vector<Eigen::Vector3f> valid;
  std::optional<cloud::Plane> ground;
  cv::Vec3d across{1, 0, 0};  // horizontal across the view: the image's x made parallel to the ground

  double Height(const cv::Vec3d& p) const {
    return ground ? double(ground->Distance(Eigen::Vector3f(float(p[0]), float(p[1]), float(p[2])))) : -p[1];
  }
  // Neighbours on one surface differ in depth by the pixel's footprint times the surface's slope;
  // across a depth edge by more. Three footprints (a surface up to ~70 degrees from facing the
  // camera) within depth_jump at most.
  double JumpAt(double z, double depth_jump_mm) const { return std::min(depth_jump_mm, std::max(10.0, 3.0 * k * z / f)); }
  void AddPixel(Blob* b, int i) const {
    b->pixels.push_back(i);
    const cv::Vec3d& p = xyz[std::size_t(i)];
    const double hh = Height(p), x = p.dot(across);
    b->min_h = std::min(b->min_h, hh), b->max_h = std::max(b->max_h, hh);
    b->min_x = std::min(b->min_x, x), b->max_x = std::max(b->max_x, x);
    b->min_z = std::min(b->min_z, p[2]), b->max_z = std::max(b->max_z, p[2]);
    b->min_u = std::min(b->min_u, i % w), b->max_u = std::max(b->max_u, i % w);
    b->min_v = std::min(b->min_v, i / w), b->max_v = std::max(b->max_v, i / w);
    b->sum += p;
  }
  // A blob's height: from the ground when there is one (the lowest part of a ball is hidden by the
  // lawn's clearance or by the ball itself), else its own vertical extent.
  double Tall(const Blob& b) const { return ground ? b.max_h : b.max_h - b.min_h; }
};

// 1. The coarse match of the whole frame: the working range's disparities at 1/k, 5 x 5 median.
CoarseScene MatchCoarse(const StereoRig& rig, const cv::Mat& left_rect, const cv::Mat& right_rect,
                        const GardenSegmentOptions& o, GardenSegmentation* out) {
  CoarseScene s;
  s.k = o.downscale > 0 ? o.downscale : std::max(1, int(std::lround(rig.P1.at<double>(0, 0) / kCoarseFocalPx)));
  CheckNearestDepth(rig.P1.at<double>(0, 0), rig.baseline_mm, o.min_z_mm, left_rect.cols);
  const int k = s.k;
  cv::Mat small_r;
  cv::resize(left_rect, s.small_left, cv::Size(left_rect.cols / k, left_rect.rows / k), 0, 0, cv::INTER_AREA);
  cv::resize(right_rect, small_r, s.small_left.size(), 0, 0, cv::INTER_AREA);
  s.f = rig.P1.at<double>(0, 0), s.cx = rig.P1.at<double>(0, 2), s.cy = rig.P1.at<double>(1, 2);
  s.fb = s.f * rig.baseline_mm;
  SgbmOptions sg;
  sg.block_size = o.block_size;
  sg.refine_radius = 0;
  sg.fill_holes = false;
  sg.mode = SgbmMode::kSgbm3Way;
  // The search reaches from the nearest working distance out to infinity (disparity 0): at 1/k it
  // costs little, and a hedge row or trees beyond the working range then get their own, far
  // disparity instead of a false match inside the range.
  {
    int lo = 0, n = 0;
    DisparityRangeForDepth(s.f / k, rig.baseline_mm, o.min_z_mm, o.max_z_mm, &lo, &n);
    sg.min_disparity = 0;
    sg.num_disparities = ((lo + n + 15) / 16) * 16;
  }
  if (s.small_left.cols <= sg.min_disparity + sg.num_disparities + o.block_size) {
    throw Error("stereo.segment_garden: the image is too small for option 'downscale' " + std::to_string(k) +
                " at this working range; lower it");
  }
  // Padded on both sides, so a hedge near either edge of the image is not cut where a search
  // would leave the other view (num_disparities coarse columns each side: a tenth of the frame).
  DisparityMap coarse = ComputeDisparity(s.small_left, small_r, sg, cv::Mat(), 1, sg.num_disparities, sg.num_disparities);
  // A 5 x 5 median: halves the coarse disparity's noise and keeps the depth edges between objects.
  {
    cv::Mat known = coarse.disparity == coarse.disparity, filtered;
    cv::Mat d0 = coarse.disparity.clone();
    d0.setTo(0, ~known);
    cv::medianBlur(d0, filtered, 5);
    filtered.setTo(std::numeric_limits<float>::quiet_NaN(), ~known);
    coarse.disparity = filtered;
  }
  out->coarse_disparity = coarse.disparity;
  s.w = s.small_left.cols, s.h = s.small_left.rows;
  s.xyz.assign(std::size_t(s.w) * s.h, cv::Vec3d(0, 0, std::numeric_limits<double>::quiet_NaN()));
  for (int v = 0; v < s.h; ++v) {
    for (int u = 0; u < s.w; ++u) {
      const float dc = coarse.disparity.at<float>(v, u);
      if (!std::isfinite(dc) || dc <= 0) continue;
      const double d = dc * k, z = s.fb / d;
      if (z < o.min_z_mm || z > o.max_z_mm) continue;
      // The coarse pixel's centre in full-resolution pixels.
      const double uf = (u + 0.5) * k - 0.5, vf = (v + 0.5) * k - 0.5;
      const cv::Vec3d p((uf - s.cx) * z / s.f, (vf - s.cy) * z / s.f, z);
      s.xyz[std::size_t(v) * s.w + u] = p;
      s.valid.emplace_back(float(p[0]), float(p[1]), float(p[2]));
    }
  }
  if (s.valid.size() < 50) {
    throw Error("no hedge found: almost nothing matched within the working range (" + std::to_string(int(o.min_z_mm)) +
                "-" + std::to_string(int(o.max_z_mm)) + " mm); check --min-z/--max-z and that the images are a stereo pair");
  }
  return s;
}

// 2. The ground: a plane with many points whose normal is near the camera's vertical. It must
// hold a good share of the points and lie below the camera.
void FindGround(CoarseScene* s, GardenSegmentation* out) {
  cloud::PlaneSearch search;
  search.axis = Eigen::Vector3f(0, -1, 0);
  search.max_angle_deg = 35;
  search.distance_threshold_mm = 40;  // ~ the coarse depth noise seen on a lawn (1 coarse px ~ 4 px)
  // A few thousand points settle a plane: RANSAC counts inliers over every point it is given.
  std::vector<Eigen::Vector3f> sample;
  const std::size_t step = std::max<std::size_t>(1, s->valid.size() / 8000);
  for (std::size_t i = 0; i < s->valid.size(); i += step) sample.push_back(s->valid[i]);
  std::optional<cloud::Plane> ground = cloud::FindPlane(sample, search);
  if (ground && ground->d < 0) {  // orient: the camera (origin) above the ground
    ground->normal = -ground->normal;
    ground->d = -ground->d;
  }
  if (ground && (ground->inliers < sample.size() / 10 || ground->d < 100)) ground.reset();
  s->ground = ground;
  out->ground_found = ground.has_value();
  if (!ground) return;
  out->ground = cv::Vec4d(ground->normal.x(), ground->normal.y(), ground->normal.z(), ground->d);
  const cv::Vec3d n(ground->normal.x(), ground->normal.y(), ground->normal.z());
  s->across = cv::normalize(cv::Vec3d(1, 0, 0) - n * n.dot(cv::Vec3d(1, 0, 0)));
}

// 3. Blobs: above the ground, connected without a depth jump. `blob_of` gets each pixel's blob.
std::vector<Blob> GrowBlobs(const CoarseScene& s, const GardenSegmentOptions& o, std::vector<int>* blob_of) {
  const int w = s.w, h = s.h;
  std::vector<std::uint8_t> fg(s.xyz.size(), 0);
  for (std::size_t i = 0; i < s.xyz.size(); ++i) {
    if (std::isfinite(s.xyz[i][2]) && (!s.ground || s.Height(s.xyz[i]) > o.ground_clearance_mm)) fg[i] = 1;
  }
  blob_of->assign(s.xyz.size(), -1);
  std::vector<Blob> blobs;
  std::vector<int> stack;
  for (int start = 0; start < int(s.xyz.size()); ++start) {
    if (!fg[std::size_t(start)] || (*blob_of)[std::size_t(start)] >= 0) continue;
    Blob b;
    const int id = int(blobs.size());
    (*blob_of)[std::size_t(start)] = id;
    stack.assign(1, start);
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      s.AddPixel(&b, i);
      const int u = i % w, v = i / w;
      const cv::Vec3d& p = s.xyz[std::size_t(i)];
      const int nbr[4][2] = {{u - 1, v}, {u + 1, v}, {u, v - 1}, {u, v + 1}};
      for (const auto& q : nbr) {
        if (q[0] < 0 || q[1] < 0 || q[0] >= w || q[1] >= h) continue;
        const int j = q[1] * w + q[0];
        if (!fg[std::size_t(j)] || (*blob_of)[std::size_t(j)] >= 0) continue;
        if (std::abs(s.xyz[std::size_t(j)][2] - p[2]) > s.JumpAt(p[2], o.depth_jump_mm)) continue;
        (*blob_of)[std::size_t(j)] = id;
        stack.push_back(j);
      }
    }
    blobs.push_back(std::move(b));
  }
  return blobs;
}

// 3b. A blob split where bridges join it to its neighbours, or nullopt when it stays as it was.
// The coarse match fattens near objects into whatever lies beside them (a strip of lawn next to a
// pot, the gap between two balls where the background is beyond the working range), so a ball and
// its neighbour can come out as one blob. The blob is opened with a disc of a third of its largest
// inscribed radius, which cuts such bridges and keeps a ball's outline; when that leaves more than
// one piece of a speck's size, each becomes a blob of its own (a pot is then judged, and rejected,
// alone), else the blob stays as it was, rim and all. Balls side by side (a row whose balls touch,
// or joined by a bridge as thick as that disc), and a pot before a ball, are first split between
// the peaks of the blob's distance transform or the pits of its depth (BallCores). A single ball,
// a dome, a hedge row or a wall has one and stays whole (a row or a wall then fails the tests
// below, as before).
std::optional<std::vector<Blob>> SplitAtBridges(const CoarseScene& s, const Blob& b, int bi,
                                                const std::vector<int>& blob_of, std::size_t min_pixels) {
  const int w = s.w;
  const cv::Rect box(b.min_u - 1, b.min_v - 1, b.max_u - b.min_u + 3, b.max_v - b.min_v + 3);  // a blank border
  cv::Mat mask = cv::Mat::zeros(box.size(), CV_8U);
  for (int i : b.pixels) mask.at<std::uint8_t>(i / w - box.y, i % w - box.x) = 255;
  mask = FillHoles(mask);
  cv::Mat dt;
  cv::distanceTransform(mask, dt, cv::DIST_L2, cv::DIST_MASK_5);
  cv::Mat z(box.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int i : b.pixels) z.at<float>(i / w - box.y, i % w - box.x) = float(s.xyz[std::size_t(i)][2]);
  cv::Mat part = cv::Mat::zeros(mask.size(), CV_32S);
  part.setTo(1, mask);
  int n_parts = 1;
  cv::Mat core_labels;
  const int n_cores = BallCores(mask, dt, z, 0.5 * std::min(b.max_x - b.min_x, s.Tall(b)), &core_labels);
  if (n_cores >= 2) part = core_labels, n_parts = n_cores;
  std::vector<Blob> pieces;
  for (int lab = 1; lab <= n_parts; ++lab) {
    cv::Mat one = part == lab;
    double inscribed = 0;
    cv::minMaxLoc(dt, nullptr, &inscribed, nullptr, nullptr, one);
    const int r_open = std::max(1, int(std::lround(inscribed / 3)));
    one = OpenMask(one, r_open);
    cv::Mat labels;
    const int n = cv::connectedComponents(one, labels, 8, CV_32S);
    std::vector<Blob> found(std::size_t(std::max(0, n - 1)));
    for (int y = 0; y < labels.rows; ++y) {
      for (int x = 0; x < labels.cols; ++x) {
        const int l = labels.at<int>(y, x), i = (y + box.y) * w + (x + box.x);
        // Only pixels of the blob itself (not its filled holes) carry a point.
        if (l > 0 && blob_of[std::size_t(i)] == bi) s.AddPixel(&found[std::size_t(l - 1)], i);
      }
    }
    for (Blob& piece : found) {
      if (piece.pixels.size() >= min_pixels) pieces.push_back(std::move(piece));  // crumbs of a bridge go
    }
  }
  if (n_parts == 1 && pieces.size() < 2) return std::nullopt;  // one ball (or nothing ball-sized): as it was
  return pieces;
}

void SplitBridges(const CoarseScene& s, std::size_t min_pixels, std::vector<Blob>* blobs, std::vector<int>* blob_of) {
  const std::size_t n_before = blobs->size();
  std::vector<Blob> pieces_all;
  for (std::size_t bi = 0; bi < n_before; ++bi) {
    if ((*blobs)[bi].pixels.size() < 200) continue;
    std::optional<std::vector<Blob>> pieces = SplitAtBridges(s, (*blobs)[bi], int(bi), *blob_of, min_pixels);
    if (!pieces) continue;
    for (int i : (*blobs)[bi].pixels) (*blob_of)[std::size_t(i)] = -1;
    (*blobs)[bi] = Blob();  // left empty: it is below every size the tests keep
    for (Blob& piece : *pieces) pieces_all.push_back(std::move(piece));
  }
  for (Blob& piece : pieces_all) {
    for (int i : piece.pixels) (*blob_of)[std::size_t(i)] = int(blobs->size());
    blobs->push_back(std::move(piece));
  }
}

void DumpBlobs(const CoarseScene& s, const std::vector<Blob>& blobs, const std::string& prefix) {
  cv::Mat vis(s.h, s.w, CV_8UC3, cv::Scalar(0, 0, 0));
  for (std::size_t bi = 0; bi < blobs.size(); ++bi) {
    const cv::Vec3b c((bi * 97) % 200 + 55, (bi * 57) % 200 + 55, (bi * 31) % 200 + 55);
    for (int i : blobs[bi].pixels) vis.at<cv::Vec3b>(i / s.w, i % s.w) = c;
  }
  WriteImageAtomic(prefix + "_blobs.png", vis);
}

struct Kept {
  int blob;
  double radius;
};

// Why blob `b` is not a hedge, or "" when it may be one; `radius` gets its size.
std::string NotAHedge(const CoarseScene& s, const Blob& b, const GardenSegmentOptions& o, bool colour, double* radius) {
  const double width = b.max_x - b.min_x, tall = s.Tall(b);
  *radius = 0.5 * std::max(width, tall);
  const double r = *radius;
  // A ball of radius r whose visible points average depth z covers about this many coarse pixels.
  // Its lowest part is lost to the lawn's clearance, its limbs to the depth jumps and parts may be
  // hidden: a hedge keeps well over 30 % of it, a fragment of something else far less.
  const double disc_r = (s.f / s.k) * r / std::max(b.sum[2] / double(b.pixels.size()), 1.0);
  const double disc_pixels = 3.14159265358979 * disc_r * disc_r;
  // A ball cut by the frame's side is narrower than it is high, one cut by its top or bottom
  // lower than it is wide: the outline's aspect says nothing there.
  const bool cut_side = b.min_u <= 1 || b.max_u >= s.w - 2, cut_end = b.min_v <= 1 || b.max_v >= s.h - 2;
  char why[160] = "";
  if (r < o.min_radius_mm || r > o.max_radius_mm) {
    std::snprintf(why, sizeof(why), "about %.0f mm in radius, outside %.0f-%.0f mm (--min-radius/--max-radius)", r,
                  o.min_radius_mm, o.max_radius_mm);
  } else if (double(b.pixels.size()) < 0.3 * disc_pixels) {
    std::snprintf(why, sizeof(why), "covers %.0f%% of the disc a %.0f mm ball would: a fragment, not a hedge",
                  100.0 * double(b.pixels.size()) / disc_pixels, r);
  } else if ((width > o.max_aspect * tall && !cut_end) || (tall > o.max_aspect * width && !cut_side)) {
    std::snprintf(why, sizeof(why), "%.0f mm wide but %.0f mm high: not round", width, tall);
  } else if (s.ground && b.min_h > o.ground_clearance_mm + 0.6 * r) {
    std::snprintf(why, sizeof(why), "does not stand on the ground (lowest point %.0f mm above it)", b.min_h);
  } else if (colour && o.min_excess_green > 0) {
    cv::Vec3d bgr(0, 0, 0);
    for (int i : b.pixels) {
      const cv::Vec3b c = s.small_left.at<cv::Vec3b>(i / s.w, i % s.w);
      bgr += cv::Vec3d(c[0], c[1], c[2]);
    }
    bgr *= 1.0 / double(b.pixels.size());
    const double exg = 2 * bgr[1] - bgr[0] - bgr[2];
    if (exg < o.min_excess_green) std::snprintf(why, sizeof(why), "not green (mean 2G-R-B = %.0f)", exg);
  }
  return why;
}

// 4. Which blobs are hedges, largest first, then left to right.
std::vector<Kept> ChooseHedges(const CoarseScene& s, const std::vector<Blob>& blobs, std::size_t min_pixels,
                               const GardenSegmentOptions& o, GardenSegmentation* out) {
  const cv::Mat& small_l = s.small_left;
  const bool colour = small_l.channels() == 3 && cv::norm(small_l.reshape(1, int(small_l.total())).col(0),
                                                          small_l.reshape(1, int(small_l.total())).col(1), cv::NORM_INF) > 0;
  std::vector<Kept> kept;
  std::vector<std::size_t> order(blobs.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return blobs[a].pixels.size() > blobs[b].pixels.size(); });
  for (std::size_t bi : order) {
    const Blob& b = blobs[bi];
    if (b.pixels.size() < min_pixels) break;
    double radius = 0;
    if (const std::string why = NotAHedge(s, b, o, colour, &radius); !why.empty()) {
      out->rejected.push_back(Where(b, s.k) + ": " + why);
      continue;
    }
    if (int(kept.size()) < o.max_hedges) kept.push_back({int(bi), radius});
  }
  if (kept.empty()) {
    std::string msg = "no hedge found: nothing hedge-like stands on the ground within the working range";
    if (!out->rejected.empty()) msg += " (" + out->rejected.front() + ")";
    throw Error(msg + "; check --min-z/--max-z and --min-radius/--max-radius");
  }
  std::sort(kept.begin(), kept.end(), [&](const Kept& a, const Kept& b) {
    return blobs[std::size_t(a.blob)].min_u + blobs[std::size_t(a.blob)].max_u <
           blobs[std::size_t(b.blob)].min_u + blobs[std::size_t(b.blob)].max_u;
  });
  return kept;
}

// 5. A kept blob at full resolution: each coarse pixel covers k x k pixels, eroded by `margin`;
// the nearer hedge (labelled first) keeps a shared pixel. False when too little is left.
bool AddRegion(const StereoRig& rig, const CoarseScene& s, const Blob& b, const Kept& kept, int margin,
               const GardenSegmentOptions& o, GardenSegmentation* out) {
  const int k = s.k;
  // Work inside the blob's box (with a blank border, so holes and erosion behave as on the whole
  // image): full-resolution morphology over the whole frame would cost more than the match.
  const cv::Rect coarse_box(b.min_u, b.min_v, b.max_u - b.min_u + 1, b.max_v - b.min_v + 1);
  const cv::Rect roi = cv::Rect(coarse_box.x * k - 2, coarse_box.y * k - 2, coarse_box.width * k + 4,
                                coarse_box.height * k + 4) &
                       cv::Rect(0, 0, out->labels.cols, out->labels.rows);
  cv::Mat coarse_mask = cv::Mat::zeros(coarse_box.size(), CV_8U);
  for (int i : b.pixels) coarse_mask.at<std::uint8_t>(i / s.w - coarse_box.y, i % s.w - coarse_box.x) = 255;
  cv::Mat part = cv::Mat::zeros(roi.size(), CV_8U);
  const cv::Rect inner(coarse_box.x * k - roi.x, coarse_box.y * k - roi.y, coarse_box.width * k, coarse_box.height * k);
  cv::resize(coarse_mask, part(inner & cv::Rect(0, 0, roi.width, roi.height)),
             (inner & cv::Rect(0, 0, roi.width, roi.height)).size(), 0, 0, cv::INTER_NEAREST);
  part = ErodeMask(FillHoles(part), margin);
  part.setTo(0, out->labels(roi) != 0);
  HedgeRegion r;
  r.id = int(out->hedges.size()) + 1;
  r.pixels = cv::countNonZero(part);
  // A sphere fit on a few hundred points of a hedge's cap says little; such a speck is far
  // away or a fragment.
  if (r.pixels < kMinHedgePixels) {
    out->rejected.push_back(Where(b, k) + ": " + std::to_string(r.pixels) + " px after erosion, fewer than " +
                            std::to_string(kMinHedgePixels) + " (too far or too small to measure)");
    return false;
  }
  out->labels(roi).setTo(r.id, part);
  r.box = cv::boundingRect(part) + roi.tl();
  r.image_box = OriginalBox(rig, r.box);
  r.approx_center_mm = b.sum * (1.0 / double(b.pixels.size()));
  r.approx_radius_mm = kept.radius;
  r.touches_border = b.min_u <= 1 || b.max_u >= s.w - 2 || b.min_v <= 1 || b.max_v >= s.h - 2;
  // The fine match's search: the blob's depths widened by a coarse pixel of disparity (several
  // times the median-filtered coarse noise) on each side, within the working range.
  const double d_near = s.fb / b.min_z + k, d_far = std::max(1.0, s.fb / b.max_z - k);
  r.min_z_mm = std::max(o.min_z_mm, s.fb / d_near);
  r.max_z_mm = std::min(o.max_z_mm, s.fb / d_far);
  out->hedges.push_back(r);
  return true;
}

}  // namespace

GardenSegmentation FindHedges(const StereoRig& rig, const cv::Mat& left_rect, const cv::Mat& right_rect,
                              const GardenSegmentOptions& o) {
  o.Check();
  if (left_rect.empty() || left_rect.size() != right_rect.size()) {
    throw Error("stereo.segment_garden: needs the rectified pair (add stereo.rectify before it)");
  }
  GardenSegmentation out;
  CoarseScene s = MatchCoarse(rig, left_rect, right_rect, o, &out);
  FindGround(&s, &out);
  std::vector<int> blob_of;
  std::vector<Blob> blobs = GrowBlobs(s, o, &blob_of);
  // Blobs smaller than a quarter of the smallest hedge's disc at the far end of the working range
  // are specks, not worth a reason.
  const double r_px = (s.f / s.k) * o.min_radius_mm / o.max_z_mm;
  const std::size_t min_pixels = std::size_t(std::max(30.0, 0.25 * 3.14159 * r_px * r_px));
  SplitBridges(s, min_pixels, &blobs, &blob_of);
  if (const char* dump = std::getenv("HEDGEFIT_GARDEN_DEBUG")) DumpBlobs(s, blobs, dump);
  const std::vector<Kept> kept = ChooseHedges(s, blobs, min_pixels, o, &out);
  // The coarse block fattens objects by up to half a block at depth edges, so that much is eroded
  // on top of erode_px.
  const int margin = (o.block_size / 2) * s.k + o.erode_px;
  out.labels = cv::Mat::zeros(left_rect.size(), CV_32S);
  for (const Kept& kb : kept) AddRegion(rig, s, blobs[std::size_t(kb.blob)], kb, margin, o, &out);
  if (out.hedges.empty()) {
    throw Error("no hedge found: every candidate is too small to measure once eroded (" + out.rejected.back() +
                "); lower --erode, or move closer");
  }
  return out;
}

}  // namespace hedgefit::stereo
