// The built-in readers.*, writers.* and filters.* stages: thin adapters from
// declared options to the free functions in cloud_io.hpp and filters.hpp.

#include <cmath>
#include <filesystem>

#include "cloud/cloud_io.hpp"
#include "cloud/filters.hpp"
#include "cloud/registry.hpp"

namespace hedgefit::cloud {

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
    ctx.Put("cloud", std::move(cloud));
  }));
}

void AddWriter(Registry& r, const std::string& name, const std::string& what, std::vector<std::string> exts,
               std::vector<OptionSpec> extra, std::function<WriteOptions(const Options&)> to_write_options) {
  StageInfo info{name, "Writes the 'cloud' artifact as " + what + " (atomically: temporary file, then rename)",
                 {StringOption("filename", "", "file to write")}, {"cloud"}, {}, exts};
  for (auto& e : extra) info.options.push_back(std::move(e));
  const StageFactory run = MakeFactory([to_write_options](const Options& o, Context& ctx) {
    const PointCloud& cloud = ctx.Get<PointCloud>("cloud");
    WriteCloud(o.GetString("filename"), cloud, to_write_options(o));
    ctx.Note("points", static_cast<std::int64_t>(cloud.size()));
    ctx.Note("filename", o.GetString("filename"));
  });
  // Checked when the pipeline is built, so a bad output path fails before any work is done.
  r.Add(info, [name, run](const Options& o) {
    const std::string& file = o.GetString("filename");
    if (file.empty()) throw Error("stage '" + name + "', option 'filename': give the file to write");
    const std::filesystem::path dir = std::filesystem::path(file).parent_path();
    std::error_code ec;
    if (!dir.empty() && !std::filesystem::is_directory(dir, ec)) {
      throw Error("stage '" + name + "', option 'filename': directory '" + dir.string() +
                  "' does not exist; create it first");
    }
    return run(o);
  });
}

}  // namespace

