// hedgefit bench lab and bench garden: parse their flags and run bench/lab_bench.hpp and bench/garden_bench.hpp.

#include "apps/commands.hpp"
#include "apps/parse.hpp"
#include "cloud/cleaning.hpp"
#include "bench/garden_bench.hpp"
#include "bench/lab_bench.hpp"
#include "cloud/cloud_io.hpp"
#include "pipeline/error.hpp"
#include "pipeline/pipeline.hpp"

#include <fstream>
#include <sstream>

namespace hedgefit::apps {

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
    bool clean = false;
    std::string pipeline;
    std::string json;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("--dir", a->lab.dir, "where the simulated captures go")->capture_default_str();
  cmd->add_option("--scale", a->lab.scale, "image scale of the simulated rig")->check(CLI::Range(0.25, 2.0))->capture_default_str();
  cmd->add_option("--erode", a->lab.convert.segment.erode_px, "mask erosion, px (drops the silhouette ring)")
      ->check(CLI::Range(0, 200))
      ->capture_default_str();
  cmd->add_option("--refine-radius", a->lab.convert.match.sgbm.refine_radius,
                  "sub-pixel refinement window half-size, px (0 = off)")
      ->check(CLI::Range(0, 15))
      ->capture_default_str();
  cmd->add_option("--refine-curvature", a->lab.convert.match.sgbm.refine_curvature,
                  "curvature correction grid half-size, steps of 2 px (0 = off)")
      ->check(CLI::Range(0, 10))
      ->capture_default_str();
  cmd->add_option("--alpha", a->lab.alpha,
                  "rectification scaling (0 = only valid pixels, -1 = OpenCV's default): a rectified focal length "
                  "that differs from the camera's varies the resampling phase over the hedge")
      ->check(CLI::Range(-1.0, 1.0))
      ->capture_default_str();
  cmd->add_flag("--reuse", a->lab.reuse, "reuse captures already in --dir");
  cmd->add_flag("--wide-boards", a->lab.wide_boards,
                "also calibrate from 12 boards near the image's edges (simulate --preset wide-boards; rendered if missing)");
  cmd->add_flag("--true-rig", a->lab.true_rig,
                "use the simulator's exact rig instead of calibrating from the boards (separates calibration "
                "error from matching error)");
  cmd->add_option("--renderer", a->lab.renderer,
                  "hedgefit (its own simulator) or povray (an independent ray tracer: its own camera, textures, "
                  "lights, anti-aliasing)")
      ->check(CLI::IsMember({"hedgefit", "povray"}))
      ->capture_default_str();
  cmd->add_option("--camera", a->lab.camera,
                  "ideal (as rendered) or real (gains, white balance, vignetting, Bayer, shot and read noise per camera)")
      ->check(CLI::IsMember({"ideal", "real"}))
      ->capture_default_str();
  cmd->add_option("--noise-draws", a->lab.noise_draws,
                  "with --camera real: record each sphere N times, each with its own draw of the cameras' noise (the "
                  "same render and calibration), and summarise over all of them with the spread of one draw's 7 "
                  "captures; the as-rendered spheres are kept in --dir/as_rendered")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_option("--camera-without", a->lab.camera_without,
                  "with --camera real: leave these camera effects (gains, vignetting, bayer, noise, jpeg; comma-separated) "
                  "out of the spheres' pairs to see what each costs; the boards, and so the calibration, keep them all")
      ->delimiter(',');
  auto* clean = cmd->add_flag("--clean,!--no-clean", a->clean,
                               "clean each capture's cloud as `measure` and `compare` do by default before the "
                               "fits (default --no-clean: they see the matcher's cloud)");
  cmd->add_option("--pipeline", a->pipeline, "clean each capture's cloud with this JSON array of filter stages instead")
      ->excludes(clean);
  cmd->add_option("--json", a->json, "also write the table as JSON here");
  GroupFlags(cmd, {{"Captures", {"--dir", "--scale", "--reuse", "--wide-boards", "--renderer", "--camera", "--noise-draws", "--camera-without"}}, {"Measuring", {"--erode", "--refine-radius", "--refine-curvature", "--alpha", "--true-rig", "--clean", "--pipeline"}}, {"Output", {"--json"}}});
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);  // the captures run through the registry a plugin matcher joins
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
      "  hedgefit bench garden --random 12 --dir build/garden-random   # 12 gardens drawn from seeds 1..12\n");
  struct GardenArgs {
    bench::GardenOptions garden;
    bool clean = true;
    std::string pipeline;
    std::string json;
  };
  auto ga = std::make_shared<GardenArgs>();
  g->add_option("--dir", ga->garden.dir, "where the simulated captures go")->capture_default_str();
  g->add_option("--scale", ga->garden.scale, "image scale of the simulated rig")->check(CLI::Range(0.25, 2.0))->capture_default_str();
  g->add_flag("--reuse", ga->garden.reuse, "reuse captures already in --dir");
  g->add_option("--renderer", ga->garden.renderer,
                "hedgefit (its own ray caster, a noise-shaded leaf shell) or povray (POV-Ray, hedges of leaf discs)")
      ->check(CLI::IsMember({"hedgefit", "povray"}))
      ->capture_default_str();
  g->add_option("--camera", ga->garden.camera,
                "povray: ideal, or real (per-camera noise, gains, white balance, vignetting, Bayer)")
      ->check(CLI::IsMember({"ideal", "real"}))
      ->capture_default_str();
  auto* hard = g->add_flag("--hard", ga->garden.hard,
              "the harder gardens instead: two balls with the hedge row between them, a low and a high camera, the "
              "smallest ball farthest, the largest nearest, one near each edge of the image, one cut by it, three touching in a row, one among other shrubs");
  g->add_option("--random", ga->garden.random,
                "N gardens drawn from seeds 1..N instead (random1 ...): one to three balls of the issue's range side by "
                "side, a camera 0.9-1.4 m up, sometimes a shrub")
      ->check(CLI::Range(0, 200))
      ->excludes(hard);
  g->add_option("--garden-refine-curvature", ga->garden.convert.match.garden_refine_curvature,
                "curvature correction grid half-size for hedges found by depth, steps of 2 px (0 = off)")
      ->check(CLI::Range(0, 10))
      ->capture_default_str();
  auto* clean = g->add_flag("--clean,!--no-clean", ga->clean,
                            "clean each capture's cloud as `compare` does (the default), or with --no-clean fit it as "
                            "the matcher gives it");
  g->add_option("--pipeline", ga->pipeline, "clean each capture's cloud with this JSON array of filter stages instead")
      ->excludes(clean);
  g->add_option("--json", ga->json, "also write the tables as JSON here");
  GroupFlags(g, {{"Captures", {"--dir", "--scale", "--reuse", "--renderer", "--camera", "--hard", "--random"}}, {"Measuring", {"--garden-refine-curvature", "--clean", "--pipeline"}}, {"Output", {"--json"}}});
  g->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      if (!ga->clean) ga->garden.cleaning = "[]";
      if (!ga->pipeline.empty()) ga->garden.cleaning = ReadFilterStagesFile(ga->pipeline);
      const bench::GardenResult result = bench::RunGarden(ga->garden);
      bench::PrintGarden(result);
      if (!ga->json.empty()) cloud::WriteTextFileAtomic(ga->json, bench::GardenJson(result));
      return kExitOk;
    };
  });
}

}  // namespace

void AddBenchCommand(CLI::App& app, CommandFn* run) {
  auto* bench = app.add_subcommand("bench", "End-to-end benchmarks");
  AddLabBench(bench, run);
  AddGardenBench(bench, run);
}

}  // namespace hedgefit::apps
