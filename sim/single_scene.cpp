#include "sim/single_scene.hpp"

#include <opencv2/calib3d.hpp>

#include <filesystem>

#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "stereo/calibration.hpp"
#include "stereo/image_io.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::sim {

namespace fs = std::filesystem;

namespace {

// The pair `stem`_left.png / _right.png, the truth written by `write_truth`, the rig's truth and
// the exact rig file.
template <class Render, class WriteTruth>
std::vector<std::string> WriteCapture(const std::string& dir, const std::string& stem, const SimRig& rig,
                                      Render render, WriteTruth write_truth, const CameraModel& camera, bool record,
                                      std::uint64_t seed) {
  const std::string left = (fs::path(dir) / (stem + "_left.png")).string();
  const std::string right = (fs::path(dir) / (stem + "_right.png")).string();
  const std::string truth = (fs::path(dir) / (stem + ".truth.json")).string();
  stereo::WriteImageAtomic(left, render(false));
  stereo::WriteImageAtomic(right, render(true));
  if (record) RecordAsCamera({left, right}, camera, seed);
  write_truth(truth);
  const std::string rig_truth = (fs::path(dir) / "rig_truth.json").string();
  const std::string rig_file = (fs::path(dir) / "rig.yaml").string();
  cloud::WriteTextFileAtomic(rig_truth, RigJson(rig) + "\n");
  stereo::WriteRig(rig_file, RigFromSimulation(rig));
  return {left, right, truth, rig_truth, rig_file};
}

}  // namespace

void RecordAsCamera(const std::vector<std::string>& files, const CameraModel& camera, std::uint64_t seed) {
  std::uint64_t view = 0;
  for (const auto& f : files) {
    const bool left = f.find("_left.png") != std::string::npos, right = f.find("_right.png") != std::string::npos;
    if (!left && !right) continue;
    stereo::WriteImageAtomic(f, ApplyCameraModel(stereo::ReadImageFile(f), camera, right, seed * 1000 + view++ / 2));
  }
}

BoardScene PosedBoard(const std::vector<double>& v, cv::Size squares, double square_mm,
                      const std::string& charuco_dictionary, double marker_mm) {
  if (v.size() != 6) throw Error("a board's pose is RX,RY,RZ (rad),TX,TY,TZ (mm)");
  BoardScene b;
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(v[0], v[1], v[2]), R);
  b.rotation = R;
  b.translation = cv::Vec3d(v[3], v[4], v[5]);
  b.squares = squares;
  b.square_mm = square_mm;
  if (!charuco_dictionary.empty()) {
    stereo::BoardSpec spec;
    spec.type = stereo::BoardType::kCharuco;
    spec.inner_corners = cv::Size(squares.width - 1, squares.height - 1);
    spec.square_mm = square_mm;
    spec.marker_mm = marker_mm;
    spec.dictionary = charuco_dictionary;
    stereo::CalibrationOptions probe;
    probe.board = spec;
    probe.Check();
    b.texture = stereo::CharucoImage(spec, 64);
  }
  return b;
}

std::vector<std::string> WriteSphereCapture(const std::string& dir, const SimRig& rig, const SphereScene& scene,
                                            const RenderOptions& options, const CameraModel& camera, bool record,
                                            std::uint64_t seed) {
  return WriteCapture(
      dir, "sphere", rig, [&](bool right) { return RenderSphere(rig, right, scene, options); },
      [&](const std::string& path) { WriteSphereTruth(path, scene); }, camera, record, seed);
}

std::vector<std::string> WriteBoardCapture(const std::string& dir, const SimRig& rig, const BoardScene& board,
                                           const RenderOptions& options, const CameraModel& camera, bool record,
                                           std::uint64_t seed) {
  return WriteCapture(
      dir, "board", rig, [&](bool right) { return RenderBoard(rig, right, board, options); },
      [&](const std::string& path) { WriteBoardTruth(path, board); }, camera, record, seed);
}

}  // namespace hedgefit::sim
