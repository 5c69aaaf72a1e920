// hedgefit bench lab and bench garden: parse their flags and run bench/lab_bench.hpp and bench/garden_bench.hpp.

#include "bench/cli/commands.hpp"
#include "cli/parse.hpp"
#include "cli/stage_flags.hpp"
#include "cloud/cleaning.hpp"
#include "bench/find_bench.hpp"
#include "bench/around_bench.hpp"
#include "bench/garden_bench.hpp"
#include "bench/lab_bench.hpp"
#include "cloud/cloud_io.hpp"
#include "fitting/methods.hpp"
#include "pipeline/error.hpp"
#include "pipeline/pipeline.hpp"

#include <fstream>
#include <sstream>

namespace hedgefit::bench_cli {

namespace {

// A --pipeline file's filter stages (checked when the bench starts).
std::string ReadFilterStagesFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error("--pipeline " + path + ": cannot open it; give a JSON array of filter stages");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void AddLabBench(CLI::App* bench, CommandFn* run) {
  auto* cmd = bench->add_subcommand("lab", "The paper's lab test on the simulated rig: Table 2 per method, beside the paper's figures");
  cmd->footer(
      "Examples:\n"
      "  hedgefit bench lab                        # renders into build/lab-bench, about a minute\n"
      "  hedgefit bench lab --reuse --json lab.json\n"
      "  hedgefit bench lab --renderer povray --camera real --dir build/lab-povray   # POV-Ray, ~20 minutes\n"
      "  hedgefit bench lab --camera real --noise-draws 7 --dir build/lab-real   # 7 x 7 captures, ~2 minutes\n"
      "  hedgefit bench lab --reuse --camera real --noise-draws 7 --dir build/lab-real --camera-without bayer,noise\n"
      "  hedgefit bench lab --reuse --clean        # the fits see the cloud as `measure` cleans it\n"
      "--clean / --no-clean is the same choice in both benches; the lab's default is --no-clean (the matcher's\n"
      "cloud, as the paper fits it), the garden's --clean.\n");
  struct Args {
    bench::LabOptions lab;
    StageFlags flags;  // bench::LabOptions::Table()'s options
    bool clean = false;
    std::string pipeline, json;
  };
  auto a = std::make_shared<Args>();
  const auto specs = bench::LabOptions::Table().Specs();
  a->flags.Add(cmd, specs, {"dir", "scale", "reuse", "wide_boards", "renderer", "camera", "noise_draws", "camera_without"}, "Captures");
  a->flags.Add(cmd, specs, {}, "Measuring");
  auto* clean = cmd->add_flag("--clean,!--no-clean", a->clean,
                              "clean each capture's cloud as `measure` and `compare` do by default before the fits "
                              "(default --no-clean: they see the matcher's cloud)")->group("Measuring");
  cmd->add_option("--pipeline", a->pipeline, "clean each capture's cloud with this JSON array of filter stages instead")
      ->excludes(clean)->group("Measuring");
  cmd->add_option("--json", a->json, "also write the table as JSON here")->group("Output");
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);  // the captures run through the registry a plugin matcher joins
      bench::LabOptions::Table().Apply(a->flags.Given(), &a->lab);
      if (a->clean) a->lab.cleaning = cloud::DefaultCleaningJson();
      if (!a->pipeline.empty()) a->lab.cleaning = ReadFilterStagesFile(a->pipeline);
      const bench::LabResult result = bench::RunLab(a->lab);
      bench::PrintLab(result);
      if (!a->json.empty()) cloud::WriteTextFileAtomic(a->json, bench::LabJson(result));
      return kExitOk;
    };
  });
}

