#include "measure/capture_batch.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "cloud/point_cloud.hpp"
#include "pipeline/error.hpp"
#include "pipeline/input_check.hpp"
#include "pipeline/parallel.hpp"
#include "pipeline/registry.hpp"
#include "measure/recipes.hpp"
#include "stereo/capture.hpp"
#include "stereo/image_io.hpp"
#include "stereo/segmentation.hpp"

namespace hedgefit::measure {

namespace fs = std::filesystem;
using stereo::ColorizeDisparity;
using stereo::ConvertOptions;
using stereo::HedgeRegion;
using stereo::MaskOverlay;
using stereo::WriteImageAtomic;

namespace {

// A directory's NAME_left.* files, each with its NAME_right.* beside it.
std::vector<CaptureFiles> DirectoryCaptures(const std::string& dir) {
  std::vector<std::string> lefts;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().filename().string().rfind("_left.") != std::string::npos) lefts.push_back(e.path().string());
  }
  std::sort(lefts.begin(), lefts.end());
  std::vector<CaptureFiles> out;
  for (const auto& l : lefts) {
    const std::string f = fs::path(l).filename().string();
    const auto pos = f.rfind("_left.");
    const std::string r = (fs::path(l).parent_path() / (f.substr(0, pos) + "_right." + f.substr(pos + 6))).string();
    out.push_back({f.substr(0, pos), l, r});
  }
  if (out.empty()) throw Error(dir + ": no NAME_left.png / NAME_right.png pairs in this directory");
  return out;
}

}  // namespace

std::vector<CaptureFiles> ListCaptures(const std::string& input) {
  std::error_code ec;
  if (fs::is_directory(input, ec)) return DirectoryCaptures(input);
  std::ifstream in(input);
  if (!in) throw Error(input + ": no such manifest or directory");
  std::vector<CaptureFiles> out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    std::istringstream ss(line);
    CaptureFiles c;
    if (!(ss >> c.left) || c.left[0] == '#') continue;
    if (!(ss >> c.right)) throw Error(input + ":" + std::to_string(n) + ": expected 'LEFT RIGHT [NAME]'");
    if (!(ss >> c.name)) c.name = fs::path(c.left).stem().string();
    out.push_back(c);
  }
  if (out.empty()) throw Error(input + ": the manifest lists no captures");
  return out;
}

std::vector<CaptureFiles> Shard(const std::vector<CaptureFiles>& captures, const std::string& shard) {
  int i = -1, n = 0;
  char slash = 0;
  std::istringstream ss(shard);
  if (!(ss >> i >> slash >> n) || slash != '/' || n < 1 || i < 0 || i >= n || !ss.eof()) {
    throw Error("--shard '" + shard + "': give i/n with 0 <= i < n, e.g. 0/4");
  }
  std::vector<CaptureFiles> mine;
  for (std::size_t k = 0; k < captures.size(); ++k) {
    if (int(k % std::size_t(n)) == i) mine.push_back(captures[k]);
  }
  return mine;
}

std::string PerHedgePath(const std::string& path, bool several) {
  if (!several || path.find('#') != std::string::npos) return path;
  const fs::path p(path);
  return (p.parent_path() / (p.stem().string() + "_#" + p.extension().string())).string();
}

std::string HedgePath(const std::string& path, int id) {
  std::string file = path;
  if (const auto hash = file.rfind('#'); hash != std::string::npos) file.replace(hash, 1, std::to_string(id));
  return file;
}

std::string StemWithoutHedgeMark(const std::string& path) {
  std::string stem = fs::path(path).stem().string();  // "row_#" -> "row"
  if (const auto hash = stem.rfind('#'); hash != std::string::npos) {
    const bool sep = hash > 0 && (stem[hash - 1] == '_' || stem[hash - 1] == '-');
    stem.erase(sep ? hash - 1 : hash, sep ? 2 : 1);
  }
  return stem;
}

