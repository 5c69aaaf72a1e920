#pragma once
/// Reading and writing point clouds: PCD (ascii, binary, binary_compressed), PLY
/// (ascii, binary) and XYZ text. Colour and extra scalar fields survive a round
/// trip. Writes go to a temporary file that is renamed into place, so a failure
/// never leaves a half-written output.

#include <string>
#include <vector>

#include "cloud/point_cloud.hpp"

namespace hedgefit::cloud {

enum class CloudFormat { kPcd, kPly, kXyz };

/// Format from a file name's extension (.pcd, .ply, .xyz/.txt/.csv); throws Error naming the file.
CloudFormat FormatFromPath(const std::string& path);

struct ReadOptions {
  double scale = 1.0;  ///< multiplies coordinates on read: 1000 turns a metre file into mm
  void Check() const;
};

/// What the file said about itself, beyond the points.
struct CloudFileHeader {
  CloudFormat format = CloudFormat::kPcd;
  std::vector<std::string> fields;  ///< field names as stored ("x", "y", "z", "rgb", ...)
  std::string encoding;             ///< "ascii", "binary", "binary_compressed", ...
};

/// Reads a cloud; throws Error with a one-line message naming the file on any problem.
PointCloud ReadCloud(const std::string& path, const ReadOptions& options = {},
                     CloudFileHeader* header = nullptr);

enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

struct WriteOptions {
  PcdEncoding pcd_encoding = PcdEncoding::kBinary;  ///< PCD only
  bool ply_binary = true;                           ///< PLY only
  int ascii_precision = 8;  ///< significant digits for text formats (float holds ~7)
};

/// Writes atomically (temporary file + rename); throws Error naming the file.
void WriteCloud(const std::string& path, const PointCloud& cloud, const WriteOptions& options = {});

/// Writes `contents` to `path` atomically; used for JSON and other small outputs.
void WriteTextFileAtomic(const std::string& path, const std::string& contents);

}  // namespace hedgefit::cloud