void AddGardenBench(CLI::App* bench, CommandFn* run) {
  auto* g = bench->add_subcommand(
      "garden", "Leafy hedge balls on a lawn (rows of three, one, the paper's outdoor size): every hedge found, fitted, "
                "scored against its envelope, beside the paper's colour path, with the matcher's radial error against "
                "the leaf each pixel truly sees, by that leaf's depth below the envelope");
  g->footer(
      "Examples:\n"
      "  hedgefit bench garden                     # renders into build/garden-bench, about a minute\n"
      "  hedgefit bench garden --reuse --json garden.json\n"
      "  hedgefit bench garden --renderer povray --camera real --dir build/garden-povray   # leaf discs, ~5 minutes\n"
      "  hedgefit bench garden --reuse --no-clean  # the fits see the clouds as converted (default --clean)\n"
      "  hedgefit bench garden --hard --dir build/garden-hard   # pair, low/high camera, small far, big near, off centre, touching, left edge, cut by frame, shrubs\n"
      "  hedgefit bench garden --random 12 --dir build/garden-random   # 12 gardens drawn from seeds 1..12\n"
      "  hedgefit bench garden --paper 4 --first-seed 101 --dir build/garden-paper-held   # the paper's size, held-back seeds\n"
      "  hedgefit bench garden --gardens outdoor,paper3 --renderer povray --dir build/garden-pov\n");
  struct GardenArgs {
    bench::GardenOptions garden;
    StageFlags flags;  // bench::GardenOptions::Table()'s options
    bool clean = true;
    std::string pipeline, json;
  };
  auto ga = std::make_shared<GardenArgs>();
  const auto specs = bench::GardenOptions::Table().Specs();
  ga->flags.Add(g, specs, {"dir", "scale", "reuse", "renderer", "camera", "hard", "random", "paper", "first_seed", "gardens"},
                "Captures");
  ga->flags.Add(g, specs, {}, "Measuring");
  auto* clean = g->add_flag("--clean,!--no-clean", ga->clean,
                            "clean each capture's cloud as `compare` does (the default), or with --no-clean fit it as "
                            "the matcher gives it")->group("Measuring");
  g->add_option("--pipeline", ga->pipeline, "clean each capture's cloud with this JSON array of filter stages instead")
      ->excludes(clean)->group("Measuring");
  g->add_option("--json", ga->json, "also write the tables as JSON here")->group("Output");
  g->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      const auto given = ga->flags.Given();
      if (given.count("hard") + given.count("random") + given.count("paper") + given.count("gardens") > 1) {
        throw Error("--hard, --random, --paper and --gardens: give one set of gardens");
      }
      bench::GardenOptions::Table().Apply(given, &ga->garden);
      if (!ga->clean) ga->garden.cleaning = "[]";
      if (!ga->pipeline.empty()) ga->garden.cleaning = ReadFilterStagesFile(ga->pipeline);
      const bench::GardenResult result = bench::RunGarden(ga->garden);
      bench::PrintGarden(result);
      if (!ga->json.empty()) cloud::WriteTextFileAtomic(ga->json, bench::GardenJson(result));
      return kExitOk;
    };
  });
}

// A bench whose flags are all its options table's (in `group`): run, print, and the JSON with --json.
template <class Options, class Result>
void AddTableBench(CLI::App* cmd, CommandFn* run, const char* group, Result (*bench_run)(const Options&),
                   void (*print)(const Result&), std::string (*to_json)(const Result&)) {
  struct Args {
    Options o;
    StageFlags flags;
    std::string json;
  };
  auto a = std::make_shared<Args>();
  a->flags.Add(cmd, Options::Table().Specs(), {}, group);
  cmd->add_option("--json", a->json, "also write the table as JSON here")->group("Output");
  cmd->callback([=]() {
    *run = [=]() {
      fitting::QuietSolverWarnings();
      Options::Table().Apply(a->flags.Given(), &a->o);
      const Result result = bench_run(a->o);
      print(result);
      if (!a->json.empty()) cloud::WriteTextFileAtomic(a->json, to_json(result));
      return kExitOk;
    };
  });
}

void AddFindBench(CLI::App* bench, CommandFn* run) {
  auto* cmd = bench->add_subcommand(
      "find", "Simulated garden scans (16- and 32-beam LiDAR driving past, a terrestrial scanner, a photogrammetry "
              "model): every ball found, nothing else called one, radius, centre and ground against the truth");
  cmd->footer(
      "Examples:\n"
      "  hedgefit bench find                       # 3 gardens per sensor, about a minute\n"
      "  hedgefit bench find --sensors lidar16 --gardens 10 --json find.json\n"
      "  hedgefit bench find --gardens 1 --dir build/scans   # also write the scans (PLY, metres) and truths\n");
  AddTableBench(cmd, run, "Scans", bench::RunFindBench, bench::PrintFindBench, bench::FindBenchJson);
}

void AddAroundBench(CLI::App* bench, CommandFn* run) {
  auto* cmd = bench->add_subcommand(
      "around", "Rings and arcs of captures around a hedge ball and a row of two, with true and odometry-like poses: "
                "fused radius, centre, coverage, registered poses and the trim plan against the truth");
  cmd->footer(
      "Examples:\n"
      "  hedgefit bench around                                  # hedgefit's renderer, ~10 minutes the first time\n"
      "  hedgefit bench around --renderer povray --scenes single --captures 4 --json around-pov.json\n"
      "  hedgefit bench around --scenes bulge --layouts ring --captures 6 --registration centres+gicp\n"
      "Captures, manifests (exact and odometry), TUM trajectories and truths are kept in --dir and reused while\n"
      "their stamp says today's build rendered them with these options (else rendered again).\n");
  AddTableBench(cmd, run, "Sets", bench::RunAroundBench, bench::PrintAroundBench, bench::AroundBenchJson);
}

}  // namespace

void AddBenchCommand(CLI::App& app, CommandFn* run) {
  auto* bench = app.add_subcommand("bench", kBenchAbout);
  bench->require_subcommand(1);
  AddLabBench(bench, run);
  AddGardenBench(bench, run);
  AddFindBench(bench, run);
  AddAroundBench(bench, run);
}

}  // namespace hedgefit::bench_cli
