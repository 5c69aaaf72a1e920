// hedgefit pipeline FILE.json: run a PDAL-style pipeline.

#include <cstdio>
#include <iostream>

#include "apps/commands.hpp"
#include "cli/parse.hpp"
#include "cloud/cloud_io.hpp"
#include "pipeline/pipeline.hpp"

namespace hedgefit::apps {

void AddPipelineCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("pipeline", "Run a JSON pipeline of stages (readers, filters, fitters, writers)");
  cmd->footer(
      "Examples:\n"
      "  hedgefit pipeline examples/clean.json\n"
      "  hedgefit pipeline examples/clean.json --set filters.statistical_outlier.mean_k=30 --metadata run.json\n"
      "Stages and their options: hedgefit plugins\n");
  struct Args {
    std::string file;
    std::vector<std::string> sets;
    std::string metadata;
    std::uint64_t seed = 42;
    bool quiet = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("FILE", a->file, "pipeline JSON file")->required();
  cmd->add_option("--set", a->sets, "override an option: stage.option=value (stage = tag or type)");
  cmd->add_option("--metadata", a->metadata, "write the run's metadata JSON here");
  cmd->add_option("--seed", a->seed, "base random seed for stages that sample")->check(Seed());
  cmd->add_flag("-q,--quiet", a->quiet, "print nothing on success");
  GroupFlags(cmd, {{"Input", {"FILE", "--set", "--seed"}}, {"Output", {"--metadata", "--quiet"}}});
  cmd->callback([=]() {
    *run = [=]() {
      PrepareRegistry(true);
      pipeline::Pipeline pipeline = pipeline::Pipeline::FromFile(a->file, pipeline::Registry::Global(), a->sets);
      pipeline::Context ctx;
      ctx.seed = a->seed;
      ctx.quiet = a->quiet;
      const pipeline::RunReport report = pipeline.Run(ctx);
      if (!a->metadata.empty()) cloud::WriteTextFileAtomic(a->metadata, pipeline.MetadataJson(report, ctx));
      if (a->quiet) return kExitOk;
      std::printf("%-30s %10s %10s %10s  %s\n", "stage", "points in", "points out", "time ms", "notes");
      for (const auto& s : report.stages) {
        std::string notes;
        for (const auto& [k, v] : s.notes) {
          if (k == "points" || k == "kept") continue;  // already in the columns
          notes += (notes.empty() ? "" : ", ") + k + "=" + pipeline::ToString(v);
        }
        auto count = [](std::int64_t n) { return n < 0 ? std::string("-") : std::to_string(n); };
        std::printf("%-30s %10s %10s %10.1f  %s\n", s.label.c_str(), count(s.points_in).c_str(),
                    count(s.points_out).c_str(), s.wall_ms, notes.c_str());
      }
      std::printf("total %.1f ms\n", report.total_ms);
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
