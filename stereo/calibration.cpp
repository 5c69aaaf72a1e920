#include "stereo/calibration.hpp"
#include "stereo/stereo_stages.hpp"

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <map>
#include <mutex>
#include <ostream>

#include "pipeline/error.hpp"
#include "pipeline/parallel.hpp"

namespace hedgefit::stereo {

void CalibrationOptions::Check() const {
  if (board.inner_corners.width < 2 || board.inner_corners.height < 2) {
    throw Error("board: needs at least 2 x 2 inner corners, e.g. 9x6");
  }
  if (!(board.square_mm > 0)) throw Error("square: must be > 0");
  if (board.type == BoardType::kCharuco) {
    if (board.marker_mm < 0 || board.marker_mm >= board.square_mm) {
      throw Error("marker: must be smaller than the square (0 = 0.75 square)");
    }
    CharucoDictionary(board.dictionary);
  }
  if (!(alpha == -1 || (alpha >= 0 && alpha <= 1))) throw Error("alpha: must be -1 (default) or in [0, 1]");
  if (reject_factor < 0) throw Error("reject_factor: must be >= 0 (0 keeps every pair)");
  if (min_pairs < 1) throw Error("min_pairs: must be >= 1");
}

std::vector<cv::Point3f> BoardCorners(const BoardSpec& board) {
  std::vector<cv::Point3f> pts;
  for (int r = 0; r < board.inner_corners.height; ++r) {
    for (int c = 0; c < board.inner_corners.width; ++c) {
      pts.emplace_back(static_cast<float>(c * board.square_mm), static_cast<float>(r * board.square_mm), 0.f);
    }
  }
  return pts;
}

namespace {

// The refinement window must stay inside one square around each corner, or it converges on a
// neighbour's edges: half the smallest corner spacing, at most 11 px.
// `clear_share`: the share of the spacing around a corner that holds nothing but the corner's
// two edges (1 for a chessboard; for ChArUco the gap to the markers, 1 - marker / square).
// `spacing`: the corners' smallest spacing, px. `clear_share`: the share of it around a corner
// that holds nothing but the corner's two edges (1 for a chessboard; for ChArUco the gap to the
// markers, 1 - marker / square).
void RefineCorners(const cv::Mat& grey, std::vector<cv::Point2f>* corners, double spacing, double clear_share = 1.0) {
  const int win = std::clamp(static_cast<int>(spacing * 0.5 * clear_share) - 1, 2, 11);
  // cornerSubPix solves for the point all image gradients in the window are orthogonal
  // to; on a sharp (aliased) edge those gradients are a few noisy pixels. A light blur
  // (a tenth of the square, at most 2 px) spreads them over the window without moving the
  // saddle point, which is symmetric: 3.4x lower corner error on the simulated lab boards
  // (0.041 -> 0.012 px rms against the projected truth). Only the board's neighbourhood is
  // blurred.
  cv::Rect box = cv::boundingRect(*corners);
  const int pad = static_cast<int>(spacing) + 16;
  box = cv::Rect(box.x - pad, box.y - pad, box.width + 2 * pad, box.height + 2 * pad) & cv::Rect(0, 0, grey.cols, grey.rows);
  const double sigma = std::min(2.0, spacing * clear_share / 10.0);
  cv::Mat smooth;
  cv::GaussianBlur(grey(box), smooth, cv::Size(0, 0), sigma);
  for (auto& p : *corners) p -= cv::Point2f(float(box.x), float(box.y));
  cv::cornerSubPix(smooth, *corners, cv::Size(win, win), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  for (auto& p : *corners) p += cv::Point2f(float(box.x), float(box.y));
}

// The board is searched for on a reduced image (the longer side at most kSearchSide px): the
// detectors' cost grows with the pixel count and a board's squares stay tens of pixels wide.
// The classic detector's fast check gives up quickly on an image without a board; the
// sector-based detector finds boards the classic one misses. The corners found are then
// refined on the full image.
constexpr int kSearchSide = 1024;

// A view as the corner search and the sub-pixel refinement read it.
struct BoardView {
  cv::Mat grey;    ///< the detectors' input
  /// The refinement's: a colour image's green channel. A Bayer sensor samples green at every
  /// other pixel and red and blue at one in four, so demosaicing leaves its smallest errors in
  /// green, and red and blue also carry the lens's lateral colour. Refined on green, the corners'
  /// error against the truth fell 0.081 -> 0.064 px on POV-Ray's real-camera lab boards and
  /// 0.043 -> 0.027 px on hedgefit's (bench_calibrate); on grey images it is the image itself.
  cv::Mat refine;
};

BoardView ViewOf(const cv::Mat& image) {
  BoardView v;
  if (image.channels() == 3) {
    cv::cvtColor(image, v.grey, cv::COLOR_BGR2GRAY);
    cv::extractChannel(image, v.refine, 1);
  } else {
    v.grey = v.refine = image;
  }
  return v;
}

bool FindCorners(const BoardView& view, const cv::Size& pattern, std::vector<cv::Point2f>* corners) {
  const cv::Mat& grey = view.grey;
  const double scale = std::max(1.0, double(std::max(grey.cols, grey.rows)) / kSearchSide);
  cv::Mat small = grey;
  if (scale > 1) cv::resize(grey, small, cv::Size(), 1.0 / scale, 1.0 / scale, cv::INTER_AREA);
  bool found = cv::findChessboardCorners(small, pattern, *corners,
                                         cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK);
  if (!found) found = cv::findChessboardCornersSB(small, pattern, *corners, cv::CALIB_CB_NORMALIZE_IMAGE);
  if (!found) return false;
  // Pixel centres: the reduced image's pixel i covers the full image's [i sx, (i + 1) sx).
  const double sx = double(grey.cols) / small.cols, sy = double(grey.rows) / small.rows;
  for (auto& p : *corners) p = cv::Point2f(float((p.x + 0.5) * sx - 0.5), float((p.y + 0.5) * sy - 0.5));
  // A chessboard's spacing along its rows. (The smallest spacing in any direction shrinks the
  // window on boards tilted about the horizontal axis, and the corners' error against the truth
  // grows on both renderers: 0.0163 -> 0.0169 px on hedgefit's lab, 0.0504 -> 0.0513 px on
  // POV-Ray's; bench_calibrate.)
  double spacing = 1e9;
  for (int r = 0; r < pattern.height; ++r) {
    for (int c = 0; c + 1 < pattern.width; ++c) {
      const auto& a = (*corners)[std::size_t(r * pattern.width + c)];
      const auto& b = (*corners)[std::size_t(r * pattern.width + c + 1)];
      spacing = std::min(spacing, double(std::hypot(a.x - b.x, a.y - b.y)));
    }
  }
  RefineCorners(view.refine, corners, spacing);
  return true;
}

cv::Ptr<cv::aruco::CharucoBoard> MakeCharuco(const BoardSpec& board) {
  const float square = float(board.square_mm);
  const float marker = float(board.marker_mm > 0 ? board.marker_mm : 0.75 * board.square_mm);
  return cv::aruco::CharucoBoard::create(board.inner_corners.width + 1, board.inner_corners.height + 1, square, marker,
                                         cv::aruco::getPredefinedDictionary(CharucoDictionary(board.dictionary)));
}

// ChArUco corners of one image: markers first, then the chessboard corners between them
// (OpenCV refines those to sub-pixel itself). Returns corners and their ids.
void FindCharuco(const BoardView& view, const cv::Ptr<cv::aruco::CharucoBoard>& board, std::vector<cv::Point2f>* corners,
                 std::vector<int>* ids) {
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  auto params = cv::aruco::DetectorParameters::create();
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;  // the chessboard corners are what count
  cv::aruco::detectMarkers(view.grey, board->dictionary, marker_corners, marker_ids, params);
  corners->clear();
  ids->clear();
  if (marker_ids.size() < 2) return;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, view.grey, board, *corners, *ids);
  // OpenCV's corners here carry the marker contours' half-pixel offset (0.5 px on simulated
  // boards, which cost 3-15 % of focal length): refined again as a chessboard's are, with the
  // window kept inside the gap between a corner and its markers.
  if (corners->size() < 2) return;
  // The corners seen need not be neighbours in a row: the smallest distance between any two.
  double spacing = 1e9;
  for (std::size_t i = 0; i < corners->size(); ++i) {
    for (std::size_t j = i + 1; j < corners->size(); ++j) {
      const cv::Point2f d = (*corners)[i] - (*corners)[j];
      spacing = std::min(spacing, double(std::hypot(d.x, d.y)));
    }
  }
  RefineCorners(view.refine, corners, spacing, 1.0 - board->getMarkerLength() / board->getSquareLength());
}

// A ChArUco pair: the corners both images saw, in the same order. Fewer than 8 is too few to
// constrain a board's pose in both cameras.
void FindCharucoPair(const BoardView& l, const BoardView& r, const BoardSpec& spec, PairCorners* pc) {
  const auto board = MakeCharuco(spec);
  std::vector<cv::Point2f> lc, rc;
  std::vector<int> li, ri;
  FindCharuco(l, board, &lc, &li);
  FindCharuco(r, board, &rc, &ri);
  std::map<int, cv::Point2f> right_by_id;
  for (std::size_t k = 0; k < ri.size(); ++k) right_by_id[ri[k]] = rc[k];
  std::vector<std::pair<int, std::size_t>> common;
  for (std::size_t k = 0; k < li.size(); ++k) {
    if (right_by_id.count(li[k])) common.emplace_back(li[k], k);
  }
  std::sort(common.begin(), common.end());
  constexpr std::size_t kMinCorners = 8;
  if (common.size() < kMinCorners) {
    pc->status = "ChArUco board: " + std::to_string(common.size()) + " corners seen in both images (left " +
                 std::to_string(li.size()) + ", right " + std::to_string(ri.size()) + "); need " +
                 std::to_string(kMinCorners);
    return;
  }
  for (const auto& [id, k] : common) {
    pc->ids.push_back(id);
    pc->left_px.push_back(lc[k]);
    pc->right_px.push_back(right_by_id[id]);
  }
}

}  // namespace

int CharucoDictionary(const std::string& name) {
  static const std::map<std::string, int> names = {
      {"4x4_50", cv::aruco::DICT_4X4_50},     {"4x4_100", cv::aruco::DICT_4X4_100},
      {"4x4_250", cv::aruco::DICT_4X4_250},   {"4x4_1000", cv::aruco::DICT_4X4_1000},
      {"5x5_50", cv::aruco::DICT_5X5_50},     {"5x5_100", cv::aruco::DICT_5X5_100},
      {"5x5_250", cv::aruco::DICT_5X5_250},   {"5x5_1000", cv::aruco::DICT_5X5_1000},
      {"6x6_50", cv::aruco::DICT_6X6_50},     {"6x6_100", cv::aruco::DICT_6X6_100},
      {"6x6_250", cv::aruco::DICT_6X6_250},   {"6x6_1000", cv::aruco::DICT_6X6_1000},
      {"7x7_50", cv::aruco::DICT_7X7_50},     {"7x7_100", cv::aruco::DICT_7X7_100},
      {"7x7_250", cv::aruco::DICT_7X7_250},   {"7x7_1000", cv::aruco::DICT_7X7_1000}};
  const auto it = names.find(name);
  if (it == names.end()) {
    std::string list;
    for (const auto& [n, id] : names) list += (list.empty() ? "" : ", ") + n;
    throw Error("dictionary: '" + name + "' is not an ArUco dictionary; use one of " + list);
  }
  return it->second;
}

cv::Mat CharucoImage(const BoardSpec& board, int px_per_square) {
  cv::Mat img;
  MakeCharuco(board)->draw(cv::Size((board.inner_corners.width + 1) * px_per_square,
                                    (board.inner_corners.height + 1) * px_per_square),
                           img, 0, 1);
  return img;
}

std::vector<PairCorners> DetectBoards(const std::vector<std::pair<std::string, std::string>>& pairs,
                                      const BoardSpec& board, cv::Size* image_size, std::ostream* progress,
                                      int threads) {
  std::vector<PairCorners> out(pairs.size());
  std::vector<cv::Size> sizes(pairs.size());
  std::mutex mutex;
  std::size_t done = 0;
  const auto t0 = std::chrono::steady_clock::now();
  // Pairs are independent: one per worker, each reporting when it is done.
  pipeline::ParallelFor(pairs.size(), threads, 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t index = begin; index < end; ++index) {
      const auto& [left, right] = pairs[index];
      PairCorners pc;
      pc.left = left;
      pc.right = right;
      // Read through the capture loader: only camera formats reach OpenCV's decoders. In colour:
      // the corners are refined on the green channel (BoardView).
      // Unreadable: the status says why (the reader's message starts with the file's name).
      auto read = [](const std::string& file, std::string* why) {
        try {
          return ReadCaptureImage(file, cv::IMREAD_COLOR);
        } catch (const Error& e) {
          *why = e.what();
          return cv::Mat();
        }
      };
      std::string why_left, why_right;
      const cv::Mat l = read(left, &why_left), r = read(right, &why_right);
      if (l.empty()) {
        pc.status = "cannot read left image " + (why_left.empty() ? left : why_left);
      } else if (r.empty()) {
        pc.status = "cannot read right image " + (why_right.empty() ? right : why_right);
      } else if (l.size() != r.size()) {
        pc.status = "left is " + std::to_string(l.cols) + "x" + std::to_string(l.rows) +
                    " but right is " + std::to_string(r.cols) + "x" + std::to_string(r.rows);
      } else {
        sizes[index] = l.size();
        if (board.type == BoardType::kCharuco) {
          FindCharucoPair(ViewOf(l), ViewOf(r), board, &pc);
        } else {
          const bool found_l = FindCorners(ViewOf(l), board.inner_corners, &pc.left_px);
          const bool found_r = found_l && FindCorners(ViewOf(r), board.inner_corners, &pc.right_px);
          if (found_l && found_r) {
            // The detector may start from either end of the board, independently per image; a
            // stereo pair needs the same corner at the same index. The cameras look roughly the
            // same way, so the matching order is the one whose corners share rows best.
            double same = 0, reversed = 0;
            const std::size_t n = pc.left_px.size();
            for (std::size_t i = 0; i < n; ++i) {
              same += std::abs(pc.left_px[i].y - pc.right_px[i].y);
              reversed += std::abs(pc.left_px[i].y - pc.right_px[n - 1 - i].y);
            }
            if (reversed < same) std::reverse(pc.right_px.begin(), pc.right_px.end());
          }
          if (!found_l || !found_r) {
            pc.status = std::string("board (") + std::to_string(board.inner_corners.width) + "x" +
                        std::to_string(board.inner_corners.height) +
                        " inner corners) not found in " + (found_l ? "right" : "left") + " image";
            pc.left_px.clear();
            pc.right_px.clear();
          }
        }
      }
      if (progress) {
        const std::lock_guard<std::mutex> lock(mutex);
        ++done;
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        *progress << "[" << done << "/" << pairs.size() << ", " << std::fixed
                  << std::setprecision(1) << s << " s] " << pc.left << " " << pc.right << ": "
                  << (pc.status.empty() ? "board found" : pc.status) << std::endl;
      }
      out[index] = std::move(pc);
    }
  });
  // Every pair must have the first readable pair's size.
  *image_size = cv::Size();
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (sizes[i].empty()) continue;
    if (image_size->empty()) {
      *image_size = sizes[i];
    } else if (sizes[i] != *image_size) {
      out[i].status = "images are " + std::to_string(sizes[i].width) + "x" + std::to_string(sizes[i].height) +
                      ", the first pair's are " + std::to_string(image_size->width) + "x" +
                      std::to_string(image_size->height);
      out[i].left_px.clear();
      out[i].right_px.clear();
    }
  }
  return out;
}

