#include "render/vtk_module.hpp"

#include <dlfcn.h>

#include <mutex>

#include "pipeline/error.hpp"
#include "pipeline/module.hpp"

namespace hedgefit::render {

const VtkModule& LoadVtkModule(const std::string& png_path) {
  static std::once_flag once;
  static VtkModule m;
  static std::string why;
  std::call_once(once, [] {
    const char* name = "libhedgefit_vtk.so";
    void* handle = pipeline::OpenOwnModule(name, reinterpret_cast<const void*>(&LoadVtkModule), &why);
    if (handle == nullptr) return;
    m.render_png = reinterpret_cast<RenderPngFn>(dlsym(handle, HEDGEFIT_VTK_RENDER_SYMBOL));
    m.plot_errors = reinterpret_cast<PlotErrorsFn>(dlsym(handle, HEDGEFIT_VTK_PLOT_SYMBOL));
    if (!m.render_png || !m.plot_errors) m = VtkModule{}, why = std::string(name) + " lacks its entry points";
  });
  if (!m.render_png) {
    throw Error(png_path + ": pictures need hedgefit's VTK module, which cannot be loaded (" + why + "); reinstall hedgefit");
  }
  return m;
}

}  // namespace hedgefit::render
