#pragma once
/// Debian's VTK renders through X11 only. When DISPLAY is unset, hedgefit starts its own
/// virtual X server (Xvfb) for the life of the process, so off-screen rendering works on
/// machines with no display and users never need to know.

namespace hedgefit::render {

/// Makes sure an X display is available: uses DISPLAY if set, else starts Xvfb (once per
/// process; it is stopped at exit). Throws hedgefit::Error saying what to install if
/// neither works.
void EnsureDisplay();

}  // namespace hedgefit::render