cv::Mat CoveragePicture(const std::vector<PairCorners>& pairs, const std::vector<PairReport>& reports,
                        cv::Size image_size, std::pair<double, double>* share) {
  const double scale = std::min(1.0, 800.0 / std::max(1, image_size.width));
  const cv::Size small(std::max(1, int(std::lround(image_size.width * scale))),
                       std::max(1, int(std::lround(image_size.height * scale))));
  constexpr int kGrid = 8;
  cv::Mat out(small.height + 24, 2 * small.width + 8, CV_8UC3, cv::Scalar(255, 255, 255));
  for (int cam = 0; cam < 2; ++cam) {
    cv::Mat count = cv::Mat::zeros(small, CV_32F);
    std::vector<cv::Point2f> dots;
    bool cell[kGrid][kGrid] = {};
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const bool used = i < reports.size() ? reports[i].used : pairs[i].status.empty();
      const auto& px = cam == 0 ? pairs[i].left_px : pairs[i].right_px;
      if (!used || px.empty()) continue;
      std::vector<cv::Point2f> scaled;
      for (const auto& p : px) {
        scaled.push_back(p * float(scale));
        const int gx = std::clamp(int(p.x / image_size.width * kGrid), 0, kGrid - 1);
        const int gy = std::clamp(int(p.y / image_size.height * kGrid), 0, kGrid - 1);
        cell[gy][gx] = true;
      }
      std::vector<cv::Point2f> hull_f;
      cv::convexHull(scaled, hull_f);
      std::vector<cv::Point> hull(hull_f.begin(), hull_f.end());
      cv::Mat one = cv::Mat::zeros(small, CV_32F);
      cv::fillConvexPoly(one, hull, cv::Scalar(1.0));
      count += one;
      dots.insert(dots.end(), scaled.begin(), scaled.end());
    }
    // Grey background, boards shaded blue by how many overlap.
    cv::Mat view(small, CV_8UC3, cv::Scalar(235, 235, 235));
    for (int y = 0; y < small.height; ++y) {
      for (int x = 0; x < small.width; ++x) {
        const float n = count.at<float>(y, x);
        if (n > 0) {
          const double t = std::min(1.0, 0.25 + 0.15 * n);
          view.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(235 - 20 * t), cv::saturate_cast<uchar>(235 - 170 * t),
                                               cv::saturate_cast<uchar>(235 - 200 * t));
        }
      }
    }
    int filled = 0;
    for (int gy = 0; gy < kGrid; ++gy) {
      for (int gx = 0; gx < kGrid; ++gx) {
        const cv::Rect r(gx * small.width / kGrid, gy * small.height / kGrid, small.width / kGrid, small.height / kGrid);
        if (cell[gy][gx]) {
          ++filled;
          continue;
        }
        cv::Mat roi = view(r);  // drawing in the cell's own view clips the hatching to it
        for (int k = -r.height; k < r.width; k += 8) {
          cv::line(roi, cv::Point(k, r.height), cv::Point(k + r.height, 0), cv::Scalar(80, 80, 220), 1, cv::LINE_AA);
        }
      }
    }
    for (const auto& d : dots) cv::circle(view, d, 1, cv::Scalar(20, 20, 20), cv::FILLED);
    for (int g = 1; g < kGrid; ++g) {
      cv::line(view, cv::Point(g * small.width / kGrid, 0), cv::Point(g * small.width / kGrid, small.height),
               cv::Scalar(200, 200, 200));
      cv::line(view, cv::Point(0, g * small.height / kGrid), cv::Point(small.width, g * small.height / kGrid),
               cv::Scalar(200, 200, 200));
    }
    view.copyTo(out(cv::Rect(cam * (small.width + 8), 24, small.width, small.height)));
    const double frac = filled / double(kGrid * kGrid);
    char label[96];
    std::snprintf(label, sizeof(label), "%s camera: corners in %d of %d cells", cam == 0 ? "left" : "right", filled,
                  kGrid * kGrid);
    cv::putText(out, label, cv::Point(cam * (small.width + 8) + 4, 17), cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    if (share) (cam == 0 ? share->first : share->second) = frac;
  }
  return out;
}

