#include "io/video.hpp"

#include <dlfcn.h>

#include <mutex>

#include "pipeline/error.hpp"
#include "pipeline/module.hpp"

namespace hedgefit::io {

namespace {

using OpenFn = Video* (*)(const char*, int);

// Loaded once, never unloaded (a Video's code lives in it; pipeline::OpenOwnModule).
OpenFn LoadModule() {
  static std::once_flag once;
  static OpenFn open = nullptr;
  static std::string why;
  std::call_once(once, [] {
    const char* name = "libhedgefit_video.so";
    void* handle = pipeline::OpenOwnModule(name, reinterpret_cast<const void*>(&OpenVideo), &why);
    if (handle == nullptr) return;
    open = reinterpret_cast<OpenFn>(dlsym(handle, HEDGEFIT_VIDEO_ENTRY_SYMBOL));
    if (open == nullptr) why = std::string(name) + " has no " + HEDGEFIT_VIDEO_ENTRY_SYMBOL;
  });
  if (open == nullptr) {
    throw Error("video and cameras need hedgefit's video module, which cannot be loaded (" + why +
                "); reinstall hedgefit, or give captures with --watch");
  }
  return open;
}

}  // namespace

std::unique_ptr<Video> OpenVideo(const std::string& path, int device) {
  return std::unique_ptr<Video>(LoadModule()(path.c_str(), device));
}

}  // namespace hedgefit::io
