// The built-in readers.*, writers.* and filters.* stages: thin adapters from
// declared options to the free functions in cloud_io.hpp and filters.hpp.

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "cloud/cloud_io.hpp"
#include "cloud/filters.hpp"
#include "pipeline/option_table.hpp"
#include "cloud/cloud_stages.hpp"
#include "pipeline/registry.hpp"

namespace hedgefit::cloud {

using pipeline::OptionSpec;
using pipeline::IntOption;
using pipeline::DoubleOption;
using pipeline::StringOption;
using pipeline::StageInfo;
using pipeline::Options;
using pipeline::Context;
using pipeline::StageFactory;
using pipeline::MakeFactory;
using pipeline::Registry;
using pipeline::TableOptions;
using pipeline::TableFactory;

namespace {

void NoteFilter(Context& ctx, const FilterResult& r) {
  ctx.Note("kept", static_cast<std::int64_t>(r.kept));
  ctx.Note("removed", static_cast<std::int64_t>(r.removed));
  if (r.nonfinite) ctx.Note("nonfinite", static_cast<std::int64_t>(r.nonfinite));
}

void AddReader(Registry& r, const std::string& name, const std::string& what, std::vector<std::string> exts) {
  StageInfo info{name, "Reads a " + what + " file into the 'cloud' artifact (units mm; scale converts)", {}, {}, {"cloud"}, exts};
  info.options = {StringOption("filename", "", "file to read"),
                  DoubleOption("scale", 1.0, "multiplies coordinates: 1000 for metre files", "").Min(1e-9)};
  r.Add(info, MakeFactory([name](const Options& o, Context& ctx) {
    if (o.GetString("filename").empty()) throw Error("stage '" + name + "', option 'filename': give the file to read");
    ReadOptions ro;
    ro.scale = o.GetDouble("scale");
    CloudFileHeader header;
    PointCloud cloud = ReadCloud(o.GetString("filename"), ro, &header);
    ctx.Note("points", static_cast<std::int64_t>(cloud.size()));
    ctx.Note("nonfinite", static_cast<std::int64_t>(CountNonFinite(cloud)));
    ctx.Note("organized", cloud.IsOrganized());
    ctx.Note("encoding", header.encoding);
    // Where the sensor stood (a PCD's VIEWPOINT), in the frame of the points as read: scaled, and
    // shifted as they were. segment.hedges reads it when given no viewpoints.
    if (header.viewpoint) ctx.Put("viewpoint", Eigen::Vector3d(*header.viewpoint * ro.scale - cloud.offset));
    ctx.Put("cloud", std::move(cloud));
  }));
}

void AddWriter(Registry& r, const std::string& name, const std::string& what, std::vector<std::string> exts,
               std::vector<OptionSpec> extra) {
  StageInfo info{name, "Writes the 'cloud' artifact as " + what + " (atomically: temporary file, then rename)",
                 {StringOption("filename", "", "file to write; a '#' in it writes one file per hedge (hedge_id)")},
                 {"cloud"}, {}, exts};
  for (auto& e : extra) info.options.push_back(std::move(e));
  const StageFactory run = MakeFactory([](const Options& o, Context& ctx) {
    const PointCloud& cloud = ctx.Get<PointCloud>("cloud");
    const std::string& filename = o.GetString("filename");
    const auto hash = filename.rfind('#');
    if (hash == std::string::npos) {
      WriteCloud(ctx.OutputPath(filename), cloud, WriteOptions::Table().FromOptions(o));
      ctx.Note("points", static_cast<std::int64_t>(cloud.size()));
      ctx.Note("filename", filename);
      return;
    }
    // One file per hedge, as PDAL's writers do per view: '#' becomes the hedge's id.
    if (!cloud.fields.count(kHedgeIdField)) {
      throw Error("stage '" + ctx.current_stage + "', option 'filename': '" + filename +
                  "' has a '#' (one file per hedge) but the cloud has no hedge_id field; segment with "
                  "stereo.segment_garden, or drop the '#'");
    }
    std::string files;
    for (const HedgeGroup& g : HedgeGroups(cloud)) {
      const std::string path = filename.substr(0, hash) + std::to_string(g.id) + filename.substr(hash + 1);
      WriteCloud(ctx.OutputPath(path), Select(cloud, g.indices), WriteOptions::Table().FromOptions(o));
      files += (files.empty() ? "" : ", ") + path;
    }
    ctx.Note("points", static_cast<std::int64_t>(cloud.size() - CountNonFinite(cloud)));
    ctx.Note("filename", files);
  });
  // Checked when the pipeline is built, so a bad output path fails before any work is done.
  r.Add(info, [name, run](const Options& o) {
    const std::string& file = o.GetString("filename");
    if (file.empty()) throw Error("stage '" + name + "', option 'filename': give the file to write");
    std::error_code ec;
    if (file.back() == '/' || std::filesystem::is_directory(file, ec)) {
      throw Error("stage '" + name + "', option 'filename': '" + file + "' is a directory; give a file name in it");
    }
    try {
      FormatFromPath(file);  // the format follows the extension: one must be known
    } catch (const Error& e) {
      throw Error("stage '" + name + "', option 'filename': " + e.what());
    }
    const std::filesystem::path dir = std::filesystem::path(file).parent_path();
    if (!dir.empty() && !std::filesystem::is_directory(dir, ec)) {
      throw Error("stage '" + name + "', option 'filename': directory '" + dir.string() +
                  "' does not exist; create it first");
    }
    return run(o);
  });
}

}  // namespace

void RegisterCloudStages(Registry& r) {
  // readers.NAME and writers.NAME for every format of the table (cloud_io.hpp).
  for (const CloudFormat& f : CloudFormats()) {
    AddReader(r, "readers." + f.name, f.description, f.extensions);
    std::vector<OptionSpec> extra;
    for (const auto& spec : WriteOptions::Table().Specs()) {
      if (std::find(f.write_options.begin(), f.write_options.end(), spec.name) != f.write_options.end()) {
        extra.push_back(spec);
      }
    }
    AddWriter(r, "writers." + f.name, f.description, f.extensions, extra);
  }

  r.Add(StageInfo{"filters.nonfinite", "Drops points with a NaN or Inf coordinate and says how many", {}, {"cloud"}, {"cloud"}, {}},
        MakeFactory([](const Options&, Context& ctx) {
          PointCloud& cloud = ctx.Get<PointCloud>("cloud");
          const bool was_organized = cloud.IsOrganized();
          FilterResult res = RemoveNonFinite(cloud);
          ctx.Note("dropped", static_cast<std::int64_t>(res.nonfinite));
          if (was_organized && res.nonfinite) ctx.Note("organization", std::string("lost (dropping points unorganises)"));
          cloud = std::move(res.cloud);
        }));

  auto filter = [&r](const std::string& name, const std::string& what, std::vector<OptionSpec> options,
                     StageFactory make) { r.Add(StageInfo{name, what, std::move(options), {"cloud"}, {"cloud"}, {}}, make); };
  // Each runs its free function on 'cloud' and replaces it by what was kept.
  auto keep = [](Context& ctx, const std::function<FilterResult(const PointCloud&)>& fn) {
    PointCloud& cloud = ctx.Get<PointCloud>("cloud");
    FilterResult res = fn(cloud);
    NoteFilter(ctx, res);
    cloud = std::move(res.cloud);
    return res;
  };
  filter("filters.statistical_outlier",
         "Removes points whose mean distance to their mean_k neighbours exceeds mean + stddev_mul * sigma "
         "(Rusu 2008; same kept set as PCL's StatisticalOutlierRemoval)",
         TableOptions<StatisticalOutlierOptions>(),
         TableFactory<StatisticalOutlierOptions>(
             "filters.statistical_outlier", [keep](const StatisticalOutlierOptions& p, const Options&, Context& ctx) {
               const FilterResult res = keep(ctx, [&](const PointCloud& c) { return StatisticalOutlierRemoval(c, p); });
               ctx.Note("threshold_mm", res.threshold);
             }));
  filter("filters.radius_outlier",
         "Removes points with fewer than min_neighbours others within radius (PCL RadiusOutlierRemoval's rule)",
         TableOptions<RadiusOutlierOptions>(),
         TableFactory<RadiusOutlierOptions>("filters.radius_outlier",
                                            [keep](const RadiusOutlierOptions& p, const Options&, Context& ctx) {
                                              keep(ctx, [&](const PointCloud& c) { return RadiusOutlierRemoval(c, p); });
                                            }));
  filter("filters.local_outlier",
         "Removes points whose local outlier factor (Breunig 2000: their k neighbours' density over their own) "
         "exceeds threshold; unlike statistical_outlier it keeps sparse but consistent surfaces",
         TableOptions<LocalOutlierOptions>(),
         TableFactory<LocalOutlierOptions>("filters.local_outlier",
                                           [keep](const LocalOutlierOptions& p, const Options&, Context& ctx) {
                                             keep(ctx, [&](const PointCloud& c) { return LocalOutlierRemoval(c, p); });
                                           }));
  filter("filters.spacing_outlier",
         "Removes points whose mean distance to their mean_k neighbours, in units of their pixel footprint "
         "(pixel_mm), exceeds max_ratio times the cloud's median: floating mismatches go, a rounded surface's "
         "sparse outline stays",
         TableOptions<SpacingOutlierOptions>(),
         TableFactory<SpacingOutlierOptions>(
             "filters.spacing_outlier", [keep](const SpacingOutlierOptions& p, const Options&, Context& ctx) {
               const FilterResult res = keep(ctx, [&](const PointCloud& c) { return SpacingOutlierRemoval(c, p); });
               ctx.Note("threshold_mm", res.threshold);
             }));
  filter("filters.hedge_outlier",
         "The default cleaning's outlier removal, by what the cloud is: on a stereo capture's cloud (pixel_mm) "
         "local_outlier (k 20, threshold 2) then spacing_outlier (mean_k 30, max_ratio 8); on hedges found by "
         "depth (hedge_id: leafy shells, unless shells is local; each hedge against its own points) and clouds "
         "without pixel_mm statistical_outlier (mean_k 30, stddev_mul 1)",
         TableOptions<HedgeOutlierOptions>(),
         TableFactory<HedgeOutlierOptions>("filters.hedge_outlier",
                                           [keep](const HedgeOutlierOptions& p, const Options&, Context& ctx) {
                                             const bool local = HedgeOutlierIsLocal(ctx.Get<PointCloud>("cloud"), p);
                                             keep(ctx, [&](const PointCloud& c) { return HedgeOutlierRemoval(c, p); });
                                             ctx.Note("filter", std::string(local ? "local + spacing" : "statistical"));
                                           }));
  filter("filters.voxel_grid", "Downsamples to one centroid per cubic voxel (colours and fields averaged)",
         TableOptions<VoxelGridOptions>(),
         TableFactory<VoxelGridOptions>("filters.voxel_grid", [keep](const VoxelGridOptions& p, const Options&, Context& ctx) {
           keep(ctx, [&](const PointCloud& c) { return VoxelGrid(c, p); });
         }));
  filter("filters.crop_box", "Keeps points inside (or, negative, outside) an axis-aligned box",
         TableOptions<CropBoxOptions>(),
         TableFactory<CropBoxOptions>("filters.crop_box", [keep](const CropBoxOptions& p, const Options&, Context& ctx) {
           keep(ctx, [&](const PointCloud& c) { return CropBox(c, p); });
         }));
  filter("filters.plane_removal", "Removes dominant planes (floor, walls) one by one with RANSAC, so fits see the object",
         TableOptions<PlaneRemovalOptions>({IntOption("seed", -1, "sampler seed; -1 = the pipeline's --seed").Min(-1)}),
         TableFactory<PlaneRemovalOptions>("filters.plane_removal",
                                           [keep](const PlaneRemovalOptions& p, const Options& o, Context& ctx) {
                                             PlaneRemovalOptions run = p;
                                             const std::int64_t seed = o.GetInt("seed");
                                             run.seed = seed >= 0 ? static_cast<std::uint64_t>(seed) : ctx.seed;
                                             const FilterResult res =
                                                 keep(ctx, [&](const PointCloud& c) { return RemovePlanes(c, run); });
                                             ctx.Note("planes", static_cast<std::int64_t>(res.threshold));
                                           }));
  filter("filters.pass_through", "Keeps points whose field (x, y, z, range or an extra field) lies in [min, max]",
         TableOptions<PassThroughOptions>(),
         TableFactory<PassThroughOptions>("filters.pass_through",
                                          [keep](const PassThroughOptions& p, const Options&, Context& ctx) {
                                            try {
                                              keep(ctx, [&](const PointCloud& c) { return PassThrough(c, p); });
                                            } catch (const Error& e) {
                                              const std::string what = e.what();
                                              throw Error("stage 'filters.pass_through', " +
                                                          (what.rfind("option '", 0) == 0 ? what : "option " + what));
                                            }
                                          }));
}

}  // namespace hedgefit::cloud
