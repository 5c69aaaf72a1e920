// PLY: PCL's reader; binary through PCL's writer, ASCII by hand (PCL's prints 6 digits).

#include <pcl/io/ply_io.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "cloud/cloud_formats.hpp"
#include "cloud/error.hpp"
#include "cloud/pcl_adapter.hpp"

namespace hedgefit::cloud::internal {

namespace {

// PCL's PLY reader reads a word as NaN, and a header that lists fewer vertices than the file
// holds silently drops the rest: the header and (for ASCII) every vertex row are checked here
// first, and a header promising more data than the file can hold is refused before anything
// is allocated.
void CheckPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const auto file_size = static_cast<std::uint64_t>(std::filesystem::file_size(path));
  std::string line, format;
  std::size_t line_no = 0;
  struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::uint64_t properties = 0, bytes = 0;
    bool has_list = false;
  };
  std::vector<Element> elements;
  bool ended = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (line_no == 1) {
      if (key != "ply") throw Error(path + ": not a PLY file (the first line is not 'ply')");
      continue;
    }
    if (key == "format") {
      ss >> format;
    } else if (key == "element") {
      Element e;
      std::string count;
      ss >> e.name >> count;
      char* end = nullptr;
      const unsigned long long n = std::strtoull(count.c_str(), &end, 10);
      if (count.empty() || *end != '\0' || count[0] == '-' || n > (1ull << 40)) {
        throw Error(path + ":" + std::to_string(line_no) + ": element '" + e.name + "' has no valid count");
      }
      e.count = n;
      elements.push_back(e);
    } else if (key == "property") {
      if (elements.empty()) throw Error(path + ":" + std::to_string(line_no) + ": a property before any element");
      std::string type;
      ss >> type;
      Element& e = elements.back();
      ++e.properties;
      if (type == "list") {
        e.has_list = true;
      } else {
        static const std::map<std::string, int> sizes = {
            {"char", 1},  {"uchar", 1},  {"int8", 1},   {"uint8", 1},   {"short", 2},   {"ushort", 2},
            {"int16", 2}, {"uint16", 2}, {"int", 4},    {"uint", 4},    {"int32", 4},   {"uint32", 4},
            {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
        auto it = sizes.find(type);
        if (it == sizes.end()) throw Error(path + ":" + std::to_string(line_no) + ": unknown property type '" + type + "'");
        e.bytes += std::uint64_t(it->second);
      }
    } else if (key == "end_header") {
      ended = true;
      break;
    }
  }
  if (!ended) throw Error(path + ": malformed PLY header: no end_header line");
  if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") {
    throw Error(path + ": malformed PLY header: unknown format '" + format + "'");
  }
  auto vertex = std::find_if(elements.begin(), elements.end(), [](const Element& e) { return e.name == "vertex"; });
  if (vertex == elements.end()) throw Error(path + ": the PLY file has no 'vertex' element; expected x, y, z per vertex");
  const std::uint64_t data_bytes = file_size - static_cast<std::uint64_t>(in.tellg());
  if (format != "ascii") {
    std::uint64_t need = 0;
    for (const auto& e : elements) need += e.has_list ? 0 : e.count * e.bytes;
    if (need > data_bytes) {
      throw Error(path + ": truncated: the header promises " + std::to_string(vertex->count) + " vertices (" +
                  std::to_string(need) + " bytes) but only " + std::to_string(data_bytes) + " bytes follow it");
    }
    return;
  }
  if (vertex->count * vertex->properties > data_bytes) {
    throw Error(path + ": truncated: the header promises " + std::to_string(vertex->count) + " vertices but only " +
                std::to_string(data_bytes) + " bytes of text follow it");
  }
  if (vertex != elements.begin() || vertex->has_list) return;  // rows of other elements first: PCL checks
  std::uint64_t rows = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    if (rows == vertex->count) {
      if (elements.size() == 1) {
        throw Error(path + ":" + std::to_string(line_no) + ": more rows than the " + std::to_string(vertex->count) +
                    " vertices the header lists; fix 'element vertex'");
      }
      break;  // the next element's rows
    }
    std::istringstream ss(line);
    std::uint64_t n = 0;
    for (std::string tok; ss >> tok; ++n) {
      char* end = nullptr;
      std::strtod(tok.c_str(), &end);
      if (end == tok.c_str() || *end != '\0') {
        throw Error(path + ":" + std::to_string(line_no) + ": '" + tok.substr(0, 20) + "' is not a number");
      }
    }
    if (n != vertex->properties) {
      throw Error(path + ":" + std::to_string(line_no) + ": " + std::to_string(n) + " values, but a vertex has " +
                  std::to_string(vertex->properties) + " properties");
    }
    ++rows;
  }
  if (rows < vertex->count) {
    throw Error(path + ": the header lists " + std::to_string(vertex->count) + " vertices but the file holds " +
                std::to_string(rows) + " rows");
  }
}

PointCloud ReadPly(const std::string& path, CloudFileHeader* header) {
  CheckPly(path);
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  pcl::PLYReader reader;
  if (reader.read(path, blob, origin, orientation, version) < 0) {
    throw Error(path + ": malformed or truncated PLY file; expected a 'vertex' element with x, y, z");
  }
  header->encoding = "ply";
  return FromBlob(blob, path, header);
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

void WritePly(const std::string& path, const PointCloud& cloud, const WriteOptions& options) {
  if (!options.ply_binary) return WritePlyAscii(path, cloud, options.ascii_precision);
  pcl::PLYWriter writer;
  if (writer.writeBinary(path, ToPclBlob(cloud), Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity(), false) < 0) {
    throw Error(path + ": write failed; check free space and permissions");
  }
}

}  // namespace

CloudFormat PlyFormat() { return {"ply", "PLY (ascii or binary)", {".ply"}, ReadPly, WritePly, {"binary", "precision"}}; }

}  // namespace hedgefit::cloud::internal