namespace {

// Why too few pairs are usable, from the pairs themselves: unreadable images are not a board problem.
Error TooFewPairs(const StereoRig& rig, std::size_t usable, std::size_t total, const CalibrationOptions& options) {
  std::size_t unreadable = 0;
  std::string first_unreadable;
  for (const auto& p : rig.pairs) {
    if (!p.used && p.status.rfind("cannot read", 0) == 0) {
      if (unreadable++ == 0) first_unreadable = p.status;
    }
  }
  const std::string head = "only " + std::to_string(usable) + " of " + std::to_string(total) +
                           " pairs are usable (need " + std::to_string(options.min_pairs) + ")";
  if (unreadable > 0) {
    return Error(head + ": " + std::to_string(unreadable) + " pair(s) cannot be read (" + first_unreadable +
                "); check that the files are PNG or JPEG images");
  }
  return Error(head + (options.board.type == BoardType::kCharuco
                          ? "; check --charuco (squares, e.g. 12x9), --marker, --dictionary and the images"
                          : "; check --board (inner corners, e.g. 9x6) and the images"));
}

// Marks the pairs whose stereo RMS `worst` (of pairs `index`) exceeds reject_factor times the
// median as not used; true when any was.
bool RejectWorstPairs(const std::vector<std::size_t>& index, const std::vector<double>& worst,
                      const CalibrationOptions& options, StereoRig* rig) {
  std::vector<double> sorted = worst;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double limit = options.reject_factor * sorted[sorted.size() / 2];
  bool rejected = false;
  for (std::size_t k = 0; k < index.size(); ++k) {
    if (worst[k] > limit && static_cast<int>(index.size()) > options.min_pairs) {
      PairReport& rep = rig->pairs[index[k]];
      rep.used = false;
      char buf[128];
      std::snprintf(buf, sizeof(buf), "rejected: RMS %.3f px > %.1f x median %.3f px", worst[k],
                    options.reject_factor, sorted[sorted.size() / 2]);
      rep.status = buf;
      rejected = true;
    }
  }
  return rejected;
}

}  // namespace