namespace {

// The coloured disparity with its scale beside it: a TURBO bar from the smallest to the largest
// disparity, labelled in px, so the picture says what its colours mean.
cv::Mat DisparityWithScale(const cv::Mat& disparity) {
  const cv::Mat colour = ColorizeDisparity(disparity);
  double lo = 0, hi = 1;
  cv::minMaxLoc(disparity, &lo, &hi, nullptr, nullptr, disparity == disparity);
  const int bar_w = 24, pad = 12, text_w = 120;
  cv::Mat out(colour.rows, colour.cols + pad + bar_w + text_w, CV_8UC3, cv::Scalar(255, 255, 255));
  colour.copyTo(out(cv::Rect(0, 0, colour.cols, colour.rows)));
  const int top = 48, bottom = colour.rows - 24, x0 = colour.cols + pad;
  if (bottom - top < 20) return colour;  // too small a picture for a scale
  cv::Mat ramp(bottom - top, 1, CV_8U);
  for (int y = 0; y < ramp.rows; ++y) ramp.at<std::uint8_t>(y) = cv::saturate_cast<std::uint8_t>(255 - 255 * y / (ramp.rows - 1));
  cv::Mat ramp_colour;
  cv::applyColorMap(ramp, ramp_colour, cv::COLORMAP_TURBO);
  cv::resize(ramp_colour, out(cv::Rect(x0, top, bar_w, bottom - top)), cv::Size(bar_w, bottom - top), 0, 0,
             cv::INTER_NEAREST);
  const double font = 0.6;  // Hershey simplex: capitals 14 px tall
  const cv::Scalar ink(0, 0, 0);
  cv::putText(out, "disparity (px)", cv::Point(colour.cols + pad - 4, 24), cv::FONT_HERSHEY_SIMPLEX, font, ink, 1,
              cv::LINE_AA);
  char label[32];
  for (int k = 0; k <= 4; ++k) {
    const double v = hi - (hi - lo) * k / 4.0;
    const int y = top + (bottom - top - 1) * k / 4;
    std::snprintf(label, sizeof(label), "%.1f", v);
    cv::line(out, cv::Point(x0 + bar_w, y), cv::Point(x0 + bar_w + 5, y), ink, 1);
    cv::putText(out, label, cv::Point(x0 + bar_w + 8, y + 6), cv::FONT_HERSHEY_SIMPLEX, font, ink, 1, cv::LINE_AA);
  }
  return out;
}

}  // namespace

void WriteDebugPictures(const std::string& base, pipeline::Context& ctx) {
  const cv::Mat& left_rect = ctx.Get<cv::Mat>("left_image");
  cv::Mat pair;
  cv::hconcat(left_rect, ctx.Get<cv::Mat>("right_image"), pair);
  WriteImageAtomic(base + "_rectified.png", pair);
  WriteImageAtomic(base + "_mask.png", MaskOverlay(left_rect, ctx.Get<cv::Mat>("mask")));
  WriteImageAtomic(base + "_disparity.png", DisparityWithScale(ctx.Get<cv::Mat>("disparity")));
}

std::string CaptureSummary(const std::string& name, const std::string& out, pipeline::Context& ctx,
                           const pipeline::RunReport& report) {
  const cloud::PointCloud& cloud = ctx.Get<cloud::PointCloud>("cloud");
  const cv::Mat& left_rect = ctx.Get<cv::Mat>("left_image");
  const int* area = ctx.Find<int>("matched_area");
  const cv::Rect* region = ctx.Find<cv::Rect>("matched_region");
  const double matched =
      double(area ? *area : (region ? region->area() : int(left_rect.total()))) / double(left_rect.total());
  char buf[512];
  std::snprintf(buf, sizeof(buf), "%-24s %8zu points %7.0f ms  matched %.1f%% of the frame  -> %s", name.c_str(),
                cloud.size() - cloud::CountNonFinite(cloud), report.total_ms, 100 * matched, out.c_str());
  std::string line = buf;
  const auto* hedges = ctx.Find<std::vector<HedgeRegion>>("hedges");
  if (!hedges) return line;
  const auto groups = cloud::HedgeGroups(cloud);
  for (const auto& h : *hedges) {
    std::size_t n = 0;
    for (const auto& g : groups) n = g.id == h.id ? g.indices.size() : n;
    // Without a '#' (the default segmentation found hedges by depth) they share one file, told
    // apart by its hedge_id field.
    std::snprintf(buf, sizeof(buf), "\n    hedge %d: box %d,%d,%d,%d px, about r %.0f mm at %.2f m%s, %zu points -> %s",
                  h.id, h.image_box.x, h.image_box.y, h.image_box.width, h.image_box.height, h.approx_radius_mm,
                  h.approx_center_mm[2] / 1000, h.touches_border ? " (cut by the frame)" : "", n,
                  HedgePath(out, h.id).c_str());
    line += buf;
  }
  return line;
}

