#include "bench/render_stamp.hpp"

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>

#include "cloud/cloud_io.hpp"
#include "pipeline/version.hpp"
#include "sim/camera_model.hpp"
#include "sim/povray.hpp"
#include "sim/simulator.hpp"

namespace hedgefit::bench {

namespace fs = std::filesystem;

namespace {

// FNV-1a, 64 bits: a fingerprint, not a defence against anyone.
struct Fnv {
  std::uint64_t h = 14695981039346656037ull;  // the offset basis
  void Add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  void Add(const std::string& s) { Add(s.data(), s.size()); }
  void Add(const cv::Mat& m) {
    for (int y = 0; y < m.rows; ++y) Add(m.ptr(y), m.cols * m.elemSize());
  }
  std::string Hex() const {
    char buf[17];
    std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(h));
    return buf;
  }
};

std::string Fingerprint(const std::string& renderer) {
  Fnv f;
  // The camera model on a fixed gradient: its gains, vignetting, mosaic and noise.
  cv::Mat grad(40, 64, CV_8UC3);
  for (int y = 0; y < grad.rows; ++y) {
    for (int x = 0; x < grad.cols; ++x) {
      grad.at<cv::Vec3b>(y, x) = cv::Vec3b(uchar(4 * x), uchar(6 * y), uchar(2 * (x + y)));
    }
  }
  f.Add(sim::ApplyCameraModel(grad, sim::CameraModel(), true, 3));
  const sim::GardenScene garden = sim::GardenPreset("row");
  if (renderer == "povray") {
    const sim::SimRig rig = sim::PovrayRig(0.05);
    const cv::Size canvas(rig.left.size.width + 8, rig.left.size.height + 8);
    f.Add(sim::PovrayGardenScene(rig, false, garden, canvas));
    f.Add(sim::PovraySphereScene(rig, true, sim::PaperLabSpheres().front(), canvas));
    f.Add(sim::PovrayBoardScene(rig, false, sim::PaperLabBoards().front(), canvas));
  } else {
    const sim::SimRig rig = sim::PaperRig(0.05);
    sim::RenderOptions ro;
    ro.blur_sigma_px = 0.5;
    ro.noise_sigma = 1.0;
    f.Add(sim::RenderGarden(rig, false, garden, ro));
    f.Add(sim::RenderSphere(rig, true, sim::PaperLabSpheres().front(), ro));
    f.Add(sim::RenderBoard(rig, false, sim::PaperLabBoards().front(), ro));
  }
  return f.Hex();
}

std::string StampPath(const std::string& dir, const std::string& set) {
  Fnv f;
  f.Add(set);
  return (fs::path(dir) / (".renders_" + f.Hex() + ".stamp")).string();
}

}  // namespace

std::string RenderStamp(const std::string& renderer, const std::string& options) {
  static std::mutex mutex;
  static std::map<std::string, std::string> fingerprints;
  std::string fp;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = fingerprints.find(renderer);
    if (it == fingerprints.end()) it = fingerprints.emplace(renderer, Fingerprint(renderer)).first;
    fp = it->second;
  }
  return "renderer " + renderer + "; " + options + "; hedgefit " + kVersion + "; fingerprint " + fp;
}

bool StampMatches(const std::string& dir, const std::string& set, const std::string& stamp, bool have_files,
                  const std::string& program) {
  const std::string path = StampPath(dir, set);
  std::ifstream in(path);
  std::string line;
  if (in && std::getline(in, line) && line == stamp) return true;
  if (in || have_files) {
    std::fprintf(stderr, "%s: %s in %s %s; rendering it again\n", program.c_str(), set.c_str(), dir.c_str(),
                 in ? "was rendered by another build or with other options (its stamp differs)"
                    : "has no stamp saying what rendered it");
  }
  return false;
}

void WriteStamp(const std::string& dir, const std::string& set, const std::string& stamp) {
  cloud::WriteTextFileAtomic(StampPath(dir, set), stamp + "\n" + set + "\n");
}

void RemoveStamp(const std::string& dir, const std::string& set) {
  std::error_code ec;
  fs::remove(StampPath(dir, set), ec);
}

}  // namespace hedgefit::bench
