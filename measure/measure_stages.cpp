// The measuring layer's stages: each hedge's outline about its envelope fitted to the cloud
// (stereo.outline, for fitters.envelope) and written beside a saved cloud (writers.outline).

#include "measure/measure_stages.hpp"

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "cloud/cleaning.hpp"
#include "cloud/outline_io.hpp"
#include "cloud/point_cloud.hpp"
#include "measure/outline_start.hpp"
#include "pipeline/error.hpp"
#include "pipeline/stage.hpp"
#include "stereo/rig.hpp"

namespace hedgefit::measure {

namespace {

using pipeline::Context;
using pipeline::Options;
using pipeline::StageInfo;

// Each hedge's outline in the context's rectified views about `cloud`'s hedges (stereo.outline,
// writers.outline), with the segmentation's labels and ground plane where it left them.
cloud::HedgeOutlines OutlinesOf(Context& ctx, const cloud::PointCloud& cloud,
                                std::map<int, stereo::OutlineStats>* stats = nullptr) {
  const cv::Mat* labels = ctx.Find<cv::Mat>("hedge_labels");
  const cv::Vec4d* ground = ctx.Find<cv::Vec4d>("ground_plane");
  return MeasureCloudOutlines(ctx.Get<cv::Mat>("left_image"), ctx.Get<cv::Mat>("right_image"),
                              labels ? *labels : cv::Mat(), ctx.Get<stereo::StereoRig>("rig"), cloud, ctx.seed,
                              ground ? std::optional<cv::Vec4d>(*ground) : std::nullopt, stats);
}

// stereo.outline: each hedge's outline in both views, about its envelope fitted to the cloud's
// points, for fitters.envelope (after the cleaning: the start fit sees the points the fits will).
void AddOutline(pipeline::Registry& r) {
  r.Add(StageInfo{"stereo.outline",
                  "Each hedge's outline in both rectified views, to a fraction of a pixel, as rays grazing its "
                  "envelope: fitters.envelope fits them with the front's points",
                  {}, {"cloud", "left_image", "right_image", "rig"}, {"outlines"}, {}},
        [](const Options& o) -> std::unique_ptr<pipeline::Stage> {
          return std::make_unique<pipeline::LambdaStage>(o, [](const Options&, Context& ctx) {
            std::map<int, stereo::OutlineStats> stats;
            cloud::HedgeOutlines outlines = OutlinesOf(ctx, ctx.Get<cloud::PointCloud>("cloud"), &stats);
            std::int64_t left = 0, right = 0;
            for (const auto& [id, st] : stats) left += std::int64_t(st.left), right += std::int64_t(st.right);
            ctx.Note("outline_left", left);
            ctx.Note("outline_right", right);
            ctx.Put("outlines", std::move(outlines));
          });
        });
}

// writers.outline: each hedge's outline measured as `measure` measures it (about the cloud as
// compare cleans it by default) and written beside the cloud, so that `compare` on the saved cloud
// fits the envelope `measure` fits. The context's cloud is left as it was.
void AddOutlineWriter(pipeline::Registry& r) {
  StageInfo info{"writers.outline",
                 "Writes each hedge's outline rays (stereo.outline, about the cloud cleaned as compare cleans it) "
                 "as JSON beside the cloud (CLOUD.outline.json), so compare's envelope on the saved cloud is "
                 "measure's",
                 {pipeline::StringOption("filename", "",
                                         "file to write (convert: the cloud's name + .outline.json); a '#' in it writes "
                                         "one file per hedge")},
                 {"cloud", "left_image", "right_image", "rig"}, {}, {".json"}};
  r.Add(info, [](const Options& o) -> std::unique_ptr<pipeline::Stage> {
    return std::make_unique<pipeline::LambdaStage>(o, [](const Options& opts, Context& ctx) {
      const std::string file = opts.GetString("filename");
      if (file.empty()) throw Error("stage 'writers.outline', option 'filename': give the file to write");
      const cloud::PointCloud cleaned =
          cloud::RunFilterStages(ctx.Get<cloud::PointCloud>("cloud"), cloud::DefaultCleaningJson(), "writers.outline");
      const cloud::HedgeOutlines outlines = OutlinesOf(ctx, cleaned);
      // One file per hedge where the clouds are one per hedge ('#' in the name, as the writers':
      // each holds its hedge's finite points).
      const cloud::PointCloud& written = ctx.Get<cloud::PointCloud>("cloud");
      if (const auto hash = file.rfind('#'); hash != std::string::npos) {
        for (const cloud::HedgeGroup& g : cloud::HedgeGroups(written)) {
          std::string one = file;
          one.replace(hash, 1, std::to_string(g.id));
          const auto it = outlines.find(g.id);
          cloud::HedgeOutlines own;
          if (it != outlines.end()) own[g.id] = it->second;
          cloud::WriteOutlines(ctx.OutputPath(one), own, g.indices.size());
        }
      } else {
        cloud::WriteOutlines(ctx.OutputPath(file), outlines, written.size());
      }
      std::int64_t rays = 0;
      for (const auto& [id, hedge_rays] : outlines) rays += std::int64_t(hedge_rays.size());
      ctx.Note("rays", rays);
    });
  });
}

}  // namespace

void RegisterMeasureStages(pipeline::Registry& r) {
  AddOutline(r);
  AddOutlineWriter(r);
}

}  // namespace hedgefit::measure
