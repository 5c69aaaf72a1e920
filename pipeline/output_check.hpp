#pragma once
/// Checks of an output path before any work, so that a bad one fails at once, names the flag or
/// option the user gave, and nothing already computed is lost to it.

#include <string>
#include <vector>

namespace hedgefit::pipeline {

/// Checks that the directory `path` would be written into exists, before any work:
/// "`flag` PATH: directory 'D' does not exist; create it first".
/// A path that is a directory is refused the same way ("give a file name in it").
void CheckOutputDirectory(const std::string& flag, const std::string& path);

/// CheckOutputDirectory, and the name ends in one of `extensions` (".png", ".jpg": any case),
/// which is the format written; and it names none of `inputs`.
void CheckImageOutput(const std::string& flag, const std::string& path, const std::vector<std::string>& extensions,
                      const std::vector<std::string>& inputs = {});

/// An output that is one of the command's own input files (the same file by any path) is
/// refused: an overlay written over the camera's image would lose the capture.
void CheckNotAnInput(const std::string& flag, const std::string& path, const std::vector<std::string>& inputs);

}  // namespace hedgefit::pipeline
