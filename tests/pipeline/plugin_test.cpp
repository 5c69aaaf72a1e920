// Runtime plugins: a good one loads and its stage runs; a library without the entry
// point, one built for another ABI and one that takes a taken name are reported by
// name and skipped, and nothing crashes.

#include "pipeline/plugin.hpp"
#include "cloud/cloud_stages.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "pipeline/pipeline.hpp"
#include "cloud/point_cloud.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::cloud {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
namespace {

const std::string kPlugins = HEDGEFIT_TEST_PLUGIN_DIR;

Registry WithBuiltins() {
  Registry r;
  RegisterCloudStages(r);
  return r;
}

TEST(Plugins, GoodPluginAddsAWorkingStage) {
  Registry r = WithBuiltins();
  LoadPlugins(r, {kPlugins + "/decimate"});
  ASSERT_EQ(r.plugin_reports.size(), 1u);
  const PluginReport& rep = r.plugin_reports[0];
  EXPECT_TRUE(rep.loaded) << rep.message;
  EXPECT_EQ(rep.name, "decimate");
  EXPECT_EQ(rep.stages, std::vector<std::string>{"filters.decimate"});
  const StageDescriptor* d = r.Find("filters.decimate");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->origin, rep.path);

  auto stage = d->make(ResolveOptions(d->info, {{"step", std::int64_t{3}}}, "filters.decimate"));
  Context ctx;
  PointCloud c;
  for (int i = 0; i < 10; ++i) c.points_mm.emplace_back(float(i), 0.f, 0.f);
  c.Flatten();
  ctx.Put("cloud", c);
  stage->Run(ctx);
  const PointCloud& out = ctx.Get<PointCloud>("cloud");
  ASSERT_EQ(out.size(), 4u);  // points 0, 3, 6, 9
  EXPECT_EQ(out.points_mm[3].x(), 9.f);
}

TEST(Plugins, MissingEntryPointIsReportedAndSkipped) {
  Registry r = WithBuiltins();
  const std::size_t before = r.stages().size();
  LoadPlugins(r, {kPlugins + "/missing_entry"});
  ASSERT_EQ(r.plugin_reports.size(), 1u);
  EXPECT_FALSE(r.plugin_reports[0].loaded);
  EXPECT_NE(r.plugin_reports[0].path.find("missing_entry.so"), std::string::npos);
  EXPECT_NE(r.plugin_reports[0].message.find("has no 'hedgefit_plugin_entry' entry point"), std::string::npos);
  EXPECT_EQ(r.stages().size(), before);
}

TEST(Plugins, WrongAbiIsReportedWithoutCallingThePlugin) {
  Registry r = WithBuiltins();
  LoadPlugins(r, {kPlugins + "/wrong_abi"});  // its register function aborts if called
  ASSERT_EQ(r.plugin_reports.size(), 1u);
  EXPECT_FALSE(r.plugin_reports[0].loaded);
  EXPECT_EQ(r.plugin_reports[0].name, "wrong_abi");
  EXPECT_NE(r.plugin_reports[0].message.find("plugin ABI version " + std::to_string(HEDGEFIT_PLUGIN_ABI_VERSION + 1000)),
            std::string::npos);
}

TEST(Plugins, DuplicateStageNameIsRefusedAndTheBuiltinKept) {
  Registry r = WithBuiltins();
  LoadPlugins(r, {kPlugins + "/duplicate"});
  ASSERT_EQ(r.plugin_reports.size(), 1u);
  EXPECT_FALSE(r.plugin_reports[0].loaded);
  EXPECT_NE(r.plugin_reports[0].message.find("already registered by builtin"), std::string::npos);
  EXPECT_EQ(r.Find("filters.statistical_outlier")->origin, "builtin");
}

TEST(Plugins, NonLibraryFileAndMissingDirectoryAreHarmless) {
  const auto dir = testing::ScratchDir();
  std::ofstream(dir / "junk.so") << "not an ELF file";
  Registry r = WithBuiltins();
  LoadPlugins(r, {dir.string(), (dir / "does_not_exist").string()});
  ASSERT_EQ(r.plugin_reports.size(), 1u);
  EXPECT_FALSE(r.plugin_reports[0].loaded);
  EXPECT_NE(r.plugin_reports[0].message.find("cannot be opened"), std::string::npos);
}

TEST(Plugins, SearchPathHonoursEnvironment) {
  setenv("HEDGEFIT_PLUGIN_PATH", "/a:/b", 1);
  const auto dirs = PluginSearchPath();
  unsetenv("HEDGEFIT_PLUGIN_PATH");
  ASSERT_GE(dirs.size(), 3u);
  EXPECT_EQ(dirs[0], "/a");
  EXPECT_EQ(dirs[1], "/b");
}

}  // namespace
}  // namespace hedgefit::cloud
