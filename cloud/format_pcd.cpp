// PCD through PCL, with the header checked first (PCL's reader trusts its input).

#include <pcl/io/pcd_io.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cloud/cloud_formats.hpp"
#include "cloud/error.hpp"
#include "cloud/pcl_adapter.hpp"

namespace hedgefit::cloud::internal {

namespace fs = std::filesystem;

namespace {

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
  std::uint64_t point_size = 0, values_per_point = 0;
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
    values_per_point += count;
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
  if (data == "ascii") {
    // Every value takes at least one byte: a header that promises
    // more points than the file can hold is refused before anything is allocated.
    if (points * values_per_point > file_size - data_start) {
      throw Error(path + ": truncated: the header promises " + std::to_string(points) + " points but only " +
                  std::to_string(file_size - data_start) + " bytes of text follow it");
    }
    // PCL reads a token that is not a number as 0 and pads short rows with zeros: check each
    // row here, so bad values are an error naming the line, not points at the origin.
    std::string row;
    std::uint64_t rows = 0;  // line_no is at the DATA line
    while (std::getline(in, row)) {
      ++line_no;
      if (!row.empty() && row.back() == '\r') row.pop_back();
      if (row.find_first_not_of(" \t") == std::string::npos) continue;
      std::istringstream ss(row);
      std::uint64_t n = 0;
      for (std::string tok; ss >> tok; ++n) {
        char* end = nullptr;
        std::strtod(tok.c_str(), &end);
        const bool nan_word = tok == "nan" || tok == "NaN" || tok == "-nan" || tok == "inf" || tok == "-inf";
        if (!nan_word && (end == tok.c_str() || *end != '\0')) {
          throw Error(path + ":" + std::to_string(line_no) + ": '" + tok.substr(0, 20) + "' is not a number");
        }
      }
      if (n != values_per_point) {
        throw Error(path + ":" + std::to_string(line_no) + ": " + std::to_string(n) + " values, but the header's " +
                    "fields need " + std::to_string(values_per_point) + " per point");
      }
      ++rows;
    }
    if (rows != points) {
      throw Error(path + ": the header promises " + std::to_string(points) + " points but the file holds " +
                  std::to_string(rows) + " rows; fix POINTS/WIDTH/HEIGHT or the data");
    }
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

PointCloud ReadPcd(const std::string& path, CloudFileHeader* header) {
  CheckPcdHeader(path);
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0, data_type = 0;
  unsigned int data_idx = 0;
  pcl::PCDReader reader;
  if (reader.readHeader(path, blob, origin, orientation, version, data_type, data_idx) < 0) {
    throw Error(path + ": malformed PCD header; expected VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, POINTS, DATA");
  }
  header->encoding = data_type == 0 ? "ascii" : data_type == 1 ? "binary" : "binary_compressed";
  if (reader.read(path, blob, origin, orientation, version) < 0) {
    throw Error(path + ": PCD data do not match its header (truncated or corrupt " + header->encoding + " data)");
  }
  return FromBlob(blob, path, header);
}

void WritePcd(const std::string& path, const PointCloud& cloud, const WriteOptions& options) {
  const pcl::PCLPointCloud2 blob = ToPclBlob(cloud);
  const Eigen::Vector4f origin = Eigen::Vector4f::Zero();
  const Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
  pcl::PCDWriter writer;
  int status = 0;
  switch (options.pcd_encoding) {
    case PcdEncoding::kAscii: status = writer.writeASCII(path, blob, origin, orientation, options.ascii_precision); break;
    case PcdEncoding::kBinary: status = writer.writeBinary(path, blob, origin, orientation); break;
    case PcdEncoding::kBinaryCompressed: status = writer.writeBinaryCompressed(path, blob, origin, orientation); break;
  }
  if (status < 0) throw Error(path + ": write failed; check free space and permissions");
}

}  // namespace

CloudFormat PcdFormat() {
  return {"pcd", "PCD (ascii, binary, binary_compressed)", {".pcd"}, ReadPcd, WritePcd, {"encoding", "precision"}};
}

}  // namespace hedgefit::cloud::internal
