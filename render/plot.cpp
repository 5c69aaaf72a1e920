#include "render/plot.hpp"

#include <filesystem>

#include "pipeline/error.hpp"
#include "render/vtk_module.hpp"

namespace hedgefit::render {

void PlotErrors(const std::vector<ErrorSeries>& series, const std::string& x_title, int width, int height,
                const std::string& png_path) {
  namespace fs = std::filesystem;
  const fs::path target(png_path);
  std::error_code ec;
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  if (!fs::is_directory(dir, ec)) throw Error(png_path + ": directory '" + dir.string() + "' does not exist; create it first");
  if (series.empty()) throw Error(png_path + ": nothing to plot; give clouds with truth (CLOUD.truth.json or --truth)");
  if (width < 100 || height < 100) throw Error("plot size: at least 100 x 100 px");
  char why[1024] = "";
  if (LoadVtkModule(png_path).plot_errors(&series, x_title.c_str(), width, height, png_path.c_str(), why, sizeof(why)) != 0) {
    throw Error(why);
  }
}

}  // namespace hedgefit::render
