#include "scene/scene_stages.hpp"

#include "cloud/point_cloud.hpp"
#include "scene/finder.hpp"

namespace hedgefit::scene {

void RegisterSceneStages(pipeline::Registry& r) {
  r.Add(pipeline::StageInfo{"segment.hedges",
                            "Finds the ground, the objects on it and every hedge ball in any cloud (LiDAR, photogrammetry, "
                            "a map, a capture): hedge_id per ball, object_id, ground",
                            pipeline::TableOptions<FindOptions>(
                                {pipeline::IntOption("seed", -1, "sampler seed; -1 = the pipeline's --seed").Min(-1)}),
                            {"cloud"},
                            {"cloud"},
                            {}},
        pipeline::TableFactory<FindOptions>("segment.hedges", [](const FindOptions& p, const pipeline::Options& o,
                                                                 pipeline::Context& ctx) {
          FindOptions run = p;
          const std::int64_t seed = o.GetInt("seed");
          run.seed = seed >= 0 ? static_cast<std::uint64_t>(seed) : ctx.seed;
          cloud::PointCloud& cloud = ctx.Get<cloud::PointCloud>("cloud");
          const FindResult found = FindHedges(cloud, run);
          cloud = LabelCloud(cloud, found);
          ctx.Note("balls", static_cast<std::int64_t>(found.Balls()));
          ctx.Note("topiary", static_cast<std::int64_t>(found.Topiary()));
          ctx.Note("objects", static_cast<std::int64_t>(found.objects.size()));
          ctx.Note("ground_points", static_cast<std::int64_t>(found.ground_points));
        }));
}

}  // namespace hedgefit::scene
