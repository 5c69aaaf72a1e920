#include "around/views.hpp"

#include "cloud/cleaning.hpp"
#include "fitting/methods.hpp"
#include "pipeline/error.hpp"
#include "pipeline/parallel.hpp"
#include "stereo/image_io.hpp"
#include "stereo/outline.hpp"
#include "stereo/rig.hpp"
#include "stereo/stereo_stages.hpp"
#include "measure/outline_start.hpp"

namespace hedgefit::around {

std::vector<PosedCapture> ReadPosedCaptures(const std::string& manifest, const std::string& trajectory,
                                            const std::string& captures_dir, const std::string& rig,
                                            std::vector<std::string>* inputs) {
  std::vector<PosedCapture> captures;
  if (!manifest.empty()) {
    captures = ReadManifest(manifest);
  } else {
    if (captures_dir.empty()) throw InputError("--trajectory: give --captures DIR, the folder of TIME_left.png / TIME_right.png");
    captures = ReadTumCaptures(trajectory, captures_dir);
  }
  const std::string source = manifest.empty() ? trajectory : manifest;
  inputs->push_back(source);
  for (const auto& c : captures) {
    if (c.rig.empty() && rig.empty()) {
      throw InputError(source + ": capture " + c.name + " has no rig: give --rig or a \"rig\" in the manifest");
    }
    stereo::ReadRig(c.rig.empty() ? rig : c.rig);
    stereo::CheckCaptureImages(c.left, c.right);
    inputs->push_back(c.left), inputs->push_back(c.right);
  }
  return captures;
}

View MeasureView(const PosedCapture& capture, const std::string& rig_path, const stereo::ConvertOptions& options) {
  View view;
  view.name = capture.name;
  view.world_from_camera = capture.world_from_camera;
  view.time_s = capture.time_s;
  const std::string rig_file = capture.rig.empty() ? rig_path : capture.rig;
  try {
    const stereo::StereoRig rig = stereo::ReadRig(rig_file);
    const cv::Mat left = stereo::ReadImageFile(capture.left), right = stereo::ReadImageFile(capture.right);
    stereo::ConvertOptions o = options;
    o.mode = stereo::SegmentMode::kGarden;
    const stereo::ConvertResult res = stereo::ConvertCapture(left, right, rig, o);
    const cloud::PointCloud cleaned = cloud::RunFilterStages(res.cloud, cloud::DefaultCleaningJson(), capture.left);
    const cloud::HedgeOutlines outlines =
        measure::MeasureCloudOutlines(res.left_rect, res.right_rect, res.hedge_labels, rig, cleaned, 42, res.ground);
    for (const cloud::HedgeGroup& g : cloud::HedgeGroups(cleaned)) {
      ViewHedge h;
      h.id = g.id;
      h.points_mm = cloud::PointsAt(cleaned, g.indices);
      h.pixel_mm = cloud::FieldAt(cleaned, cloud::kPixelSizeField, g.indices);
      const auto it = outlines.find(g.id);
      if (it != outlines.end()) h.outline = it->second;
      h.fit = fitting::RunFitMethod("envelope", h.points_mm, {}, 42, true, &h.pixel_mm,
                                    h.outline.empty() ? nullptr : &h.outline);
      h.fit.hedge_id = g.id;
      view.hedges.push_back(std::move(h));
    }
    if (view.hedges.empty()) view.failed = "no hedge found";
  } catch (const Error& e) {
    view.failed = e.what();
  }
  return view;
}

std::vector<View> MeasureViews(const std::vector<PosedCapture>& captures, const std::string& rig,
                               const stereo::ConvertOptions& options) {
  std::vector<View> views(captures.size());
  for (std::size_t k = 0; k < captures.size(); ++k) views[k] = MeasureView(captures[k], rig, options);
  return views;
}

}  // namespace hedgefit::around
