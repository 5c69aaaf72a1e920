#include "render/render_stages.hpp"

#include <sstream>

#include "fitting/sphere_fit.hpp"
#include "render/render.hpp"

namespace hedgefit::render {

void RegisterRenderStages(cloud::Registry& r) {
  using namespace hedgefit::cloud;
  const std::string name = "writers.png";
  StageInfo info{name,
                 "Renders the 'cloud' artifact and every converged fit in 'fits' to PNG, off-screen (VTK)",
                 {StringOption("filename", "", "PNG to write"),
                  StringOption("color", "own", "point colours").Choices({"own", "distance", "depth"}),
                  StringOption("view", "front", "front, side, top, iso, a comma list, or all"),
                  IntOption("width", 1024, "width of each view", "px").Range(16, 8192),
                  IntOption("height", 768, "height of each view", "px").Range(16, 8192),
                  DoubleOption("point_size", 2.0, "point size", "px").Range(0.1, 50),
                  BoolOption("wireframe", false, "draw fitted spheres as wireframes")},
                 {"cloud"},
                 {},
                 {".png"}};
  r.Add(info, [name](const Options& o) -> std::unique_ptr<Stage> {
    if (o.GetString("filename").empty()) throw Error("stage '" + name + "', option 'filename': give the PNG to write");
    RenderOptions ro;
    ro.color = ParseColorMode(o.GetString("color"));
    ro.views.clear();
    std::stringstream vs(o.GetString("view") == "all" ? std::string("front,side,top,iso") : o.GetString("view"));
    try {
      for (std::string v; std::getline(vs, v, ',');) ro.views.push_back(ParseView(v));
    } catch (const Error& e) {
      throw Error("stage '" + name + "', option " + e.what());
    }
    ro.width = static_cast<int>(o.GetInt("width"));
    ro.height = static_cast<int>(o.GetInt("height"));
    ro.point_size = o.GetDouble("point_size");
    ro.wireframe = o.GetBool("wireframe");
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
