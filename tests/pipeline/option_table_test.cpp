// Options declared once: a table bound to a struct's fields gives the declarations (defaults
// from the struct), fills the struct from resolved options, turns it back into values, and
// checks it with messages that name the option; ParallelFor covers each index once.

#include "pipeline/option_table.hpp"
#include "cloud/cloud_stages.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <thread>

#include "cloud/cloud_io.hpp"
#include "cloud/filters.hpp"
#include "pipeline/parallel.hpp"
#include "pipeline/registry.hpp"

namespace hedgefit::cloud {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
namespace {

enum class Shape { kBall, kDome };

struct Inner {
  int steps = 3;
  static const OptionTable<Inner>& Table() {
    static const auto t = OptionTable<Inner>().Add("steps", &Inner::steps, "steps").Range(1, 10);
    return t;
  }
};

struct Demo {
  double radius_mm = 450;
  int count = 7;
  bool flag = true;
  std::string name = "hedge";
  Shape shape = Shape::kDome;
  Eigen::Vector3f corner = Eigen::Vector3f(1, 2, 3);
  Inner inner;
  static const OptionTable<Demo>& Table() {
    static const auto t = OptionTable<Demo>()
                              .Add("radius", &Demo::radius_mm, "radius", "mm").Min(1)
                              .Add("count", &Demo::count, "count").Range(0, 100)
                              .Add("flag", &Demo::flag, "flag")
                              .Add("name", &Demo::name, "name")
                              .AddEnum("shape", &Demo::shape, {{"ball", Shape::kBall}, {"dome", Shape::kDome}}, "shape")
                              .Add("corner", &Demo::corner, "corner", "mm")
                              .Nest(Inner::Table(), &Demo::inner);
    return t;
  }
};

TEST(OptionTable, DefaultsComeFromTheStruct) {
  const std::vector<OptionSpec> specs = Demo::Table().Specs();
  ASSERT_EQ(specs.size(), 7u);
  EXPECT_EQ(std::get<double>(specs[0].default_value), 450.0);
  EXPECT_EQ(std::get<std::int64_t>(specs[1].default_value), 7);
  EXPECT_EQ(std::get<bool>(specs[2].default_value), true);
  EXPECT_EQ(std::get<std::string>(specs[3].default_value), "hedge");
  EXPECT_EQ(std::get<std::string>(specs[4].default_value), "dome");
  EXPECT_EQ(specs[4].choices, (std::vector<std::string>{"ball", "dome"}));
  EXPECT_EQ(std::get<std::vector<double>>(specs[5].default_value), (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(specs[5].list_size, 3u);
  EXPECT_EQ(specs[6].name, "steps");
  EXPECT_EQ(std::get<std::int64_t>(specs[6].default_value), 3);
  EXPECT_EQ(specs[0].unit, "mm");
  EXPECT_EQ(*specs[1].max, 100.0);
}

TEST(OptionTable, OptionsFillTheStructAndValuesRoundTrip) {
  StageInfo info{"demo", "", Demo::Table().Specs(), {}, {}, {}};
  const Options o = ResolveOptions(info,
                                   {{"radius", 600.0}, {"count", std::int64_t(9)}, {"flag", false},
                                    {"shape", std::string("ball")}, {"corner", std::vector<double>{4, 5, 6}},
                                    {"steps", std::int64_t(8)}},
                                   "demo");
  const Demo d = Demo::Table().FromOptions(o);
  EXPECT_EQ(d.radius_mm, 600.0);
  EXPECT_EQ(d.count, 9);
  EXPECT_FALSE(d.flag);
  EXPECT_EQ(d.name, "hedge");  // not given: the struct's default
  EXPECT_EQ(d.shape, Shape::kBall);
  EXPECT_EQ(d.corner, Eigen::Vector3f(4, 5, 6));
  EXPECT_EQ(d.inner.steps, 8);
  const Demo back = Demo::Table().FromOptions(Options(Demo::Table().Values(d)));
  EXPECT_EQ(back.radius_mm, d.radius_mm);
  EXPECT_EQ(back.shape, d.shape);
  EXPECT_EQ(back.corner, d.corner);
  EXPECT_EQ(back.inner.steps, d.inner.steps);
}

TEST(OptionTable, ValidateNamesTheOptionNotTheField) {
  Demo d;
  d.count = 101;
  try {
    Demo::Table().Validate(d);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "option 'count': 101 is out of range; use a value in [0, 100]");
  }
  d.count = 1;
  d.inner.steps = 0;
  try {
    Demo::Table().Validate(d, [](const std::string& o) { return FlagName(o); });
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "--steps: 0 is out of range; use a value in [1, 10]");
  }
  // A filter's Check() is its table: the message names 'threads', the option users type,
  // not the field num_threads.
  StatisticalOutlierOptions so;
  so.num_threads = -1;
  try {
    so.Check();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("option 'threads'", 0), 0u) << e.what();
  }
}

TEST(OptionTable, EveryCloudFormatHasAReaderAndAWriterStage) {
  Registry r;
  RegisterCloudStages(r);
  for (const CloudFormat& f : CloudFormats()) {
    ASSERT_NE(r.Find("readers." + f.name), nullptr) << f.name;
    const StageDescriptor* w = r.Find("writers." + f.name);
    ASSERT_NE(w, nullptr) << f.name;
    for (const auto& opt : f.write_options) EXPECT_NE(w->info.FindOption(opt), nullptr) << f.name << " " << opt;
  }
  try {
    FormatFromPath("scan.e57");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "scan.e57: unknown cloud format '.e57'; use .pcd, .ply, .xyz or .las");
  }
}

TEST(ParallelFor, EachIndexOnceWithinTheThreadLimitAndErrorsReachTheCaller) {
  for (int threads : {1, 2, 0}) {
    const std::size_t n = 10007;
    std::vector<std::atomic<int>> seen(n);
    std::mutex m;
    std::set<std::thread::id> ids;
    ParallelFor(n, threads, 64, [&](std::size_t b, std::size_t e) {
      EXPECT_EQ(b % 64, 0u);  // chunks start on the grain: fixed by n and grain, not by timing
      EXPECT_LE(e - b, 64u);
      for (std::size_t i = b; i < e; ++i) ++seen[i];
      std::lock_guard<std::mutex> lock(m);
      ids.insert(std::this_thread::get_id());
    });
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(seen[i], 1) << i;
    EXPECT_LE(int(ids.size()), WorkerCount(threads));
  }
  EXPECT_THROW(ParallelFor(100, 2, 1, [](std::size_t b, std::size_t) {
                 if (b == 57) throw Error("stop");
               }),
               Error);
}

// A loop on all cores (threads 0) inside one capped at 2 workers (fits of several hedges, each
// summing its likelihood in parallel) stays within the cap: it runs in the enclosing loop's
// workers rather than in an arena of its own on every core. (On a 2-core machine the pool has no
// more threads to take, so this can only fail where there are more cores.)
TEST(ParallelFor, ANestedLoopOnAllCoresStaysWithinTheEnclosingCap) {
  std::mutex m;
  std::set<std::thread::id> ids;
  std::atomic<int> calls{0};
  ParallelFor(8, 2, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) {
      ParallelFor(64, 0, 1, [&](std::size_t, std::size_t) {
        ++calls;
        std::this_thread::sleep_for(std::chrono::microseconds(200));
        std::lock_guard<std::mutex> lock(m);
        ids.insert(std::this_thread::get_id());
      });
    }
  });
  EXPECT_EQ(calls, 8 * 64);
  EXPECT_LE(int(ids.size()), 2);
}

}  // namespace
}  // namespace hedgefit::cloud
