// XYZ text: 'x y z [r g b]' per line.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "cloud/formats/formats.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::cloud::internal {

namespace {

// Reads x y z [r g b] lines; '#' or '//' start a comment; separators: spaces, tabs, commas.
PointCloud ReadXyz(const std::string& path) {
  std::ifstream in(path);
  PointCloud cloud;
  std::vector<Eigen::Vector3d> xyz;  // as written: shifted once all are read (SetPoints)
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
    xyz.emplace_back(v[0], v[1], v[2]);
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
  SetPoints(xyz, &cloud);
  cloud.Flatten();
  return cloud;
}

void WriteXyz(const std::string& path, const PointCloud& cloud, int precision) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot be opened for writing");
  char buf[160];
  const CoordinateText text(cloud, precision);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    int n = text.Print(buf, sizeof(buf), cloud.points_mm[i]);
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

PointCloud ReadXyzFile(const std::string& path, CloudFileHeader* header) {
  PointCloud cloud = ReadXyz(path);
  header->encoding = "ascii";
  header->fields = {"x", "y", "z"};
  if (cloud.HasColor()) header->fields.insert(header->fields.end(), {"r", "g", "b"});
  return cloud;
}

void WriteXyzFile(const std::string& path, const PointCloud& cloud, const WriteOptions& options) {
  WriteXyz(path, cloud, options.ascii_precision);
}

}  // namespace

CloudFormat XyzFormat() {
  return {"xyz", "text 'x y z [r g b]' per line", {".xyz", ".txt", ".csv"}, ReadXyzFile, WriteXyzFile, {"precision"}};
}

}  // namespace hedgefit::cloud::internal
