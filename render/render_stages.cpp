#include "render/render_stages.hpp"

#include <sstream>

#include "fitting/sphere_fit.hpp"
#include "cloud/option_table.hpp"
#include "render/render.hpp"

namespace hedgefit::render {

void RegisterRenderStages(cloud::Registry& r) {
  using namespace hedgefit::cloud;
  const std::string name = "writers.png";
  StageInfo info{name,
                 "Renders the 'cloud' artifact and every converged fit in 'fits' to PNG, off-screen (VTK)",
                 TableOptions<RenderOptions>({StringOption("filename", "", "PNG to write")}),
                 {"cloud"},
                 {},
                 {".png"}};
  r.Add(info, [name](const Options& o) -> std::unique_ptr<Stage> {
    if (o.GetString("filename").empty()) throw Error("stage '" + name + "', option 'filename': give the PNG to write");
    RenderOptions ro;
    try {
      ro = RenderOptions::Table().FromOptions(o);
    } catch (const Error& e) {
      throw Error("stage '" + name + "', " + e.what());
    }
    ro = CheckedParams(ro, name);
    const std::string file = o.GetString("filename");
    return std::make_unique<LambdaStage>(o, [ro, file](const Options&, Context& ctx) {
      std::vector<SphereOverlay> spheres;
      if (const auto* fits = ctx.Find<std::vector<fitting::SphereFitResult>>("fits")) {
        for (const auto& f : *fits) {
          if (f.converged) spheres.push_back(SphereOverlay{f.method, f.sphere, false});
        }
      }
      RenderOptions run = ro;
      if (!spheres.empty()) run.distance_sphere = spheres.back().sphere;  // the pipeline's last fit
      RenderToPng(ctx.Get<PointCloud>("cloud"), spheres, run, ctx.OutputPath(file));
      ctx.Note("filename", file);
      ctx.Note("spheres", static_cast<std::int64_t>(spheres.size()));
    });
  });
}

}  // namespace hedgefit::render
