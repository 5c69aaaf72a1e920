#pragma once
// libhedgefit_vtk.so: the pictures VTK draws (render_vtk.cpp, plot_vtk.cpp; its own X server,
// virtual_display.cpp). Debian's VTK is some forty libraries that take a tenth of a second to load,
// so they live in a module of their own, loaded the first time a picture is drawn; a command that
// draws none does not load them. Every entry point returns 0, or 1 with the reason in `why`.

#include <cstddef>
#include <string>
#include <vector>

#include "render/plot.hpp"
#include "render/render.hpp"

#define HEDGEFIT_VTK_RENDER_SYMBOL "hedgefit_vtk_render_png_v1"
#define HEDGEFIT_VTK_PLOT_SYMBOL "hedgefit_vtk_plot_errors_v1"

namespace hedgefit::render {

using RenderPngFn = int (*)(const cloud::PointCloud* cloud, const std::vector<SphereOverlay>* spheres,
                            const RenderOptions* options, const char* png_path, char* why, std::size_t why_size);
using PlotErrorsFn = int (*)(const std::vector<ErrorSeries>* series, const char* x_title, int width, int height,
                             const char* png_path, char* why, std::size_t why_size);

struct VtkModule {
  RenderPngFn render_png = nullptr;
  PlotErrorsFn plot_errors = nullptr;
};

/// The module's entry points, loaded on the first call (pipeline::OpenOwnModule). Throws
/// hedgefit::Error naming `png_path` when it cannot be loaded.
const VtkModule& LoadVtkModule(const std::string& png_path);

}  // namespace hedgefit::render
