// Calibration speed and accuracy on a rendered lab (16 board pairs at 1920 x 1200, and the 12 of
// `simulate --preset wide-boards` when present, with the
// renderer's truth: rig_truth.json and each board's pose), in one run, with the same thread
// count for all:
//  - stock OpenCV as its tutorial does it: findChessboardCorners (adaptive threshold,
//    normalise) on the full image, cornerSubPix 11 x 11, then calibrateCamera per camera and
//    stereoCalibrate;
//  - OpenCV's sector-based detector findChessboardCornersSB with CALIB_CB_ACCURACY (its own
//    sub-pixel step), the same calibration;
//  - hedgefit calibrate's path: DetectBoards (search on a reduced image, pairs in parallel,
//    blurred cornerSubPix on the full image) and CalibrateFromCorners (+ the Ceres
//    covariance).
// Reported: pairs found, detection and calibration wall time, the corners' RMS error against
// the truth projected through the true rig (pairs all three found), and the calibrated
// parameters' errors: principal points (px), focal lengths (%), baseline (mm).
// Usage: bench_calibrate DIR [--threads N] [--last N]   (boards board_01 .. board_N; default all)   (DIR from `hedgefit bench lab --keep DIR` or
//        `hedgefit simulate --preset lab -o DIR`, or the POV-Ray lab)

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bench/bench_util.hpp"
#include "stereo/calibration.hpp"

namespace {

using namespace hedgefit::stereo;
namespace fs = std::filesystem;

nlohmann::json ReadJson(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw std::runtime_error(p.string() + ": cannot open");
  return nlohmann::json::parse(in);
}

struct Truth {
  cv::Mat K[2], D[2], R, T;
  std::vector<cv::Vec3d> rvec, tvec;  // left_camera_from_board per pair (empty rvec: unknown)
};

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Corners of each pair by a detector; empty vectors where it found none.
using Detector = bool (*)(const cv::Mat&, const cv::Size&, std::vector<cv::Point2f>*);

bool StockClassic(const cv::Mat& grey, const cv::Size& pattern, std::vector<cv::Point2f>* c) {
  if (!cv::findChessboardCorners(grey, pattern, *c, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
    return false;
  }
  cv::cornerSubPix(grey, *c, cv::Size(11, 11), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.01));
  return true;
}

bool StockSB(const cv::Mat& grey, const cv::Size& pattern, std::vector<cv::Point2f>* c) {
  return cv::findChessboardCornersSB(grey, pattern, *c, cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_ACCURACY);
}

std::vector<PairCorners> DetectWith(Detector d, const std::vector<std::pair<std::string, std::string>>& files,
                                    const cv::Size& pattern, int threads) {
  std::vector<PairCorners> out(files.size());
  cv::parallel_for_(cv::Range(0, int(files.size())), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) {
      PairCorners& pc = out[std::size_t(i)];
      pc.left = files[std::size_t(i)].first;
      pc.right = files[std::size_t(i)].second;
      const cv::Mat l = cv::imread(pc.left, cv::IMREAD_GRAYSCALE), rr = cv::imread(pc.right, cv::IMREAD_GRAYSCALE);
      if (!d(l, pattern, &pc.left_px) || !d(rr, pattern, &pc.right_px)) {
        pc.left_px.clear();
        pc.right_px.clear();
        pc.status = "not found";
      }
    }
  }, threads);
  return out;
}

struct Row {
  std::string name;
  double detect_s = 0, calibrate_s = 0;
  int found = 0;
  std::vector<PairCorners> corners;
  StereoRig rig;
};

}  // namespace

