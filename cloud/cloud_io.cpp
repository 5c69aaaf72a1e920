#include "cloud/cloud_io.hpp"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cloud/error.hpp"
#include "cloud/pcl_adapter.hpp"

namespace hedgefit::cloud {

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
  if (fs::is_directory(status)) throw Error(path + ": is a directory; give a cloud file (.pcd, .ply, .xyz)");
  if (!fs::is_regular_file(status)) throw Error(path + ": is not a regular file");
  if (fs::file_size(path, ec) == 0) throw Error(path + ": is empty (0 bytes); the file was not written completely");
  std::ifstream probe(path, std::ios::binary);
  if (!probe) throw Error(path + ": cannot be opened for reading; check its permissions");
}

// PCL's PCD reader trusts its input (a file with no header at all crashes it), so the
// header is checked here first: every field declared consistently, sizes and types
// known, and enough bytes behind it for the points it promises.
void CheckPcdHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const auto file_size = static_cast<std::uintmax_t>(fs::file_size(path));
  std::map<std::string, std::vector<std::string>> entries;
  std::string line;
  std::size_t line_no = 0;
  std::string data;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no > 64) break;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    const bool known = key == "VERSION" || key == "FIELDS" || key == "SIZE" || key == "TYPE" || key == "COUNT" ||
                       key == "WIDTH" || key == "HEIGHT" || key == "VIEWPOINT" || key == "POINTS" || key == "DATA";
    if (!known) {
      throw Error(path + ": not a PCD file (line " + std::to_string(line_no) + " starts with '" + key.substr(0, 20) +
                  "', expected a header keyword such as FIELDS)");
    }
    std::vector<std::string> values;
    for (std::string v; ss >> v;) values.push_back(v);
    entries[key] = values;
    if (key == "DATA") {
      data = values.empty() ? "" : values[0];
      break;
    }
  }
  if (data.empty()) throw Error(path + ": malformed PCD header: no DATA line (ascii, binary or binary_compressed)");
  if (data != "ascii" && data != "binary" && data != "binary_compressed") {
    throw Error(path + ": malformed PCD header: unknown DATA '" + data + "'");
  }
  for (const char* key : {"FIELDS", "SIZE", "TYPE", "WIDTH", "HEIGHT", "POINTS"}) {
    if (entries[key].empty()) throw Error(path + ": malformed PCD header: missing " + key);
  }
  const std::size_t nf = entries["FIELDS"].size();
  if (entries["SIZE"].size() != nf || entries["TYPE"].size() != nf ||
      (!entries["COUNT"].empty() && entries["COUNT"].size() != nf)) {
    throw Error(path + ": malformed PCD header: FIELDS, SIZE, TYPE and COUNT list different numbers of fields");
  }
  auto number = [&](const std::string& text, const char* what) {
    char* end = nullptr;
    const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
    if (end == text.c_str() || *end != '\0' || text[0] == '-' || v > (1ull << 40)) {
      throw Error(path + ": malformed PCD header: " + what + " '" + text + "' is not a valid count");
    }
    return static_cast<std::uint64_t>(v);
  };
  std::uint64_t point_size = 0;
  for (std::size_t i = 0; i < nf; ++i) {
    const std::uint64_t size = number(entries["SIZE"][i], "SIZE");
    const std::string& type = entries["TYPE"][i];
    const std::uint64_t count = entries["COUNT"].empty() ? 1 : number(entries["COUNT"][i], "COUNT");
    const bool ok = (type == "F" && (size == 4 || size == 8)) ||
                    ((type == "I" || type == "U") && (size == 1 || size == 2 || size == 4 || size == 8));
    if (!ok) {
      throw Error(path + ": malformed PCD header: field '" + entries["FIELDS"][i] + "' has TYPE " + type + " SIZE " +
                  entries["SIZE"][i]);
    }
    point_size += size * count;
  }
  const std::uint64_t width = number(entries["WIDTH"][0], "WIDTH");
  const std::uint64_t height = number(entries["HEIGHT"][0], "HEIGHT");
  const std::uint64_t points = number(entries["POINTS"][0], "POINTS");
  if (width * height != points) {
    throw Error(path + ": malformed PCD header: WIDTH*HEIGHT = " + std::to_string(width * height) + " but POINTS = " +
                std::to_string(points));
  }
  const auto data_start = static_cast<std::uint64_t>(in.tellg());
  if (data == "binary" && file_size < data_start + points * point_size) {
    throw Error(path + ": truncated: the header promises " + std::to_string(points) + " points (" +
                std::to_string(points * point_size) + " bytes) but only " + std::to_string(file_size - data_start) +
                " bytes follow it");
  }
  if (data == "binary_compressed" && points > 0) {
    std::uint32_t sizes[2] = {0, 0};
    in.read(reinterpret_cast<char*>(sizes), sizeof(sizes));
    if (!in || data_start + 8 + sizes[0] > file_size) {
      throw Error(path + ": truncated: compressed point data ends before the size its header gives");
    }
    if (sizes[1] != points * point_size) {
      throw Error(path + ": corrupt: compressed data unpack to " + std::to_string(sizes[1]) + " bytes, but " +
                  std::to_string(points) + " points need " + std::to_string(points * point_size));
    }
  }
}

