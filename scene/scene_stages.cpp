#include "scene/scene_stages.hpp"

#include "cloud/describe.hpp"
#include "cloud/point_cloud.hpp"
#include "pipeline/error.hpp"
#include "pipeline/print.hpp"
#include "scene/finder.hpp"

namespace hedgefit::scene {

void RegisterSceneStages(pipeline::Registry& r) {
  r.Add(pipeline::StageInfo{"segment.hedges",
                            "Finds the ground, the objects on it and every hedge ball in any cloud (LiDAR, photogrammetry, "
                            "a map, a capture): hedge_id per ball, object_id, ground",
                            pipeline::TableOptions<FindOptions>(
                                {pipeline::IntOption("seed", -1, "sampler seed; -1 = the pipeline's --seed").Min(-1),
                                 pipeline::ListOption("viewpoints", {}, 0,
                                                      "where the sensor stood, x,y,z for each station in the cloud's frame "
                                                      "(mm, as read: after the reader's scale); none: a PCD's VIEWPOINT "
                                                      "when the reader found one, else the origin of a spinning LiDAR's scan in its own frame (its rings), else the cloud is judged as seen from above",
                                                      "mm")}),
                            {"cloud"},
                            {"cloud"},
                            {}},
        pipeline::TableFactory<FindOptions>("segment.hedges", [](const FindOptions& p, const pipeline::Options& o,
                                                                 pipeline::Context& ctx) {
          FindOptions run = p;
          const std::int64_t seed = o.GetInt("seed");
          run.seed = seed >= 0 ? static_cast<std::uint64_t>(seed) : ctx.seed;
          cloud::PointCloud& cloud = ctx.Get<cloud::PointCloud>("cloud");
          const std::vector<double>& at = o.GetList("viewpoints");
          if (at.size() % 3 != 0) {
            throw Error(pipeline::Format("stage 'segment.hedges', option 'viewpoints': %zu numbers is not x,y,z per "
                                         "station; give three for each place the sensor stood",
                                         at.size()));
          }
          // Given in the cloud's frame as read; the finder takes them in the frame of the points
          // it holds, which a reader may have shifted (a survey's large coordinates).
          for (std::size_t k = 0; k < at.size(); k += 3) {
            run.viewpoints_mm.push_back(Eigen::Vector3d(at[k], at[k + 1], at[k + 2]) - cloud.offset);
          }
          if (run.viewpoints_mm.empty()) {
            if (const auto* v = ctx.Find<Eigen::Vector3d>("viewpoint")) run.viewpoints_mm.push_back(*v);
          }
          // A spinning LiDAR's scan in its own frame stood at its origin, as `find` reads it.
          if (run.viewpoints_mm.empty() && cloud::ScannerRings(cloud) > 0) run.viewpoints_mm.push_back(-cloud.offset);
          ctx.Note("viewpoints", static_cast<std::int64_t>(run.viewpoints_mm.size()));
          const FindResult found = FindHedges(cloud, run);
          cloud = LabelCloud(cloud, found);
          ctx.Note("balls", static_cast<std::int64_t>(found.Balls()));
          ctx.Note("topiary", static_cast<std::int64_t>(found.Topiary()));
          ctx.Note("objects", static_cast<std::int64_t>(found.objects.size()));
          ctx.Note("ground_points", static_cast<std::int64_t>(found.ground_points));
        }));
}

}  // namespace hedgefit::scene