namespace {

// The simulated rig's truth and every board pair with a truth file (the lab's 16, and the
// wide-boards preset's 17..28 if present), up to board `last`.
Truth ReadTruth(const fs::path& dir, int last, std::vector<std::pair<std::string, std::string>>* files, BoardSpec* spec_out) {
  BoardSpec& spec = *spec_out;
  Truth truth;
  const auto rt = ReadJson(dir / "rig_truth.json");
  for (int c = 0; c < 2; ++c) {
    const auto& cam = rt[c == 0 ? "left" : "right"];
    truth.K[c] = cv::Mat::eye(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) truth.K[c].at<double>(r, k) = cam["K"][r][k].get<double>();
    }
    truth.D[c] = cv::Mat(1, 5, CV_64F);
    for (int k = 0; k < 5; ++k) truth.D[c].at<double>(k) = cam["dist"][k].get<double>();
  }
  truth.R = cv::Mat(3, 3, CV_64F);
  truth.T = cv::Mat(3, 1, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) truth.R.at<double>(r, k) = rt["R"][r][k].get<double>();
    truth.T.at<double>(r) = rt["T"][r].get<double>();
  }
  // Every board pair with a truth file: the lab's 16, and the wide-boards preset's 17..28 if present.
  for (int i = 1; i <= last; ++i) {
    char base[32];
    std::snprintf(base, sizeof(base), "board_%02d", i);
    if (!fs::exists(dir / (std::string(base) + ".truth.json"))) continue;
    files->emplace_back((dir / (std::string(base) + "_left.png")).string(),
                       (dir / (std::string(base) + "_right.png")).string());
    const auto bt = ReadJson(dir / (std::string(base) + ".truth.json"));
    spec.inner_corners = cv::Size(bt["inner_corners"][0].get<int>(), bt["inner_corners"][1].get<int>());
    spec.square_mm = bt["square_mm"].get<double>();
    cv::Matx33d rot;
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) rot(r, k) = bt["rotation"][r][k].get<double>();
    }
    cv::Vec3d rvec;
    cv::Rodrigues(rot, rvec);
    truth.rvec.push_back(rvec);
    truth.tvec.emplace_back(bt["translation_mm"][0].get<double>(), bt["translation_mm"][1].get<double>(),
                            bt["translation_mm"][2].get<double>());
  }
  return truth;
}

