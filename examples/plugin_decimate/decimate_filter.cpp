// An example out-of-tree hedgefit plugin: filters.decimate keeps every n-th point.
// Build it against an installed hedgefit (see CMakeLists.txt beside this file), put
// the .so in a directory on HEDGEFIT_PLUGIN_PATH, and `hedgefit plugins` lists it.

#include <cstdint>
#include <vector>

#include "pipeline/plugin.hpp"
#include "cloud/point_cloud.hpp"

namespace {

using namespace hedgefit::cloud;
using namespace hedgefit::pipeline;

void RegisterDecimate(Registry& registry) {
  StageInfo info{"filters.decimate",
                 "Keeps every step-th point (example plugin)",
                 {IntOption("step", 2, "keep one point in this many", "points").Range(1, 1000000)},
                 {"cloud"},
                 {"cloud"},
                 {}};
  registry.Add(info, MakeFactory([](const Options& options, Context& ctx) {
    PointCloud& cloud = ctx.Get<PointCloud>("cloud");
    const auto step = static_cast<std::size_t>(options.GetInt("step"));
    std::vector<std::size_t> keep;
    for (std::size_t i = 0; i < cloud.size(); i += step) keep.push_back(i);
    ctx.Note("kept", static_cast<std::int64_t>(keep.size()));
    cloud = Select(cloud, keep);
  }));
}

}  // namespace

HEDGEFIT_PLUGIN("decimate", "1.0", RegisterDecimate)
