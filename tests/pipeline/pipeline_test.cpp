// JSON pipelines: everything is validated before anything runs, errors name the
// stage and option, bare filenames pick readers and writers, and a run's metadata
// records the resolved options, versions, seed, times and point counts.

#include "pipeline/pipeline.hpp"
#include "cloud/cleaning.hpp"
#include "cloud/cloud_stages.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>

#include "cloud/cloud_io.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::cloud {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
namespace {

namespace fs = std::filesystem;
using pipeline::Pipeline;
using pipeline::Registry;

// cloud/'s built-in stages (the process registry starts empty: the CLI and Python fill it).
const Registry& CloudStages() {
  static const Registry registry = [] {
    Registry r;
    RegisterCloudStages(r);
    return r;
  }();
  return registry;
}

std::string BuildError(const std::string& json, const std::vector<std::string>& overrides = {}) {
  try {
    Pipeline::FromJson(json, "p.json", CloudStages(), overrides);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

PointCloud Grid(int n) {
  PointCloud c;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) c.points_mm.emplace_back(float(i), float(j), 1000.f);
  c.points_mm.emplace_back(5000.f, 5000.f, 5000.f);  // one far outlier
  c.Flatten();
  return c;
}

TEST(Pipeline, ValidationErrorsNameStageAndOption) {
  EXPECT_EQ(BuildError("[\"in.pcd\", {\"type\": \"filters.statistical_outlyer\"}]"),
            "p.json: stage 2: unknown stage 'filters.statistical_outlyer' (did you mean "
            "'filters.statistical_outlier'?); `hedgefit plugins` lists every stage");
  EXPECT_EQ(BuildError("[\"in.pcd\", {\"type\": \"filters.statistical_outlier\", \"meank\": 5}]"),
            "stage 'filters.statistical_outlier': unknown option 'meank' (did you mean 'mean_k'?); see `hedgefit "
            "plugins` for filters.statistical_outlier's options");
  EXPECT_EQ(BuildError("[\"in.pcd\", {\"type\": \"filters.statistical_outlier\", \"mean_k\": \"many\"}]"),
            "stage 'filters.statistical_outlier', option 'mean_k': expected integer, got string \"many\"");
  EXPECT_EQ(BuildError("[\"in.pcd\", {\"type\": \"filters.statistical_outlier\", \"mean_k\": 0}]"),
            "stage 'filters.statistical_outlier', option 'mean_k': 0 is out of range; use a value in [1, 10000] points");
  EXPECT_EQ(BuildError("[\"in.pcd\", {\"type\": \"writers.pcd\", \"filename\": \"o.pcd\", \"encoding\": \"zip\"}]"),
            "stage 'writers.pcd', option 'encoding': 'zip' is not one of ascii, binary, binary_compressed");
  EXPECT_EQ(BuildError("[{\"type\": \"filters.voxel_grid\"}]"),
            "p.json: stage 'filters.voxel_grid' needs a 'cloud' artifact but no earlier stage makes one; start the "
            "pipeline with a reader, e.g. \"input.pcd\"");
  EXPECT_EQ(BuildError("[\"in.e57\"]"), "p.json: stage 1: no reader for 'in.e57'; use .pcd, .ply, .xyz or .las, or give \"type\"");
  EXPECT_EQ(BuildError("[\"in.pcd\", {\"type\": \"filters.crop_box\", \"min\": [0, 0, 10], \"max\": [1, 1, 1]}]"),
            "stage 'filters.crop_box', option 'min'/'max': min z (10.000000) is above max z (1.000000); swap them");
  EXPECT_EQ(BuildError("[\"in.pcd\", \"no/such/dir/out.pcd\"]"),
            "stage 'writers.pcd', option 'filename': directory 'no/such/dir' does not exist; create it first");
  EXPECT_EQ(BuildError("[\"in.pcd\", {\"type\": \"writers.pcd\", \"filename\": \"out.foo\"}]"),
            "stage 'writers.pcd', option 'filename': out.foo: unknown cloud format '.foo'; use .pcd, .ply, .xyz or .las");
  EXPECT_EQ(BuildError("[\"in.pcd\", {\"type\": \"writers.pcd\", \"filename\": \"out/\"}]"),
            "stage 'writers.pcd', option 'filename': 'out/' is a directory; give a file name in it");
  EXPECT_EQ(BuildError("[]"), "p.json: the pipeline has no stages");
  EXPECT_EQ(BuildError("{\"stages\": 1}"), "p.json: a pipeline is a JSON array of stages (or {\"pipeline\": [...]})");
  EXPECT_NE(BuildError("[\"in.pcd\", {\"type\": ").find("p.json: invalid JSON at byte"), std::string::npos);
}

TEST(Pipeline, OverridesAreValidatedLikeJson) {
  const std::string json = "[\"in.pcd\", {\"type\": \"filters.statistical_outlier\", \"tag\": \"sor\"}]";
  const Pipeline p = Pipeline::FromJson(json, "p.json", CloudStages(), {"sor.mean_k=12"});
  EXPECT_EQ(p.stages()[1].options.GetInt("mean_k"), 12);
  EXPECT_EQ(BuildError(json, {"sor.mean_k=twelve"}), "stage 'sor', option 'mean_k': cannot read 'twelve' as integer");
  EXPECT_EQ(BuildError(json, {"sor.mean=3"}), "--set 'sor.mean=3': stage 'sor' has no option 'mean' (did you mean 'mean_k'?)");
  EXPECT_EQ(BuildError(json, {"sr.mean_k=3"}), "--set 'sr.mean_k=3': no stage 'sr' in p.json (did you mean 'sor'?)");
  EXPECT_EQ(BuildError(json, {"mean_k"}), "--set 'mean_k': expected stage.option=value, e.g. filters.statistical_outlier.mean_k=30");
}

TEST(Pipeline, BareFilenamesChooseReaderThenWriter) {
  const Pipeline p = Pipeline::FromJson("[\"a.ply\", \"b.xyz\", {\"type\": \"filters.nonfinite\"}, \"c.pcd\"]", "p",
                                        CloudStages());
  ASSERT_EQ(p.stages().size(), 4u);
  EXPECT_EQ(p.stages()[0].type, "readers.ply");
  EXPECT_EQ(p.stages()[1].type, "readers.xyz");
  EXPECT_EQ(p.stages()[3].type, "writers.pcd");
  EXPECT_EQ(p.stages()[3].options.GetString("filename"), "c.pcd");
  const Pipeline convert = Pipeline::FromJson("[\"a.ply\", \"b.pcd\"]", "p", CloudStages());
  EXPECT_EQ(convert.stages()[1].type, "writers.pcd");
}

TEST(Pipeline, RunsEndToEndAndWritesMetadata) {
  const fs::path dir = testing::ScratchDir();
  const PointCloud cloud = Grid(20);
  WriteCloud((dir / "in.pcd").string(), cloud);
  const std::string json = "[\"" + (dir / "in.pcd").string() +
                           "\", {\"type\": \"filters.statistical_outlier\", \"mean_k\": 8}, \"" +
                           (dir / "out.ply").string() + "\"]";
  Pipeline p = Pipeline::FromJson(json, "p", CloudStages());
  Context ctx;
  ctx.seed = 7;
  const RunReport report = p.Run(ctx);
  ASSERT_EQ(report.stages.size(), 3u);
  EXPECT_EQ(report.stages[1].points_in, 401);
  EXPECT_EQ(report.stages[1].points_out, 400);  // the far outlier is gone
  EXPECT_EQ(ReadCloud((dir / "out.ply").string()).size(), 400u);

  const auto meta = nlohmann::json::parse(p.MetadataJson(report, ctx));
  EXPECT_EQ(meta["seed"], 7);
  EXPECT_EQ(meta["pipeline"][1]["type"], "filters.statistical_outlier");
  EXPECT_EQ(meta["pipeline"][1]["mean_k"], 8);
  EXPECT_EQ(meta["pipeline"][1]["stddev_mul"], 1.0);  // defaults are recorded too
  EXPECT_EQ(meta["stages"][1]["notes"]["removed"], 1);
  EXPECT_TRUE(meta["versions"].contains("pcl"));
  EXPECT_TRUE(meta["versions"].contains("hedgefit"));
  EXPECT_GE(meta["stages"][1]["wall_ms"].get<double>(), 0.0);
}

TEST(Pipeline, RunFailureNamesTheStageAndLeavesNoOutput) {
  const fs::path dir = testing::ScratchDir();
  const std::string json = "[\"" + (dir / "missing.pcd").string() + "\", \"" + (dir / "out.pcd").string() + "\"]";
  Pipeline p = Pipeline::FromJson(json, "p", CloudStages());
  Context ctx;
  try {
    p.Run(ctx);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.pcd: no such file"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(dir / "out.pcd"));
}

// Filter stages run on a cloud in memory (what the benches clean with): the grid's one far point
// goes, the default cleaning's stages among them; anything but an array of filters.* stages is
// refused with the source named, before anything runs; "[]" returns the cloud as it is.
TEST(Pipeline, FilterStagesRunOnACloudInMemory) {
  PointCloud grid = Grid(20);
  grid.fields[kPixelSizeField] = std::vector<float>(grid.size(), 1.f);  // a stereo capture's footprints
  EXPECT_EQ(RunFilterStages(grid, DefaultCleaningJson(), "cleaning").size(), 400u);
  EXPECT_EQ(RunFilterStages(grid, "[]", "cleaning").size(), 401u);
  auto error = [&](const std::string& stages) {
    try {
      CheckFilterStages(stages, "my.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error("[{"), "my.json: invalid JSON; give an array of filter stages, e.g. [{\"type\": \"filters.nonfinite\"}]");
  EXPECT_EQ(error("{\"type\": \"filters.nonfinite\"}"),
            "my.json: filter stages are a JSON array, e.g. [{\"type\": \"filters.nonfinite\"}]");
  EXPECT_EQ(error("[\"in.pcd\"]"), "my.json: give filters.* stages only (\"in.pcd\" is not one)");
  EXPECT_EQ(error("[{\"type\": \"fitters.kasa\"}]"), "my.json: give filters.* stages only ({\"type\":\"fitters.kasa\"} is not one)");
  EXPECT_NE(error("[{\"type\": \"filters.spacing_outlier\", \"max_ratio\": 0.5}]").find("max_ratio"), std::string::npos);
  EXPECT_EQ(error(DefaultCleaningJson()), "");
}

}  // namespace
}  // namespace hedgefit::cloud
