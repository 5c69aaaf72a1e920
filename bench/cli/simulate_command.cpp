// hedgefit simulate: render a stereo rig's view of a chessboard, a textured sphere or a preset
// (sim::Simulate; its options, and so these flags, are sim::SimulateRequest::Table()'s).

#include <cstdio>

#include "bench/cli/commands.hpp"
#include "cli/stage_flags.hpp"
#include "sim/simulate.hpp"

namespace hedgefit::bench_cli {

void AddSimulateCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("simulate", kSimulateAbout);
  cmd->footer(
      "Examples:\n"
      "  hedgefit simulate --preset paper-lab -o build/lab          # 16 board pairs + spheres at Z = 2000..2600 mm\n"
      "  hedgefit simulate --sphere 70,50,2300,300 -o build/sphere  # one capture, centre x,y,z and radius (mm)\n"
      "  hedgefit simulate --board 0.3,0.2,0,-150,-150,1200 -o build/board   # rotation vector (rad), translation (mm)\n"
      "  hedgefit simulate --board 0.2,-0.3,0,-200,-150,900 --squares 8x6 --square 60 --charuco 4x4_50 --marker 45 -o build/charuco\n"
      "  hedgefit simulate --preset garden -o build/garden         # leafy balls on a lawn: row, single, outdoor\n"
      "  hedgefit simulate --preset garden --renderer povray --camera real -o build/garden-povray   # leaf discs, POV-Ray\n"
      "The rig is the paper's (1920x1200, f 933.3 px, baseline 140 mm); --scale shrinks it.\n");
  auto flags = std::make_shared<StageFlags>();
  const auto specs = sim::SimulateRequest::Table().Specs();
  flags->Add(cmd, specs, {"preset", "renderer", "sphere", "board", "squares", "charuco", "marker", "square"}, "Scene");
  flags->Add(cmd, specs, {"output"}, "Output", {{"output", "-o,--output"}});
  flags->Add(cmd, specs, {}, "Camera");
  cmd->callback([=]() {
    *run = [=]() {
      sim::SimulateRequest r;
      sim::SimulateRequest::Table().Apply(flags->Given(), &r);
      try {
        std::printf("%s\n", sim::Simulate(r).c_str());
      } catch (const Error& e) {
        throw Error(AsFlagMessage(e.what()));  // option 'sphere' as typed: --sphere
      }
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::bench_cli
