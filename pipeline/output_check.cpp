#include "pipeline/output_check.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "pipeline/error.hpp"

namespace hedgefit::pipeline {

void CheckOutputDirectory(const std::string& flag, const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!path.empty() && (path.back() == '/' || fs::is_directory(path, ec))) {
    throw Error(flag + " " + path + ": is a directory; give a file name in it");
  }
  const fs::path dir = fs::path(path).parent_path();
  if (!dir.empty() && !fs::is_directory(dir, ec)) {
    throw Error(flag + " " + path + ": directory '" + dir.string() + "' does not exist; create it first");
  }
}

void CheckImageOutput(const std::string& flag, const std::string& path, const std::vector<std::string>& extensions,
                      const std::vector<std::string>& inputs) {
  CheckOutputDirectory(flag, path);
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (std::find(extensions.begin(), extensions.end(), ext) == extensions.end()) {
    std::string list;
    for (const std::string& e : extensions) list += (list.empty() ? "" : " or ") + e;
    throw Error(flag + " " + path + ": not an image file name this writes; end it in " + list);
  }
  CheckNotAnInput(flag, path, inputs);
}

void CheckNotAnInput(const std::string& flag, const std::string& path, const std::vector<std::string>& inputs) {
  std::error_code ec;
  for (const std::string& in : inputs) {
    if (!in.empty() && std::filesystem::equivalent(path, in, ec)) {
      throw Error(flag + " " + path + ": is the input " + in + "; write it to another file");
    }
  }
}

}  // namespace hedgefit::pipeline
