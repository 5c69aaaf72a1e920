#pragma once
/// Charts of fit errors, drawn off-screen with VTK's charts and written to PNG.

#include <string>
#include <vector>

#include "eval/compare.hpp"

namespace hedgefit::render {

/// One method's errors against truth, one entry per cloud (eval/compare.hpp).
using ErrorSeries = eval::ErrorSeries;

/// Two charts side by side: |AER| and LD against x, one line per method. `x_title`
/// names the x axis. Writes `png_path` atomically; throws hedgefit::Error.
void PlotErrors(const std::vector<ErrorSeries>& series, const std::string& x_title, int width, int height,
                const std::string& png_path);

}  // namespace hedgefit::render
