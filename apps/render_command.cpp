// hedgefit render CLOUD: an off-screen VTK picture of a cloud and its fitted spheres.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli/capture_flags.hpp"
#include "apps/commands.hpp"
#include "cloud/describe.hpp"
#include "pipeline/output_check.hpp"
#include "cli/stage_flags.hpp"
#include "cli/parse.hpp"
#include "cloud/cloud_io.hpp"
#include "eval/compare.hpp"
#include "eval/evaluation.hpp"
#include "fitting/methods.hpp"
#include "render/render.hpp"

namespace hedgefit::apps {

namespace {

// The fits file's spheres as the picture draws them.
std::vector<render::SphereOverlay> ReadFits(const std::string& path, const std::string& cloud_path) {
  std::vector<render::SphereOverlay> out;
  for (const auto& f : eval::ReadCompareFits(path, cloud_path)) {
    out.push_back({f.label, f.sphere, f.truth, false, f.axes_mm, f.heading_deg, f.up, f.form});
  }
  return out;
}

}  // namespace

void AddRenderCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("render", "Render a cloud and its fitted spheres to PNG, off-screen (VTK)");
  cmd->footer(
      "Examples:\n"
      "  hedgefit compare sample_clouds/cap_z2300_a60_o30.pcd --format json > build/fits.json\n"
      "  hedgefit render sample_clouds/cap_z2300_a60_o30.pcd --fits build/fits.json -o build/cap.png\n"
      "  hedgefit render sample_clouds/cap_z2300_a60_o30.pcd --fits build/fits.json --color distance --view all\n"
      "No display is needed: without DISPLAY, hedgefit runs its own virtual X server (Xvfb).\n");
  struct Args {
    std::string cloud, fits, truth, output = "render.png", size = "1024x768", background = "255,255,255";
    double scale = 1.0;
    std::vector<std::string> methods;
    StageFlags flags;  // the render options, as declared in RenderOptions::Table()
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("CLOUD", a->cloud, "cloud file (" + cloud::CloudExtensionList() + ")")->required();
  cmd->add_option("--fits", a->fits, "fits to draw: the output of `hedgefit compare --format json`");
  cmd->add_option("--truth", a->truth, "true sphere JSON to draw (black wireframe)");
  cmd->add_option("-o,--output", a->output, "PNG to write")->capture_default_str();
  // --size and --background are the command line's spellings of width/height and background.
  a->flags.Add(cmd, render::RenderOptions::Table().Specs(),
               {"color", "field", "view", "point_size", "wireframe", "sphere_opacity", "distance_range"});
  cmd->add_option("--size", a->size, "WxH of each view, px")->capture_default_str();
  cmd->add_option("--background", a->background, "R,G,B in 0..255")->capture_default_str();
  cmd->add_option("--method,--methods", a->methods, "draw only these fits (comma-separated)")->delimiter(',');
  cmd->add_option("--scale", a->scale, "multiply coordinates on read (1000 for metre files)")->capture_default_str();
  GroupFlags(cmd, {{"Inputs", {"CLOUD", "--fits", "--truth", "--method", "--scale"}}, {"Picture", {"--color", "--field", "--view", "--point-size", "--wireframe", "--sphere-opacity", "--distance-range", "--size", "--background"}}, {"Output", {"--output"}}});
  cmd->callback([=]() {
    *run = [=]() {
      pipeline::CheckImageOutput("-o", a->output, {".png"}, {a->cloud, a->fits, a->truth});
      render::RenderOptions o;
      try {
        const auto specs = render::RenderOptions::Table().Specs();
        o = render::RenderOptions::Table().FromOptions(
            pipeline::ResolveOptions(pipeline::StageInfo{"render", "", specs, {}, {}, {}}, a->flags.Given(), "render"));
      } catch (const Error& e) {
        throw Error(AsFlagMessage(e.what()));
      }
      const auto [w, h] = ParseCount2(a->size, "--size", 1, "WIDTHxHEIGHT in px", "1024x768");
      o.width = w;
      o.height = h;
      const auto rgb = ParseNumbers(a->background, 3, "--background");
      for (int k = 0; k < 3; ++k) {
        if (!(rgb[std::size_t(k)] >= 0 && rgb[std::size_t(k)] <= 255)) {
          throw Error("--background '" + a->background + "': give R,G,B in 0..255, e.g. 255,255,255");
        }
        o.background[std::size_t(k)] = rgb[std::size_t(k)] / 255.0;
      }
      try {
        o.Check();
      } catch (const Error& e) {
        const std::string msg = e.what();
        if (msg.rfind("option 'width'", 0) == 0 || msg.rfind("option 'height'", 0) == 0) {
          throw Error("--size '" + a->size + "': each side must be 16..8192 px");
        }
        throw Error(AsFlagMessage(msg));
      }
      cloud::ReadOptions ro;
      ro.scale = a->scale;
      const cloud::PointCloud cloud = cloud::ReadCloud(a->cloud, ro);
      if (a->scale == 1.0) {
        if (const std::string why = cloud::MetresReason(cloud::LargestExtent(cloud), "read it with --scale 1000");
            !why.empty()) {
          throw InputError(a->cloud + ": " + why);
        }
      }
      std::vector<render::SphereOverlay> spheres;
      if (!a->fits.empty()) spheres = ReadFits(a->fits, a->cloud);
      for (const auto& m : a->methods) fitting::FindFitMethod(m, "--method");
      if (!a->methods.empty()) {
        std::vector<render::SphereOverlay> kept;
        for (const auto& s : spheres) {
          if (s.truth || std::find(a->methods.begin(), a->methods.end(), s.label) != a->methods.end()) kept.push_back(s);
        }
        spheres = kept;
      }
      if (!a->truth.empty()) {
        render::SphereOverlay t;
        t.label = "truth";
        t.truth = true;
        t.sphere = eval::ReadTruthFile(a->truth);
        spheres.push_back(t);
      }
      // Fits and truths are in the file's frame; a cloud shifted on reading is drawn in its own.
      for (auto& s : spheres) s.sphere.center_mm -= cloud.offset;
      o.label_offset_mm = cloud.offset;
      o.distance_sphere = render::MostTrustedSphere(spheres);
      render::RenderToPng(cloud, spheres, o, a->output);
      std::printf("wrote %s\n", a->output.c_str());
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
