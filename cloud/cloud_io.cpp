#include "cloud/cloud_io.hpp"

#include "pipeline/output_check.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "cloud/formats/formats.hpp"
#include "pipeline/error.hpp"
#include "cloud/pcl_adapter.hpp"

namespace hedgefit::cloud {

using pipeline::OptionTable;

namespace fs = std::filesystem;

namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

void CheckReadable(const std::string& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status)) throw Error(path + ": no such file; check the path");
  if (fs::is_directory(status)) throw Error(path + ": is a directory; give a cloud file (" + CloudExtensionList() + ")");
  if (!fs::is_regular_file(status)) throw Error(path + ": is not a regular file");
  if (fs::file_size(path, ec) == 0) throw Error(path + ": is empty (0 bytes); the file was not written completely");
  std::ifstream probe(path, std::ios::binary);
  if (!probe) throw Error(path + ": cannot be opened for reading; check its permissions");
}

}  // namespace

std::string CloudExtensionList() {
  std::string out;
  const auto& formats = CloudFormats();
  for (std::size_t i = 0; i < formats.size(); ++i) {
    out += (i == 0 ? "" : i + 1 == formats.size() ? " or " : ", ") + formats[i].extensions.front();
  }
  return out;
}

namespace internal {

PointCloud FromBlob(const pcl::PCLPointCloud2& blob, const std::string& path, CloudFileHeader* header) {
  for (const auto& f : blob.fields) header->fields.push_back(f.name);
  return FromPclBlob(blob, path);
}

}  // namespace internal

const std::vector<CloudFormat>& CloudFormats() {
  // The one list of formats: a new one is its own file and one entry here.
  static const std::vector<CloudFormat> formats = {internal::PcdFormat(), internal::PlyFormat(), internal::XyzFormat(), internal::LasFormat()};
  return formats;
}

const pipeline::OptionTable<WriteOptions>& WriteOptions::Table() {
  using O = WriteOptions;
  static const auto table =
      OptionTable<O>()
          .AddEnum("encoding", &O::pcd_encoding,
                   {{"ascii", PcdEncoding::kAscii}, {"binary", PcdEncoding::kBinary},
                    {"binary_compressed", PcdEncoding::kBinaryCompressed}},
                   "PCD data encoding")
          .Add("binary", &O::ply_binary, "binary little-endian (else ascii)")
          .Add("precision", &O::ascii_precision, "significant digits of text output", "digits").Range(1, 17);
  return table;
}

void ReadOptions::Check() const {
  if (!(std::isfinite(scale) && scale > 0)) {
    throw Error("scale: must be a positive number (1 for mm files, 1000 for metre files), got " + std::to_string(scale));
  }
}

const CloudFormat& FormatFromPath(const std::string& path) {
  const std::string ext = Lower(fs::path(path).extension().string());
  for (const auto& f : CloudFormats()) {
    if (std::find(f.extensions.begin(), f.extensions.end(), ext) != f.extensions.end()) return f;
  }
  throw Error(path + ": unknown cloud format '" + ext + "'; use " + CloudExtensionList());
}

PointCloud ReadCloud(const std::string& path, const ReadOptions& options, CloudFileHeader* header) {
  options.Check();
  CheckReadable(path);  // first: a directory or a missing file says so, whatever its name
  const CloudFormat& format = FormatFromPath(path);
  QuietPcl();
  CloudFileHeader info;
  info.format = format.name;
  PointCloud cloud;
  try {
    cloud = format.read(path, &info);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path + ": cannot be read: " + e.what());
  }
  if (cloud.empty()) throw Error(path + ": holds no points; nothing to process");
  cloud.CheckConsistent(path);
  if (options.scale != 1.0) {
    const float s = static_cast<float>(options.scale);
    for (auto& p : cloud.points_mm) p *= s;
    cloud.offset *= options.scale;
  }
  if (header) *header = info;
  return cloud;
}

void WriteTextFileAtomic(const std::string& path, const std::string& contents) {
  const fs::path target(path);
  const fs::path tmp = target.parent_path() / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()));
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw Error(path + ": cannot be written; check that its directory exists and is writable");
    out << contents;
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw Error(path + ": write failed (disk full?)");
    }
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(path + ": cannot be replaced: " + ec.message());
  }
}

void WriteCloud(const std::string& path, const PointCloud& cloud, const WriteOptions& options) {
  const CloudFormat& format = FormatFromPath(path);
  WriteOptions::Table().Validate(options);
  cloud.CheckConsistent(path);
  if (cloud.empty()) throw Error(path + ": refusing to write an empty cloud; an earlier stage removed every point");
  const fs::path target(path);
  std::error_code ec;
  if (fs::is_directory(target, ec)) throw Error(path + ": is a directory; give an output file name");
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  if (!fs::is_directory(dir, ec)) throw Error(path + ": directory '" + dir.string() + "' does not exist; create it first");
  // Same directory, so the final rename is atomic; same extension, so writers see the right type.
  const fs::path tmp = dir / ("." + target.stem().string() + ".tmp" + std::to_string(::getpid()) +
                              target.extension().string());
  QuietPcl();
  try {
    format.write(tmp.string(), cloud, options);
  } catch (const Error& e) {
    fs::remove(tmp, ec);
    std::string what = e.what();
    if (what.rfind(tmp.string(), 0) == 0) what = path + what.substr(tmp.string().size());
    throw Error(what);
  } catch (const std::exception& e) {
    fs::remove(tmp, ec);
    throw Error(path + ": write failed: " + e.what());
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(path + ": cannot be replaced: " + ec.message());
  }
}

void CheckCloudOutput(const std::string& flag, const std::string& path, const std::vector<std::string>& inputs) {
  pipeline::CheckOutputDirectory(flag, path);
  try {
    FormatFromPath(path);
  } catch (const Error&) {
    throw Error(flag + " " + path + ": not a cloud file name; end it in " + CloudExtensionList());
  }
  pipeline::CheckNotAnInput(flag, path, inputs);
}

}  // namespace hedgefit::cloud
