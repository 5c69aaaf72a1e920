#include "pipeline/module.hpp"

#include <dlfcn.h>

#include <filesystem>

namespace hedgefit::pipeline {

void* OpenOwnModule(const char* name, const void* anchor, std::string* why) {
  namespace fs = std::filesystem;
  void* handle = nullptr;
  Dl_info self;
  if (dladdr(anchor, &self) != 0 && self.dli_fname != nullptr) {
    handle = dlopen((fs::path(self.dli_fname).parent_path() / name).c_str(), RTLD_NOW | RTLD_LOCAL);
  }
  if (handle == nullptr) handle = dlopen(name, RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* e = dlerror();
    *why = e ? e : std::string(name) + " not found";
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) handle = dlopen((exe.parent_path() / name).c_str(), RTLD_NOW | RTLD_LOCAL);
  }
  return handle;
}

}  // namespace hedgefit::pipeline