void RegisterCloudStages(Registry& r) {
  AddReader(r, "readers.pcd", "PCD (ascii, binary, binary_compressed)", {".pcd"});
  AddReader(r, "readers.ply", "PLY (ascii or binary)", {".ply"});
  AddReader(r, "readers.xyz", "text 'x y z [r g b]' per line", {".xyz", ".txt", ".csv"});

  AddWriter(r, "writers.pcd", "PCD", {".pcd"},
            {StringOption("encoding", "binary", "PCD data encoding").Choices({"ascii", "binary", "binary_compressed"})},
            [](const Options& o) {
              WriteOptions w;
              const std::string& e = o.GetString("encoding");
              w.pcd_encoding = e == "ascii" ? PcdEncoding::kAscii
                               : e == "binary" ? PcdEncoding::kBinary
                                               : PcdEncoding::kBinaryCompressed;
              return w;
            });
  AddWriter(r, "writers.ply", "PLY", {".ply"}, {BoolOption("binary", true, "binary little-endian (else ascii)")},
            [](const Options& o) {
              WriteOptions w;
              w.ply_binary = o.GetBool("binary");
              return w;
            });
  AddWriter(r, "writers.xyz", "text 'x y z [r g b]'", {".xyz", ".txt", ".csv"},
            {IntOption("precision", 8, "significant digits", "digits").Range(1, 17)}, [](const Options& o) {
              WriteOptions w;
              w.ascii_precision = static_cast<int>(o.GetInt("precision"));
              return w;
            });

  r.Add(StageInfo{"filters.nonfinite", "Drops points with a NaN or Inf coordinate and says how many", {}, {"cloud"}, {"cloud"}, {}},
        MakeFactory([](const Options&, Context& ctx) {
          PointCloud& cloud = ctx.Get<PointCloud>("cloud");
          const bool was_organized = cloud.IsOrganized();
          FilterResult res = RemoveNonFinite(cloud);
          ctx.Note("dropped", static_cast<std::int64_t>(res.nonfinite));
          if (was_organized && res.nonfinite) ctx.Note("organization", std::string("lost (dropping points unorganises)"));
          cloud = std::move(res.cloud);
        }));

  {
    const std::string name = "filters.statistical_outlier";
    StageInfo info{name,
                   "Removes points whose mean distance to their mean_k neighbours exceeds mean + stddev_mul * sigma "
                   "(Rusu 2008; same kept set as PCL's StatisticalOutlierRemoval)",
                   {IntOption("mean_k", 50, "neighbours used for each point's mean distance", "points").Range(1, 10000),
                    DoubleOption("stddev_mul", 1.0, "threshold in standard deviations above the mean distance", "sigma"),
                    IntOption("threads", 0, "worker threads, 0 = all cores", "threads").Range(0, 1024),
                    BoolOption("keep_organized", false, "set removed points to NaN instead of dropping them")},
                   {"cloud"}, {"cloud"}, {}};
    r.Add(info, MakeParamsFactory<StatisticalOutlierOptions>(
                    [name](const Options& o) {
                      StatisticalOutlierOptions p;
                      p.mean_k = static_cast<int>(o.GetInt("mean_k"));
                      p.stddev_mul = o.GetDouble("stddev_mul");
                      p.num_threads = static_cast<int>(o.GetInt("threads"));
                      p.keep_organized = o.GetBool("keep_organized");
                      return CheckedParams(p, name);
                    },
                    [](const StatisticalOutlierOptions& p, Context& ctx) {
                      PointCloud& cloud = ctx.Get<PointCloud>("cloud");
                      FilterResult res = StatisticalOutlierRemoval(cloud, p);
                      NoteFilter(ctx, res);
                      ctx.Note("threshold_mm", res.threshold);
                      cloud = std::move(res.cloud);
                    }));
  }
  {
    const std::string name = "filters.radius_outlier";
    StageInfo info{name, "Removes points with fewer than min_neighbours others within radius (PCL RadiusOutlierRemoval's rule)",
                   {DoubleOption("radius", 10.0, "neighbourhood radius", "mm").Min(1e-9),
                    IntOption("min_neighbours", 5, "other points needed within radius", "points").Range(0, 1000000),
                    IntOption("threads", 0, "worker threads, 0 = all cores", "threads").Range(0, 1024),
                    BoolOption("keep_organized", false, "set removed points to NaN instead of dropping them")},
                   {"cloud"}, {"cloud"}, {}};
    r.Add(info, MakeParamsFactory<RadiusOutlierOptions>(
                    [name](const Options& o) {
                      RadiusOutlierOptions p;
                      p.radius_mm = o.GetDouble("radius");
                      p.min_neighbours = static_cast<int>(o.GetInt("min_neighbours"));
                      p.num_threads = static_cast<int>(o.GetInt("threads"));
                      p.keep_organized = o.GetBool("keep_organized");
                      return CheckedParams(p, name);
                    },
                    [](const RadiusOutlierOptions& p, Context& ctx) {
                      PointCloud& cloud = ctx.Get<PointCloud>("cloud");
                      FilterResult res = RadiusOutlierRemoval(cloud, p);
                      NoteFilter(ctx, res);
                      cloud = std::move(res.cloud);
                    }));
  }
  {
    const std::string name = "filters.voxel_grid";
    StageInfo info{name, "Downsamples to one centroid per cubic voxel (colours and fields averaged)",
                   {DoubleOption("leaf", 5.0, "voxel edge length", "mm").Min(1e-6),
                    IntOption("min_points_per_voxel", 1, "drop voxels with fewer points", "points").Range(1, 1000000)},
                   {"cloud"}, {"cloud"}, {}};
    r.Add(info, MakeParamsFactory<VoxelGridOptions>(
                    [name](const Options& o) {
                      VoxelGridOptions p;
                      p.leaf_mm = o.GetDouble("leaf");
                      p.min_points_per_voxel = static_cast<int>(o.GetInt("min_points_per_voxel"));
                      return CheckedParams(p, name);
                    },
                    [](const VoxelGridOptions& p, Context& ctx) {
                      PointCloud& cloud = ctx.Get<PointCloud>("cloud");
                      FilterResult res = VoxelGrid(cloud, p);
                      NoteFilter(ctx, res);
                      cloud = std::move(res.cloud);
                    }));
  }
  {
    const std::string name = "filters.crop_box";
    StageInfo info{name, "Keeps points inside (or, negative, outside) an axis-aligned box",
                   {ListOption("min", {-1e9, -1e9, -1e9}, 3, "box corner [x, y, z]", "mm"),
                    ListOption("max", {1e9, 1e9, 1e9}, 3, "opposite corner [x, y, z]", "mm"),
                    BoolOption("negative", false, "keep the points outside the box"),
                    BoolOption("keep_organized", false, "set removed points to NaN instead of dropping them")},
                   {"cloud"}, {"cloud"}, {}};
    r.Add(info, MakeParamsFactory<CropBoxOptions>(
                    [name](const Options& o) {
                      CropBoxOptions p;
                      const auto& lo = o.GetList("min");
                      const auto& hi = o.GetList("max");
                      p.min_mm = Eigen::Vector3d(lo[0], lo[1], lo[2]).cast<float>();
                      p.max_mm = Eigen::Vector3d(hi[0], hi[1], hi[2]).cast<float>();
                      p.negative = o.GetBool("negative");
                      p.keep_organized = o.GetBool("keep_organized");
                      return CheckedParams(p, name);
                    },
                    [](const CropBoxOptions& p, Context& ctx) {
                      PointCloud& cloud = ctx.Get<PointCloud>("cloud");
                      FilterResult res = CropBox(cloud, p);
                      NoteFilter(ctx, res);
                      cloud = std::move(res.cloud);
                    }));
  }
  {
    const std::string name = "filters.plane_removal";
    StageInfo info{name, "Removes dominant planes (floor, walls) one by one with RANSAC, so fits see the object",
                   {DoubleOption("distance_threshold", 20.0, "points this close to a plane are removed", "mm").Min(1e-9),
                    IntOption("min_inliers", 1000, "stop when the best plane has fewer points", "points").Range(3, 1000000000),
                    IntOption("max_planes", 5, "planes to remove at most", "planes").Range(1, 1000),
                    IntOption("max_iterations", 1000, "RANSAC samples per plane", "samples").Range(1, 10000000),
                    IntOption("seed", -1, "sampler seed; -1 = the pipeline's --seed").Min(-1)},
                   {"cloud"}, {"cloud"}, {}};
    r.Add(info, [name](const Options& o) -> std::unique_ptr<Stage> {
      PlaneRemovalOptions p;
      p.distance_threshold_mm = o.GetDouble("distance_threshold");
      p.min_inliers = static_cast<int>(o.GetInt("min_inliers"));
      p.max_planes = static_cast<int>(o.GetInt("max_planes"));
      p.max_iterations = static_cast<int>(o.GetInt("max_iterations"));
      p = CheckedParams(p, name);
      const std::int64_t seed = o.GetInt("seed");
      return std::make_unique<LambdaStage>(o, [p, seed](const Options&, Context& ctx) {
        PlaneRemovalOptions run = p;
        run.seed = seed >= 0 ? static_cast<std::uint64_t>(seed) : ctx.seed;
        PointCloud& cloud = ctx.Get<PointCloud>("cloud");
        FilterResult res = RemovePlanes(cloud, run);
        NoteFilter(ctx, res);
        ctx.Note("planes", static_cast<std::int64_t>(res.threshold));
        cloud = std::move(res.cloud);
      });
    });
  }
  {
    const std::string name = "filters.pass_through";
    StageInfo info{name, "Keeps points whose field (x, y, z, range or an extra field) lies in [min, max]",
                   {StringOption("field", "z", "field to test: x, y, z, range (distance from the sensor) or an extra field"),
                    DoubleOption("min", -1e30, "inclusive lower limit", "field unit (mm for x y z)"),
                    DoubleOption("max", 1e30, "inclusive upper limit", "field unit (mm for x y z)"),
                    BoolOption("negative", false, "keep the points outside [min, max]"),
                    BoolOption("keep_organized", false, "set removed points to NaN instead of dropping them")},
                   {"cloud"}, {"cloud"}, {}};
    r.Add(info, MakeParamsFactory<PassThroughOptions>(
                    [name](const Options& o) {
                      PassThroughOptions p;
                      p.field = o.GetString("field");
                      p.min = o.GetDouble("min");
                      p.max = o.GetDouble("max");
                      p.negative = o.GetBool("negative");
                      p.keep_organized = o.GetBool("keep_organized");
                      return CheckedParams(p, name);
                    },
                    [name](const PassThroughOptions& p, Context& ctx) {
                      PointCloud& cloud = ctx.Get<PointCloud>("cloud");
                      FilterResult res;
                      try {
                        res = PassThrough(cloud, p);
                      } catch (const Error& e) {
                        throw Error("stage '" + name + "', option " + e.what());
                      }
                      NoteFilter(ctx, res);
                      cloud = std::move(res.cloud);
                    }));
  }
}

}  // namespace hedgefit::cloud
