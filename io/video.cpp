#include "io/video.hpp"

#include <dlfcn.h>

#include <filesystem>
#include <mutex>

#include "pipeline/error.hpp"

namespace hedgefit::io {

namespace {

using OpenFn = Video* (*)(const char*, int);

// Loaded once, never unloaded (a Video's code lives in it). Looked up beside this library (the
// build tree's io/, or the installed lib/), then on the run path, then beside the executable.
OpenFn LoadModule() {
  static std::once_flag once;
  static OpenFn open = nullptr;
  static std::string why;
  std::call_once(once, [] {
    const char* name = "libhedgefit_video.so";
    void* handle = nullptr;
    Dl_info self;
    if (dladdr(reinterpret_cast<const void*>(&OpenVideo), &self) != 0 && self.dli_fname != nullptr) {
      handle = dlopen((std::filesystem::path(self.dli_fname).parent_path() / name).c_str(), RTLD_NOW | RTLD_LOCAL);
    }
    if (handle == nullptr) handle = dlopen(name, RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      why = dlerror();
      std::error_code ec;
      const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
      if (!ec) handle = dlopen((exe.parent_path() / name).c_str(), RTLD_NOW | RTLD_LOCAL);
    }
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
