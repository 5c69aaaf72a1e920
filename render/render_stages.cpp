#include "render/render_stages.hpp"

#include <sstream>

#include "fitting/sphere_fit.hpp"
#include "pipeline/option_table.hpp"
#include "cloud/cloud_io.hpp"
#include "render/overlay.hpp"
#include "render/render.hpp"
#include "stereo/image_io.hpp"

#include <opencv2/imgproc.hpp>

#include <cctype>
#include <filesystem>

namespace hedgefit::render {

void RegisterRenderStages(pipeline::Registry& r) {
  using namespace hedgefit::cloud;
  using namespace hedgefit::pipeline;
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
        const Eigen::Vector3d offset = ctx.Get<PointCloud>("cloud").offset;  // fits are in the file's frame
        for (const auto& f : *fits) {
          if (!f.converged) continue;
          spheres.push_back(OverlayOf(f, f.method));
          spheres.back().sphere.center_mm -= offset;
        }
      }
      RenderOptions run = ro;
      run.label_offset_mm = ctx.Get<PointCloud>("cloud").offset;
      if (!spheres.empty()) run.distance_sphere = spheres.back().sphere;  // the pipeline's last fit
      RenderToPng(ctx.Get<PointCloud>("cloud"), spheres, run, ctx.OutputPath(file));
      ctx.Note("filename", file);
      ctx.Note("spheres", static_cast<std::int64_t>(spheres.size()));
    });
  });

  // The operator's picture from a capture pipeline: mask outline and fitted spheres drawn on
  // the rectified left image.
  const std::string overlay = "writers.overlay";
  r.Add(StageInfo{overlay,
                  "Draws the mask's outline and every converged fit (projected outline, centre, label, radius) on the "
                  "rectified left image, to PNG",
                  {StringOption("filename", "", "PNG to write"),
                   IntOption("line_width", 2, "line width", "px").Range(1, 20),
                   BoolOption("crop", false, "crop to the drawn spheres plus a quarter of their size around them")},
                  {"left_image", "rig", "fits"},
                  {},
                  {}},
        [overlay](const Options& o) -> std::unique_ptr<Stage> {
          const std::string file = o.GetString("filename");
          if (file.empty()) throw Error("stage '" + overlay + "', option 'filename': give the PNG to write");
          std::string ext = std::filesystem::path(file).extension().string();
          for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
          if (ext != ".png") {
            throw Error("stage '" + overlay + "', option 'filename': '" + file + "' must end in .png");
          }
          return std::make_unique<LambdaStage>(o, [file](const Options& opts, Context& ctx) {
            std::vector<SphereOverlay> spheres;
            for (const auto& f : ctx.Get<std::vector<fitting::SphereFitResult>>("fits")) {
              if (f.converged) {
                std::string label = f.hedge_id ? "hedge " + std::to_string(f.hedge_id) + " " + f.method : f.method;
                if (f.not_a_ball) label += " (not a ball)";
                spheres.push_back(OverlayOf(f, label));
              }
            }
            const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
            const cv::Mat picture = DrawOverlay(ctx.Get<cv::Mat>("left_image"), ctx.Get<stereo::StereoRig>("rig"),
                                                mask ? *mask : cv::Mat(), spheres, int(opts.GetInt("line_width")),
                                                opts.GetBool("crop"));
            std::vector<std::uint8_t> png;
            if (!stereo::EncodeImage(".png", picture, &png)) throw Error(file + ": cannot encode the overlay as PNG");
            cloud::WriteTextFileAtomic(ctx.OutputPath(file), std::string(png.begin(), png.end()));
            ctx.Note("filename", file);
            ctx.Note("spheres", static_cast<std::int64_t>(spheres.size()));
          });
        });
}

}  // namespace hedgefit::render
