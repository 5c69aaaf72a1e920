#pragma once
/// Debian's VTK renders through X11 only. When DISPLAY is unset, hedgefit starts its own
/// virtual X server (Xvfb) for the life of the process, so off-screen rendering works on
/// machines with no display and users never need to know.

#include <string>

namespace hedgefit::render {

/// Makes sure an X display is available: uses DISPLAY if set, else starts Xvfb (once per
/// process; it is stopped at exit). Throws hedgefit::Error saying what to install if
/// neither works.
void EnsureDisplay();

}  // namespace hedgefit::render

class vtkRenderWindow;

namespace hedgefit::render {

/// Grabs `window`'s back buffer (RGB) and writes it to `png_path` via a temporary file and
/// a rename; throws hedgefit::Error naming the file.
void WriteWindowPng(vtkRenderWindow* window, const std::string& png_path);

}  // namespace hedgefit::render