StereoRig CalibrateFromCorners(const std::vector<PairCorners>& pairs, cv::Size image_size,
                               const CalibrationOptions& options) {
  options.Check();
  StereoRig rig;
  rig.image_size = image_size;
  for (const auto& p : pairs) {
    PairReport rep;
    rep.left = p.left;
    rep.right = p.right;
    rep.status = p.status.empty() ? "used" : p.status;
    rep.used = p.status.empty() && !p.left_px.empty();
    rig.pairs.push_back(rep);
  }
  int flags = 0;
  switch (options.model) {
    case DistortionModel::kK1K2P1P2: flags |= cv::CALIB_FIX_K3; break;
    case DistortionModel::kK1K2P1P2K3: break;
    case DistortionModel::kRational: flags |= cv::CALIB_RATIONAL_MODEL; break;
  }
  if (options.fix_principal_point) flags |= cv::CALIB_FIX_PRINCIPAL_POINT;
  if (options.fix_aspect_ratio) flags |= cv::CALIB_FIX_ASPECT_RATIO;
  const std::vector<cv::Point3f> board = BoardCorners(options.board);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);
  std::vector<std::vector<cv::Point2f>> left, right;  // the corners of the pairs in use
  std::vector<std::vector<cv::Point3f>> used_object;   // and their board coordinates
  cv::Mat std_left, std_right;                          // per-camera intrinsics' standard deviations

  for (int round = 0;; ++round) {
    std::vector<std::vector<cv::Point3f>> object;
    std::vector<std::size_t> index;
    left.clear();
    right.clear();
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      if (!rig.pairs[i].used) continue;
      if (pairs[i].ids.empty()) {
        object.push_back(board);
      } else {  // the ChArUco corners this pair saw
        std::vector<cv::Point3f> seen;
        for (int id : pairs[i].ids) seen.push_back(board[std::size_t(id)]);
        object.push_back(seen);
      }
      left.push_back(pairs[i].left_px);
      right.push_back(pairs[i].right_px);
      index.push_back(i);
    }
    if (static_cast<int>(object.size()) < options.min_pairs) {
      throw TooFewPairs(rig, object.size(), pairs.size(), options);
    }
    // Zhang's method per camera (fx = fy fixed at 1 ratio only when asked).
    used_object = object;
    cv::Mat K1 = cv::Mat::eye(3, 3, CV_64F), K2 = cv::Mat::eye(3, 3, CV_64F), D1, D2;
    std::vector<cv::Mat> rv, tv;
    cv::Mat std_extrinsic, per_view_single;
    rig.rms_left_px = cv::calibrateCamera(object, left, image_size, K1, D1, rv, tv, std_left, std_extrinsic,
                                          per_view_single, flags, criteria);
    rig.rms_right_px = cv::calibrateCamera(object, right, image_size, K2, D2, rv, tv, std_right, std_extrinsic,
                                           per_view_single, flags, criteria);
    // Joint stereo refinement; per-view errors come back with it.
    int stereo_flags = flags | (options.refine_intrinsics ? cv::CALIB_USE_INTRINSIC_GUESS : cv::CALIB_FIX_INTRINSIC);
    cv::Mat R, T, E, F, per_view;
    rig.rms_stereo_px = cv::stereoCalibrate(object, left, right, K1, D1, K2, D2, image_size, R, T, E, F, per_view,
                                            stereo_flags, criteria);
    rig.K1 = K1;
    rig.D1 = D1;
    rig.K2 = K2;
    rig.D2 = D2;
    rig.R = R;
    rig.T = T;
    rig.E = E;
    rig.F = F;
    std::vector<double> worst(index.size());
    for (std::size_t k = 0; k < index.size(); ++k) {
      PairReport& rep = rig.pairs[index[k]];
      rep.rms_left_px = per_view.at<double>(static_cast<int>(k), 0);
      rep.rms_right_px = per_view.at<double>(static_cast<int>(k), 1);
      rep.rms_stereo_px = std::sqrt(0.5 * (rep.rms_left_px * rep.rms_left_px + rep.rms_right_px * rep.rms_right_px));
      worst[k] = rep.rms_stereo_px;
    }
    if (options.reject_factor <= 0 || round >= 3) break;
    if (!RejectWorstPairs(index, worst, options, &rig)) break;
  }
  // The same problem again in Ceres, from OpenCV's answer, for the parameters' covariance.
  RefineStereoBundle(left, right, used_object, options, &rig);
  if (!options.refine_intrinsics) {
    // The intrinsics were held at the per-camera calibrations: their variances come from those.
    for (int c = 0; c < 2; ++c) {
      const cv::Mat& sd = c == 0 ? std_left : std_right;
      for (int i = 0; i < std::min(12, static_cast<int>(sd.total())); ++i) {
        rig.covariance.at<double>(12 * c + i, 12 * c + i) = sd.at<double>(i) * sd.at<double>(i);
      }
    }
  }
  rig.baseline_mm = cv::norm(rig.T);
  const cv::Mat tx = (cv::Mat_<double>(3, 3) << 0, -rig.T.at<double>(2), rig.T.at<double>(1), rig.T.at<double>(2), 0,
                      -rig.T.at<double>(0), -rig.T.at<double>(1), rig.T.at<double>(0), 0);
  rig.E = tx * rig.R;
  rig.F = rig.K2.inv().t() * rig.E * rig.K1.inv();
  cv::stereoRectify(rig.K1, rig.D1, rig.K2, rig.D2, image_size, rig.R, rig.T, rig.R1, rig.R2, rig.P1, rig.P2, rig.Q,
                    cv::CALIB_ZERO_DISPARITY, options.alpha);
  return rig;
}

}  // namespace hedgefit::stereo
