// Option declarations drive validation: types, ranges, choices and "did you mean".

#include "pipeline/stage.hpp"

#include <gtest/gtest.h>

namespace hedgefit::cloud {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
namespace {

StageInfo Info() {
  return StageInfo{"filters.test",
                   "test stage",
                   {IntOption("mean_k", 50, "neighbours", "points").Range(1, 100),
                    DoubleOption("radius", 10.0, "radius", "mm").Min(0.5),
                    StringOption("mode", "fast", "mode").Choices({"fast", "exact"}),
                    BoolOption("flag", false, "a flag"), ListOption("min", {0, 0, 0}, 3, "corner", "mm")},
                   {},
                   {},
                   {}};
}

std::string ErrorOf(const std::map<std::string, OptionValue>& given) {
  try {
    ResolveOptions(Info(), given, "clean");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Options, DefaultsFillEveryDeclaredOption) {
  const Options o = ResolveOptions(Info(), {{"mean_k", std::int64_t{7}}}, "clean");
  EXPECT_EQ(o.GetInt("mean_k"), 7);
  EXPECT_DOUBLE_EQ(o.GetDouble("radius"), 10.0);
  EXPECT_EQ(o.GetString("mode"), "fast");
  EXPECT_FALSE(o.GetBool("flag"));
  EXPECT_EQ(o.GetList("min").size(), 3u);
}

TEST(Options, IntegerAcceptedWhereNumberDeclaredAndWholeNumberWhereIntegerDeclared) {
  const Options o = ResolveOptions(Info(), {{"radius", std::int64_t{3}}, {"mean_k", 20.0}}, "clean");
  EXPECT_DOUBLE_EQ(o.GetDouble("radius"), 3.0);
  EXPECT_EQ(o.GetInt("mean_k"), 20);
}

TEST(Options, ErrorsNameStageOptionAndFix) {
  EXPECT_EQ(ErrorOf({{"mean_kk", std::int64_t{3}}}),
            "stage 'clean': unknown option 'mean_kk' (did you mean 'mean_k'?); see `hedgefit plugins` for "
            "filters.test's options");
  EXPECT_EQ(ErrorOf({{"mean_k", std::string("ten")}}), "stage 'clean', option 'mean_k': expected integer, got string \"ten\"");
  EXPECT_EQ(ErrorOf({{"mean_k", 2.5}}), "stage 'clean', option 'mean_k': expected integer, got number 2.5");
  EXPECT_EQ(ErrorOf({{"mean_k", std::int64_t{0}}}),
            "stage 'clean', option 'mean_k': 0 is out of range; use a value in [1, 100] points");
  EXPECT_EQ(ErrorOf({{"radius", 0.1}}), "stage 'clean', option 'radius': 0.1 is out of range; use a value >= 0.5 mm");
  EXPECT_EQ(ErrorOf({{"mode", std::string("exatc")}}),
            "stage 'clean', option 'mode': 'exatc' is not one of fast, exact (did you mean 'exact'?)");
  EXPECT_EQ(ErrorOf({{"flag", std::int64_t{1}}}), "stage 'clean', option 'flag': expected boolean, got integer 1");
  EXPECT_EQ(ErrorOf({{"min", std::vector<double>{1, 2}}}), "stage 'clean', option 'min': expected 3 numbers, got 2");
}

TEST(Options, ParseFromCommandLineStrings) {
  const StageInfo info = Info();
  EXPECT_EQ(std::get<std::int64_t>(ParseOptionString(*info.FindOption("mean_k"), "30", "s")), 30);
  EXPECT_DOUBLE_EQ(std::get<double>(ParseOptionString(*info.FindOption("radius"), "2.5", "s")), 2.5);
  EXPECT_TRUE(std::get<bool>(ParseOptionString(*info.FindOption("flag"), "true", "s")));
  EXPECT_EQ(std::get<std::vector<double>>(ParseOptionString(*info.FindOption("min"), "[1, 2.5,3]", "s")),
            (std::vector<double>{1, 2.5, 3}));
  EXPECT_THROW(ParseOptionString(*info.FindOption("mean_k"), "30x", "s"), Error);
  EXPECT_THROW(ParseOptionString(*info.FindOption("flag"), "maybe", "s"), Error);
  EXPECT_THROW(ParseOptionString(*info.FindOption("min"), "[1,a,3]", "s"), Error);
}

TEST(Options, DidYouMeanOnlySuggestsCloseNames) {
  EXPECT_EQ(DidYouMean("stdev_mul", {"mean_k", "stddev_mul"}), "stddev_mul");
  EXPECT_EQ(DidYouMean("zzzzzz", {"mean_k", "stddev_mul"}), "");
}

}  // namespace
}  // namespace hedgefit::cloud