// RMS corner error of `row` against the truth, over the pairs every detector found.
double CornerRms(const Row& row, const std::vector<Row>& rows, const Truth& truth, const std::vector<cv::Point3f>& board,
                 std::size_t pairs) {
  double sum = 0;
  long n = 0;
  for (std::size_t i = 0; i < pairs; ++i) {
    bool all = true;
    for (const Row& o : rows) all = all && o.corners[i].status.empty();
    if (!all) continue;
    std::vector<cv::Point2f> pl, pr;
    cv::projectPoints(board, truth.rvec[i], truth.tvec[i], truth.K[0], truth.D[0], pl);
    cv::Mat Rb;
    cv::Rodrigues(truth.rvec[i], Rb);
    cv::Mat Rr = truth.R * Rb, tr = truth.R * cv::Mat(truth.tvec[i]) + truth.T, rr;
    cv::Rodrigues(Rr, rr);
    cv::projectPoints(board, rr, tr, truth.K[1], truth.D[1], pr);
    // A board with an odd number of inner corners one way and an even number the other has
    // a 180-degree ambiguity the detectors resolve arbitrarily: compare in the closer order.
    for (int view = 0; view < 2; ++view) {
      const std::vector<cv::Point2f>& found = view == 0 ? row.corners[i].left_px : row.corners[i].right_px;
      const std::vector<cv::Point2f>& want = view == 0 ? pl : pr;
      double same = 0, reversed = 0;
      const std::size_t m = want.size();
      for (std::size_t k = 0; k < m; ++k) {
        const cv::Point2f a = found[k] - want[k], b = found[m - 1 - k] - want[k];
        same += a.dot(a);
        reversed += b.dot(b);
      }
      sum += std::min(same, reversed);
      n += long(m);
    }
  }
  return n ? std::sqrt(sum / double(n)) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  const char* usage = "DIR [--threads N] [--last N]";
  fs::path dir;
  int threads = 2, last = 99;
  const int done = hedgefit::bench::ParseOptions(
      argc, argv, "bench_calibrate", usage,
      [&](const std::string& a, const char* v) {
        if (a == "--threads") threads = std::max(1, std::atoi(v));
        else if (a == "--last") last = std::atoi(v);
        else return false;
        return true;
      },
      [&](const std::string& a) {
        if (a.empty() || a[0] == '-' || !dir.empty()) return false;
        dir = a;
        return true;
      });
  if (done >= 0) return done;
  if (dir.empty()) {
    std::fprintf(stderr, "bench_calibrate: no DIR given\nusage: bench_calibrate %s\n", usage);
    return 2;
  }
  cv::setNumThreads(threads);
  try {
    std::vector<std::pair<std::string, std::string>> files;
    BoardSpec spec;
    const Truth truth = ReadTruth(dir, last, &files, &spec);
    if (files.size() < 3) {
      std::fprintf(stderr,
                   "bench_calibrate: %s: %zu board pairs with a truth file (board_01 .. board_%02d); calibrating needs at "
                   "least 3: render the lab's boards there first (hedgefit simulate --preset paper-lab -o DIR)\n",
                   dir.string().c_str(), files.size(), last);
      return 2;
    }
    CalibrationOptions co;
    co.board = spec;
    std::vector<Row> rows;
    for (const char* name : {"stock OpenCV (classic + cornerSubPix)", "OpenCV SB (ACCURACY)", "hedgefit"}) {
      Row row;
      row.name = name;
      const auto t0 = std::chrono::steady_clock::now();
      cv::Size size;
      if (row.name == "hedgefit") {
        row.corners = DetectBoards(files, spec, &size, nullptr, threads);
      } else {
        row.corners = DetectWith(row.name.rfind("stock", 0) == 0 ? StockClassic : StockSB, files, spec.inner_corners,
                                 threads);
        size = cv::imread(files[0].first, cv::IMREAD_GRAYSCALE).size();
      }
      row.detect_s = Seconds(t0);
      for (const auto& c : row.corners) row.found += c.status.empty();
      const auto t1 = std::chrono::steady_clock::now();
      row.rig = CalibrateFromCorners(row.corners, size, co);
      row.calibrate_s = Seconds(t1);
      rows.push_back(std::move(row));
      std::fprintf(stderr, "%s done\n", name);
    }
    // Corner error against the truth, on the pairs every detector found.
    const std::vector<cv::Point3f> board = BoardCorners(spec);
    std::printf("bench_calibrate %s, %d thread(s)\n", dir.string().c_str(), threads);
    std::printf("  %-38s %5s %9s %9s %10s %9s %9s %9s %9s %8s %9s\n", "detector", "pairs", "detect s", "calib s",
                "corner rms", "dcx1 px", "dcy1 px", "dcx2 px", "dcy2 px", "dfx %", "dB mm");
    for (const Row& row : rows) {
      const double rms = CornerRms(row, rows, truth, board, files.size());
      const StereoRig& r = row.rig;
      const double dfx = 100 * std::max(std::abs(r.K1.at<double>(0, 0) / truth.K[0].at<double>(0, 0) - 1),
                                        std::abs(r.K2.at<double>(0, 0) / truth.K[1].at<double>(0, 0) - 1));
      std::printf("  %-38s %5d %9.1f %9.2f %10.4f %+9.3f %+9.3f %+9.3f %+9.3f %8.4f %+9.4f\n", row.name.c_str(), row.found,
                  row.detect_s, row.calibrate_s, rms,
                  r.K1.at<double>(0, 2) - truth.K[0].at<double>(0, 2), r.K1.at<double>(1, 2) - truth.K[0].at<double>(1, 2),
                  r.K2.at<double>(0, 2) - truth.K[1].at<double>(0, 2), r.K2.at<double>(1, 2) - truth.K[1].at<double>(1, 2),
                  dfx, r.baseline_mm - cv::norm(truth.T));
    }
    const std::vector<double> sd = RigStdDevs(rows.back().rig);
    if (!sd.empty()) {
      std::printf("  hedgefit's stated standard deviations: cx1 %.3f cy1 %.3f cx2 %.3f cy2 %.3f px, fx1 %.4f %%, "
                  "baseline %.4f mm\n",
                  sd[2], sd[3], sd[14], sd[15], 100 * sd[0] / rows.back().rig.K1.at<double>(0, 0),
                  BaselineStdDev(rows.back().rig));
    }
    std::printf("  speed-up of hedgefit over stock OpenCV (detection + calibration): %.1fx\n",
                (rows[0].detect_s + rows[0].calibrate_s) / (rows[2].detect_s + rows[2].calibrate_s));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_calibrate: %s\n", e.what());
    return 1;
  }
  return 0;
}
