// XYZ text: 'x y z [r g b]' per line, and the text layouts scanners and CloudCompare write.

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>

#include "cloud/formats/formats.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::cloud::internal {

namespace {

constexpr const char* kLayouts =
    "lines are 'x y z', 'x y z i', 'x y z r g b' or 'x y z i r g b' (Leica PTS), or give a first line naming the "
    "columns (x y z, and r g b or red green blue)";

// Where each column goes: x, y, z, and red, green and blue when the file has colour; the rest
// (intensity, normals, scalar fields) is read past.
struct Layout {
  std::size_t columns = 0;
  std::array<std::size_t, 3> xyz{0, 1, 2};
  std::optional<std::array<std::size_t, 3>> rgb;
};

// A headerless line's layout from its count of values, as PDAL's and CloudCompare's text readers
// and Leica's PTS take them.
std::optional<Layout> LayoutOfCount(std::size_t n) {
  Layout l;
  l.columns = n;
  if (n == 3 || n == 4) return l;
  if (n == 6) return l.rgb = std::array<std::size_t, 3>{3, 4, 5}, l;
  if (n == 7) return l.rgb = std::array<std::size_t, 3>{4, 5, 6}, l;
  return std::nullopt;
}

// The token as a number, or nullopt when it is not one whole.
std::optional<double> Number(const std::string& token) {
  char* end = nullptr;
  const double d = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0') return std::nullopt;
  return d;
}

// A header line's layout from its column names (any case, '//' or quotes about them); nullopt
// when they name no x, y and z.
std::optional<Layout> LayoutOfNames(const std::vector<std::string>& names) {
  Layout l;
  l.columns = names.size();
  std::array<std::optional<std::size_t>, 6> at;  // x y z r g b
  const std::array<std::vector<std::string>, 6> aliases = {{{"x"}, {"y"}, {"z"}, {"r", "red"}, {"g", "green"}, {"b", "blue"}}};
  for (std::size_t i = 0; i < names.size(); ++i) {
    std::string n;
    for (char c : names[i]) {
      if (c != '"' && c != '\'' && c != '/') n += char(std::tolower(static_cast<unsigned char>(c)));
    }
    for (std::size_t k = 0; k < aliases.size(); ++k) {
      if (!at[k] && std::find(aliases[k].begin(), aliases[k].end(), n) != aliases[k].end()) at[k] = i;
    }
  }
  if (!at[0] || !at[1] || !at[2]) return std::nullopt;
  l.xyz = {*at[0], *at[1], *at[2]};
  if (at[3] && at[4] && at[5]) l.rgb = std::array<std::size_t, 3>{*at[3], *at[4], *at[5]};
  return l;
}

// Reads x y z [r g b] lines; '#' or '//' start a comment (a first '//' line naming the columns,
// as CloudCompare writes, is the header); separators: spaces, tabs, commas, semicolons. A line of
// one whole number is a count (PTS writes one before each scan).
PointCloud ReadXyz(const std::string& path) {
  std::ifstream in(path);
  PointCloud cloud;
  std::vector<Eigen::Vector3d> xyz;  // as written: shifted once all are read (SetPoints)
  std::string line;
  std::size_t line_no = 0;
  std::optional<Layout> layout;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string where = path + ":" + std::to_string(line_no);
    const auto hash = line.find_first_of('#');
    if (hash != std::string::npos) line.erase(hash);
    const bool slashes = line.rfind("//", 0) == 0;
    if (slashes && (layout || !xyz.empty())) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::replace(line.begin(), line.end(), ';', ' ');
    std::istringstream ss(slashes ? line.substr(2) : line);
    std::vector<double> v;
    std::vector<std::string> tokens;
    std::optional<std::string> word;  // the first token that is not a number
    std::string tok;
    while (ss >> tok) {
      const std::optional<double> d = Number(tok);
      if (!d && !word) word = tok;
      tokens.push_back(tok);
      v.push_back(d.value_or(0.0));
    }
    if (tokens.empty()) continue;
    if (word || slashes) {
      // Only the first line before any point may name the columns; a '//' line that names no
      // x, y and z is a comment.
      if (layout || !xyz.empty()) throw Error(where + ": '" + *word + "' is not a number; " + kLayouts);
      layout = LayoutOfNames(tokens);
      if (!layout && !slashes) throw Error(where + ": the header names no x, y and z columns; " + kLayouts);
      continue;
    }
    if (v.size() == 1 && v[0] >= 0 && v[0] == std::floor(v[0])) continue;  // a PTS count
    if (!layout) {
      layout = LayoutOfCount(v.size());
      if (!layout) throw Error(where + ": " + std::to_string(v.size()) + " values; " + kLayouts);
    }
    if (v.size() != layout->columns) {
      throw Error(where + ": " + std::to_string(v.size()) + " values but the file's layout has " +
                  std::to_string(layout->columns) + "; use one layout for the whole file");
    }
    xyz.emplace_back(v[layout->xyz[0]], v[layout->xyz[1]], v[layout->xyz[2]]);
    if (layout->rgb) {
      Rgb c;
      for (int k = 0; k < 3; ++k) {
        const double x = v[(*layout->rgb)[std::size_t(k)]];
        if (!(x >= 0 && x <= 255)) throw Error(where + ": colour " + std::to_string(x) + " is outside 0..255");
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
  return {"xyz", "text 'x y z [r g b]' per line (read: also 'x y z i [r g b]', Leica PTS, a header naming the columns)",
          {".xyz", ".txt", ".csv", ".pts"}, ReadXyzFile, WriteXyzFile, {"precision"}};
}

}  // namespace hedgefit::cloud::internal
