#pragma once
/// Reading and writing point clouds: PCD (ascii, binary, binary_compressed), PLY
/// (ascii, binary) and XYZ text. Colour and extra scalar fields survive a round
/// trip. Writes go to a temporary file that is renamed into place, so a failure
/// never leaves a half-written output.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/option_table.hpp"
#include "cloud/point_cloud.hpp"

namespace hedgefit::cloud {

struct ReadOptions {
  double scale = 1.0;  ///< multiplies coordinates on read: 1000 turns a metre file into mm
  void Check() const;
};

/// What the file said about itself, beyond the points.
struct CloudFileHeader {
  std::string format;               ///< "pcd", "ply", "xyz": the CloudFormat's name
  std::vector<std::string> fields;  ///< field names as stored ("x", "y", "z", "rgb", ...)
  std::string encoding;             ///< "ascii", "binary", "binary_compressed", ...
  /// Where the sensor stood, in the file's own units and frame: a PCD's VIEWPOINT translation
  /// when it is not the origin (PCL writes the origin when it does not know).
  std::optional<Eigen::Vector3d> viewpoint;
};

/// Reads a cloud; throws Error with a one-line message naming the file on any problem.
PointCloud ReadCloud(const std::string& path, const ReadOptions& options = {},
                     CloudFileHeader* header = nullptr);

enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

struct WriteOptions {
  PcdEncoding pcd_encoding = PcdEncoding::kBinary;  ///< PCD only
  bool ply_binary = true;                           ///< PLY only
  int ascii_precision = 8;  ///< significant digits for text formats (float holds ~7)
  /// The writers' options, declared once; each format uses the ones it names.
  static const pipeline::OptionTable<WriteOptions>& Table();
};

/// One cloud file format: a file of its own (cloud/format_*.cpp) and one entry in
/// CloudFormats(). readers.NAME and writers.NAME are made from it.
struct CloudFormat {
  std::string name;                     ///< "pcd"
  std::string description;              ///< one line
  std::vector<std::string> extensions;  ///< lower case, with the dot; the first is the usual one
  /// Reads a checked, readable file; fills the header's encoding and fields.
  std::function<PointCloud(const std::string& path, CloudFileHeader* header)> read;
  /// Writes to `path` (a temporary name; WriteCloud renames it into place).
  std::function<void(const std::string& path, const PointCloud& cloud, const WriteOptions& options)> write;
  std::vector<std::string> write_options;  ///< which of WriteOptions::Table() apply
};

/// Every format, in the order messages list them.
const std::vector<CloudFormat>& CloudFormats();

/// ".pcd, .ply or .xyz": every format's usual extension, for messages and help.
std::string CloudExtensionList();

/// The format of a file name's extension; throws Error naming the file and the known extensions.
const CloudFormat& FormatFromPath(const std::string& path);

/// Writes atomically (temporary file + rename); throws Error naming the file.
void WriteCloud(const std::string& path, const PointCloud& cloud, const WriteOptions& options = {});

/// Writes `contents` to `path` atomically; used for JSON and other small outputs.
void WriteTextFileAtomic(const std::string& path, const std::string& contents);

/// pipeline::CheckOutputDirectory, and the name ends in a cloud format's extension (.pcd, .ply,
/// .xyz...), so a bad name fails before the work and names the flag, not the writer's temporary
/// file; and it names none of `inputs` (pipeline::CheckNotAnInput).
void CheckCloudOutput(const std::string& flag, const std::string& path, const std::vector<std::string>& inputs = {});

}  // namespace hedgefit::cloud