// Reads x y z [r g b] lines; '#' or '//' start a comment; separators: spaces, tabs, commas.
PointCloud ReadXyz(const std::string& path) {
  std::ifstream in(path);
  PointCloud cloud;
  std::string line;
  std::size_t line_no = 0;
  int columns = -1;
  while (std::getline(in, line)) {
    ++line_no;
    const auto hash = line.find_first_of('#');
    if (hash != std::string::npos) line.erase(hash);
    if (line.rfind("//", 0) == 0) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::replace(line.begin(), line.end(), ';', ' ');
    std::istringstream ss(line);
    std::vector<double> v;
    std::string tok;
    while (ss >> tok) {
      char* end = nullptr;
      const double d = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str() || *end != '\0') {
        throw Error(path + ":" + std::to_string(line_no) + ": '" + tok +
                    "' is not a number; XYZ lines are 'x y z' or 'x y z r g b'");
      }
      v.push_back(d);
    }
    if (v.empty()) continue;
    if (v.size() != 3 && v.size() != 6) {
      throw Error(path + ":" + std::to_string(line_no) + ": " + std::to_string(v.size()) +
                  " values; XYZ lines are 'x y z' or 'x y z r g b'");
    }
    if (columns == -1) columns = static_cast<int>(v.size());
    if (static_cast<int>(v.size()) != columns) {
      throw Error(path + ":" + std::to_string(line_no) + ": " + std::to_string(v.size()) + " values but line 1 of data had " +
                  std::to_string(columns) + "; use one layout for the whole file");
    }
    cloud.points_mm.emplace_back(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
    if (columns == 6) {
      Rgb c;
      for (int k = 0; k < 3; ++k) {
        const double x = v[3 + k];
        if (!(x >= 0 && x <= 255)) {
          throw Error(path + ":" + std::to_string(line_no) + ": colour " + std::to_string(x) + " is outside 0..255");
        }
        c[k] = static_cast<std::uint8_t>(std::lround(x));
      }
      cloud.colors.push_back(c);
    }
  }
  if (in.bad()) throw Error(path + ": read error after line " + std::to_string(line_no));
  cloud.Flatten();
  return cloud;
}

void WriteXyz(const std::string& path, const PointCloud& cloud, int precision) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot be opened for writing");
  char buf[160];
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points_mm[i];
    int n = std::snprintf(buf, sizeof(buf), "%.*g %.*g %.*g", precision, p.x(), precision, p.y(), precision, p.z());
    out.write(buf, n);
    if (cloud.HasColor()) {
      n = std::snprintf(buf, sizeof(buf), " %d %d %d", cloud.colors[i][0], cloud.colors[i][1], cloud.colors[i][2]);
      out.write(buf, n);
    }
    out.put('\n');
  }
  out.flush();
  if (!out) throw Error(path + ": write failed (disk full?)");
}

// ASCII PLY with full float precision (PCL's ASCII PLY writer prints 6 digits, losing
// up to 0.005 mm at 2 m).
void WritePlyAscii(const std::string& path, const PointCloud& cloud, int precision) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot be opened for writing");
  out << "ply\nformat ascii 1.0\ncomment written by hedgefit\nelement vertex " << cloud.size()
      << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (cloud.HasColor()) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  std::vector<std::pair<std::string, const std::vector<float>*>> extra;
  for (const auto& [name, values] : cloud.fields) {
    if (values.empty()) continue;
    out << "property float " << name << "\n";
    extra.emplace_back(name, &values);
  }
  out << "end_header\n";
  char buf[64];
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points_mm[i];
    out.write(buf, std::snprintf(buf, sizeof(buf), "%.*g %.*g %.*g", precision, p.x(), precision, p.y(), precision, p.z()));
    if (cloud.HasColor()) {
      out.write(buf, std::snprintf(buf, sizeof(buf), " %d %d %d", cloud.colors[i][0], cloud.colors[i][1], cloud.colors[i][2]));
    }
    for (const auto& e : extra) out.write(buf, std::snprintf(buf, sizeof(buf), " %.*g", precision, (*e.second)[i]));
    out.put('\n');
  }
  out.flush();
  if (!out) throw Error(path + ": write failed (disk full?)");
}

}  // namespace