std::string CaptureHint(pipeline::Context& ctx) {
  std::string hint;
  char buf[256];
  const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
  if (!ctx.Find<std::vector<HedgeRegion>>("hedges") && !ctx.Find<bool>("mask_given") && mask && !mask->empty()) {
    const double share = double(cv::countNonZero(*mask)) / double(mask->total());
    if (share > 0.5) {
      std::snprintf(buf, sizeof(buf),
                    "the colour mask covers %.0f%% of the frame (a lawn, a hedge row or trees are green too); in a "
                    "garden, --garden finds every hedge by depth",
                    100 * share);
      hint = buf;
      // The default searched by depth and found nothing: say so and why (a pair swapped left for
      // right, or a wrong rig, matches nothing in the working range).
      if (const auto* why = ctx.Find<std::string>("depth_segmentation_failed")) {
        std::snprintf(buf, sizeof(buf),
                      "the colour mask covers %.0f%% of the frame (a lawn, a hedge row or trees are green too) and the "
                      "search by depth found no hedge; check --min-z/--max-z and that left and right are not swapped",
                      100 * share);
        hint = std::string(buf) + " (" + *why + ")";
      }
    }
  }
  auto add = [&hint](const std::string& text) { hint += (hint.empty() ? "" : "; ") + text; };
  if (const auto* checks = ctx.Find<pipeline::InputChecks>("input_checks")) {
    // One message per text: "hedge 1, 2: ..." or, when every hedge shares it, the text alone.
    std::vector<std::pair<std::string, std::vector<int>>> said;
    for (const auto& [id, check] : *checks) {
      const std::string text = !check.unusable.empty() ? "unusable: " + check.unusable : check.warning;
      if (text.empty()) continue;
      auto it = std::find_if(said.begin(), said.end(), [&](const auto& s) { return s.first == text; });
      if (it == said.end()) said.push_back({text, {id}});
      else it->second.push_back(id);
    }
    for (const auto& [text, ids] : said) {
      if (ids.size() == checks->size() || (ids.size() == 1 && ids[0] == 0)) {
        add(text);
        continue;
      }
      std::string who = "hedge";
      for (std::size_t k = 0; k < ids.size(); ++k) who += (k ? ", " : " ") + std::to_string(ids[k]);
      add(who + ": " + text);
    }
  } else if (const double* rows = ctx.Find<double>("vertical_disparity_px"); rows && *rows > 0.5) {
    std::snprintf(buf, sizeof(buf),
                  "the rectified rows disagree by up to %.2f px: the rig file is not these cameras', or they moved "
                  "since calibration; recalibrate (hedgefit calibrate)",
                  *rows);
    add(buf);
  }
  return hint;
}

bool CaptureUnusable(pipeline::Context& ctx) {
  const auto* checks = ctx.Find<pipeline::InputChecks>("input_checks");
  if (!checks) return false;
  return std::any_of(checks->begin(), checks->end(), [](const auto& c) { return !c.second.unusable.empty(); });
}

std::string CaptureUnchecked(pipeline::Context& ctx) {
  const auto* checks = ctx.Find<pipeline::InputChecks>("input_checks");
  if (!checks) return "";
  for (const auto& [id, check] : *checks) {
    bool unchecked = false;
    std::string why = "the rig could not be checked against this capture";
    for (const auto& [key, value] : check.fields) {
      const std::string* text = std::get_if<std::string>(&value);
      if (!text) continue;
      if (key == "rig_check" && *text == "unchecked") unchecked = true;
      if (key == "rig_check_reason") why = "the rig could not be checked against this capture: " + *text;
    }
    if (unchecked) return why;
  }
  return "";
}

void ConvertCaptures(const ConvertOptions& o, const std::vector<CaptureFiles>& captures, const std::string& rig,
                     const std::function<std::string(const CaptureFiles&)>& output_of, bool debug, int threads,
                     const std::function<void(const CaptureOutcome&)>& done) {
  std::mutex report;
  pipeline::ParallelFor(captures.size(), threads, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) {
      CaptureOutcome c;
      c.capture = &captures[k];
      c.output = output_of(captures[k]);
      try {
        pipeline::Pipeline p = pipeline::Pipeline::FromJson(
            ConvertPipelineJson(o, captures[k].left, captures[k].right, rig, c.output), "convert",
            pipeline::Registry::Global());
        pipeline::Context ctx;
        ctx.quiet = true;
        const pipeline::RunReport run = p.Run(ctx);
        if (debug) WriteDebugPictures((fs::path(c.output).parent_path() / StemWithoutHedgeMark(c.output)).string(), ctx);
        c.summary = CaptureSummary(captures[k].name, c.output, ctx, run);
        c.hint = CaptureHint(ctx);
        c.unusable = CaptureUnusable(ctx);
      } catch (const std::exception& ex) {
        c.error = ex.what();
        c.input_error = dynamic_cast<const InputError*>(&ex) != nullptr;
      }
      std::lock_guard<std::mutex> lock(report);
      done(c);
    }
  });
}

}  // namespace hedgefit::measure