void ReadOptions::Check() const {
  if (!(std::isfinite(scale) && scale > 0)) {
    throw Error("scale: must be a positive number (1 for mm files, 1000 for metre files), got " + std::to_string(scale));
  }
}

CloudFormat FormatFromPath(const std::string& path) {
  const std::string ext = Lower(fs::path(path).extension().string());
  if (ext == ".pcd") return CloudFormat::kPcd;
  if (ext == ".ply") return CloudFormat::kPly;
  if (ext == ".xyz" || ext == ".txt" || ext == ".csv") return CloudFormat::kXyz;
  throw Error(path + ": unknown cloud format '" + ext + "'; use .pcd, .ply or .xyz");
}

PointCloud ReadCloud(const std::string& path, const ReadOptions& options, CloudFileHeader* header) {
  options.Check();
  const CloudFormat format = FormatFromPath(path);
  CheckReadable(path);
  QuietPcl();
  CloudFileHeader info;
  info.format = format;
  PointCloud cloud;
  try {
    if (format == CloudFormat::kXyz) {
      cloud = ReadXyz(path);
      info.encoding = "ascii";
      info.fields = {"x", "y", "z"};
      if (cloud.HasColor()) info.fields.insert(info.fields.end(), {"r", "g", "b"});
    } else {
      pcl::PCLPointCloud2 blob;
      Eigen::Vector4f origin;
      Eigen::Quaternionf orientation;
      int version = 0;
      int status = 0;
      if (format == CloudFormat::kPcd) {
        CheckPcdHeader(path);
        pcl::PCDReader reader;
        int data_type = 0;
        unsigned int data_idx = 0;
        if (reader.readHeader(path, blob, origin, orientation, version, data_type, data_idx) < 0) {
          throw Error(path + ": malformed PCD header; expected VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, POINTS, DATA");
        }
        info.encoding = data_type == 0 ? "ascii" : data_type == 1 ? "binary" : "binary_compressed";
        status = reader.read(path, blob, origin, orientation, version);
        if (status < 0) {
          throw Error(path + ": PCD data do not match its header (truncated or corrupt " + info.encoding + " data)");
        }
      } else {
        pcl::PLYReader reader;
        status = reader.read(path, blob, origin, orientation, version);
        if (status < 0) throw Error(path + ": malformed or truncated PLY file; expected a 'vertex' element with x, y, z");
        info.encoding = "ply";
      }
      for (const auto& f : blob.fields) info.fields.push_back(f.name);
      cloud = FromPclBlob(blob, path);
    }
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
  const CloudFormat format = FormatFromPath(path);
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
  int status = 0;
  try {
    if (format == CloudFormat::kXyz) {
      WriteXyz(tmp.string(), cloud, options.ascii_precision);
    } else {
      const pcl::PCLPointCloud2 blob = ToPclBlob(cloud);
      const Eigen::Vector4f origin = Eigen::Vector4f::Zero();
      const Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
      if (format == CloudFormat::kPcd) {
        pcl::PCDWriter writer;
        switch (options.pcd_encoding) {
          case PcdEncoding::kAscii:
            status = writer.writeASCII(tmp.string(), blob, origin, orientation, options.ascii_precision);
            break;
          case PcdEncoding::kBinary: status = writer.writeBinary(tmp.string(), blob, origin, orientation); break;
          case PcdEncoding::kBinaryCompressed:
            status = writer.writeBinaryCompressed(tmp.string(), blob, origin, orientation);
            break;
        }
      } else {
        if (options.ply_binary) {
          pcl::PLYWriter writer;
          status = writer.writeBinary(tmp.string(), blob, origin, orientation, false);
        } else {
          WritePlyAscii(tmp.string(), cloud, options.ascii_precision);  // PCL's prints 6 digits
        }
      }
    }
  } catch (const std::exception& e) {
    fs::remove(tmp, ec);
    throw Error(path + ": write failed: " + e.what());
  }
  if (status < 0) {
    fs::remove(tmp, ec);
    throw Error(path + ": write failed; check free space and permissions of " + dir.string());
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(path + ": cannot be replaced: " + ec.message());
  }
}

}  // namespace hedgefit::cloud
