// PLY: read by hand (PCL's reader aborts on malformed headers); binary written through PCL's
// writer (from libhedgefit_pclio.so, pcl_io.hpp), ASCII by hand (PCL's prints 6 digits).

#include <pcl/PCLPointCloud2.h>

#include <algorithm>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "cloud/formats/formats.hpp"
#include "cloud/formats/pcl_io.hpp"
#include "pipeline/error.hpp"
#include "cloud/pcl_adapter.hpp"

namespace hedgefit::cloud::internal {

namespace {

// The PLY reader is hedgefit's own: PCL's reads a word as NaN, silently drops vertices a header
// does not list, and aborts (assert) on headers whose obj_info num_cols x num_rows disagree with
// the vertex count, which fuzzing found. Every element is parsed or skipped by its declared
// properties; a header promising more data than the file holds is refused before anything is
// allocated.

struct Property {
  std::string name;
  int bytes = 0;            // scalar type's size; for a list, the items' size
  char kind = 'f';          // 'i' signed, 'u' unsigned, 'f' floating
  bool list = false;
  int count_bytes = 0;      // list: the count's size
  char count_kind = 'u';
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
  bool HasList() const {
    return std::any_of(properties.begin(), properties.end(), [](const Property& p) { return p.list; });
  }
  std::uint64_t Bytes() const {
    std::uint64_t b = 0;
    for (const auto& p : properties) b += std::uint64_t(p.list ? p.count_bytes : p.bytes);
    return b;
  }
};

bool ScalarType(const std::string& type, int* bytes, char* kind) {
  static const std::map<std::string, std::pair<int, char>> types = {
      {"char", {1, 'i'}},   {"int8", {1, 'i'}},   {"uchar", {1, 'u'}},  {"uint8", {1, 'u'}},    {"short", {2, 'i'}},
      {"int16", {2, 'i'}},  {"ushort", {2, 'u'}}, {"uint16", {2, 'u'}}, {"int", {4, 'i'}},      {"int32", {4, 'i'}},
      {"uint", {4, 'u'}},   {"uint32", {4, 'u'}}, {"float", {4, 'f'}},  {"float32", {4, 'f'}}, {"double", {8, 'f'}},
      {"float64", {8, 'f'}}};
  auto it = types.find(type);
  if (it == types.end()) return false;
  *bytes = it->second.first;
  *kind = it->second.second;
  return true;
}

// One binary value as a double.
double Decode(const char* p, int bytes, char kind, bool big_endian) {
  unsigned char b[8];
  for (int i = 0; i < bytes; ++i) b[i] = static_cast<unsigned char>(p[big_endian ? bytes - 1 - i : i]);
  switch (bytes) {
    case 1: return kind == 'i' ? double(static_cast<std::int8_t>(b[0])) : double(b[0]);
    case 2: {
      std::uint16_t v;
      std::memcpy(&v, b, 2);
      return kind == 'i' ? double(static_cast<std::int16_t>(v)) : double(v);
    }
    case 4: {
      std::uint32_t v;
      std::memcpy(&v, b, 4);
      if (kind == 'f') {
        float f;
        std::memcpy(&f, &v, 4);
        return double(f);
      }
      return kind == 'i' ? double(static_cast<std::int32_t>(v)) : double(v);
    }
    default: {
      double d;
      std::memcpy(&d, b, 8);
      return d;
    }
  }
}

namespace {

struct PlyHeader {
  std::string format;
  std::vector<Element> elements;
  long long cols = -1, rows_hint = -1;  // PCL's obj_info num_cols / num_rows: an organised cloud
};

// The header up to end_header; `line_no` counts the lines read.
PlyHeader ReadPlyHeader(std::istream& in, const std::string& path, std::size_t* line_no) {
  PlyHeader h;
  std::string line;
  bool ended = false;
  auto where = [&] { return path + ":" + std::to_string(*line_no); };
  while (std::getline(in, line)) {
    ++*line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (*line_no == 1) {
      if (key != "ply") throw Error(path + ": not a PLY file (the first line is not 'ply')");
      continue;
    }
    if (key == "format") {
      ss >> h.format;
    } else if (key == "element") {
      Element e;
      std::string count;
      ss >> e.name >> count;
      char* end = nullptr;
      const unsigned long long n = std::strtoull(count.c_str(), &end, 10);
      if (count.empty() || *end != '\0' || count[0] == '-' || n > (1ull << 40)) {
        throw Error(where() + ": element '" + e.name + "' has no valid count");
      }
      e.count = n;
      h.elements.push_back(e);
    } else if (key == "property") {
      if (h.elements.empty()) throw Error(where() + ": a property before any element");
      Property prop;
      std::string type;
      ss >> type;
      if (type == "list") {
        std::string count_type, item_type;
        ss >> count_type >> item_type;
        prop.list = true;
        if (!ScalarType(count_type, &prop.count_bytes, &prop.count_kind) || prop.count_kind == 'f' ||
            !ScalarType(item_type, &prop.bytes, &prop.kind)) {
          throw Error(where() + ": a list property needs an integer count type and an item type");
        }
      } else if (!ScalarType(type, &prop.bytes, &prop.kind)) {
        throw Error(where() + ": unknown property type '" + type + "'");
      }
      ss >> prop.name;
      if (prop.name.empty()) throw Error(where() + ": the property has no name");
      h.elements.back().properties.push_back(prop);
    } else if (key == "obj_info") {
      std::string what;
      long long v = -1;
      ss >> what >> v;
      if (what == "num_cols") h.cols = v;
      if (what == "num_rows") h.rows_hint = v;
    } else if (key == "end_header") {
      ended = true;
      break;
    } else if (key != "comment" && !key.empty()) {
      throw Error(where() + ": unknown PLY header line '" + line.substr(0, 40) + "'");
    }
  }
  if (!ended) throw Error(path + ": malformed PLY header: no end_header line");
  return h;
}

// Row `i` of element `e` in a text file (blank lines skipped) into `values`.
void ReadAsciiRow(std::istream& in, const std::string& path, std::size_t* line_no, const Element& e, std::uint64_t i,
                  std::vector<double>* values) {
  std::string line;
  auto where = [&] { return path + ":" + std::to_string(*line_no); };
  do {
    if (!std::getline(in, line)) {
      throw Error(path + ": the header lists " + std::to_string(e.count) + " " + (e.name == "vertex" ? std::string("vertices") : e.name + "s") +
                  " but the file holds " + std::to_string(i) + " rows");
    }
    ++*line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
  } while (line.find_first_not_of(" \t") == std::string::npos);
  std::istringstream ss(line);
  for (std::string tok; ss >> tok;) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') throw Error(where() + ": '" + tok.substr(0, 20) + "' is not a number");
    values->push_back(v);
  }
  if (!e.HasList() && values->size() != e.properties.size()) {
    throw Error(where() + ": " + std::to_string(values->size()) + " values, but a " + e.name + " has " +
                std::to_string(e.properties.size()) + " properties");
  }
}

// Row `i` of element `e` in a binary file into `values` (a list property reads as 0, its items skipped).
void ReadBinaryRow(std::istream& in, const std::string& path, const Element& e, std::uint64_t i, bool big,
                   std::vector<char>* buffer, std::vector<double>* values) {
  for (const Property& p : e.properties) {
    if (p.list) {
      buffer->resize(std::size_t(p.count_bytes));
      if (!in.read(buffer->data(), p.count_bytes)) throw Error(path + ": truncated in element '" + e.name + "'");
      const double n = Decode(buffer->data(), p.count_bytes, p.count_kind, big);
      if (n < 0 || n > 1e6) throw Error(path + ": a list in element '" + e.name + "' claims " + std::to_string(n) + " items");
      in.seekg(std::streamoff(n) * p.bytes, std::ios::cur);
      values->push_back(0);
      continue;
    }
    buffer->resize(std::size_t(p.bytes));
    if (!in.read(buffer->data(), p.bytes)) {
      throw Error(path + ": truncated: the data ends inside " + e.name + " " + std::to_string(i) + " of " +
                  std::to_string(e.count));
    }
    values->push_back(Decode(buffer->data(), p.bytes, p.kind, big));
  }
}

}  // namespace

PointCloud ReadPly(const std::string& path, CloudFileHeader* header) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open the file; check the path and permissions");
  const auto file_size = static_cast<std::uint64_t>(std::filesystem::file_size(path));
  std::string line;
  std::size_t line_no = 0;
  auto where = [&] { return path + ":" + std::to_string(line_no); };
  const PlyHeader h = ReadPlyHeader(in, path, &line_no);
  const std::string& format = h.format;
  const std::vector<Element>& elements = h.elements;
  const long long cols = h.cols, rows_hint = h.rows_hint;
  const bool ascii = format == "ascii", big = format == "binary_big_endian";
  if (!ascii && !big && format != "binary_little_endian") {
    throw Error(path + ": malformed PLY header: unknown format '" + format + "'");
  }
  auto vertex = std::find_if(elements.begin(), elements.end(), [](const Element& e) { return e.name == "vertex"; });
  if (vertex == elements.end()) throw Error(path + ": the PLY file has no 'vertex' element; expected x, y, z per vertex");
  int ix = -1, iy = -1, iz = -1, ir = -1, ig = -1, ib = -1;
  for (std::size_t k = 0; k < vertex->properties.size(); ++k) {
    const Property& p = vertex->properties[k];
    if (p.list) throw Error(path + ": vertex property '" + p.name + "' is a list; expected scalar properties");
    const std::string& n = p.name;
    if (n == "x") ix = int(k);
    if (n == "y") iy = int(k);
    if (n == "z") iz = int(k);
    if (n == "red" || n == "r" || n == "diffuse_red") ir = int(k);
    if (n == "green" || n == "g" || n == "diffuse_green") ig = int(k);
    if (n == "blue" || n == "b" || n == "diffuse_blue") ib = int(k);
  }
  if (ix < 0 || iy < 0 || iz < 0) throw Error(path + ": the vertex element has no x, y and z properties");
  const std::uint64_t data_bytes = file_size - static_cast<std::uint64_t>(in.tellg());
  // Size before allocating: binary scalars exactly; text at least a byte per value.
  std::uint64_t need = 0;
  for (const auto& e : elements) need += e.count * (ascii ? std::max<std::uint64_t>(1, e.properties.size()) : e.Bytes());
  if (need > data_bytes) {
    throw Error(path + ": truncated: the header promises " + std::to_string(vertex->count) + " vertices (" +
                std::to_string(need) + " bytes or more) but only " + std::to_string(data_bytes) + " bytes follow it");
  }
  const bool colour = ir >= 0 && ig >= 0 && ib >= 0;
  PointCloud cloud;
  std::vector<Eigen::Vector3d> xyz;  // as written: shifted once all are read (SetPoints)
  xyz.reserve(std::size_t(vertex->count));
  if (colour) cloud.colors.reserve(std::size_t(vertex->count));
  std::vector<std::pair<std::string, int>> extra;  // other scalar vertex properties -> fields
  for (std::size_t k = 0; k < vertex->properties.size(); ++k) {
    const int ki = int(k);
    if (ki == ix || ki == iy || ki == iz || (colour && (ki == ir || ki == ig || ki == ib))) continue;
    extra.emplace_back(vertex->properties[k].name, ki);
    cloud.fields[vertex->properties[k].name].reserve(std::size_t(vertex->count));
  }
  std::vector<double> values;
  std::vector<char> buffer;
  auto colour_byte = [](double v, const Property& p) {
    // Float colours are in [0, 1]; integer ones in [0, 255].
    const double c = p.kind == 'f' ? v * 255.0 : v;
    return static_cast<std::uint8_t>(std::clamp(std::lround(c), 0L, 255L));
  };
  for (const Element& e : elements) {
    const bool is_vertex = &e == &*vertex;
    // A binary element without properties holds no bytes, whatever its count (fuzzing found a
    // 1 kB file declaring 7.7 billion of them, which took 20 s to step through).
    if (!ascii && e.properties.empty()) continue;
    for (std::uint64_t i = 0; i < e.count; ++i) {
      values.clear();
      if (ascii) {
        ReadAsciiRow(in, path, &line_no, e, i, &values);
      } else {
        ReadBinaryRow(in, path, e, i, big, &buffer, &values);
      }
      if (!is_vertex) continue;
      xyz.emplace_back(values[std::size_t(ix)], values[std::size_t(iy)], values[std::size_t(iz)]);
      if (colour) {
        cloud.colors.push_back({colour_byte(values[std::size_t(ir)], vertex->properties[std::size_t(ir)]),
                                colour_byte(values[std::size_t(ig)], vertex->properties[std::size_t(ig)]),
                                colour_byte(values[std::size_t(ib)], vertex->properties[std::size_t(ib)])});
      }
      for (const auto& [name, k] : extra) cloud.fields[name].push_back(float(values[std::size_t(k)]));
    }
    if (is_vertex && ascii && elements.size() == 1) {
      // Nothing may follow the last vertex row but blank lines.
      while (std::getline(in, line)) {
        ++line_no;
        if (line.find_first_not_of(" \t\r") != std::string::npos) {
          throw Error(where() + ": more rows than the " + std::to_string(e.count) +
                      " vertices the header lists; fix 'element vertex'");
        }
      }
    }
  }
  SetPoints(xyz, &cloud);
  // PCL writes organised clouds with obj_info num_cols / num_rows.
  if (cols > 0 && rows_hint > 1 && std::uint64_t(cols) * std::uint64_t(rows_hint) == vertex->count) {
    cloud.width = static_cast<std::uint32_t>(cols);
    cloud.height = static_cast<std::uint32_t>(rows_hint);
  } else {
    cloud.Flatten();
  }
  header->encoding = ascii ? "ascii" : "binary";
  header->fields.clear();
  for (const auto& p : vertex->properties) header->fields.push_back(p.name);
  cloud.CheckConsistent(path);
  return cloud;
}

// ASCII PLY with full float precision (PCL's ASCII PLY writer prints 6 digits, losing
// up to 0.005 mm at 2 m).
void WritePlyAscii(const std::string& path, const PointCloud& cloud, int precision) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot be opened for writing");
  const CoordinateText text(cloud, precision);
  const bool shifted = text.Shifted();
  out << "ply\nformat ascii 1.0\ncomment written by hedgefit\nelement vertex " << cloud.size()
      << (shifted ? "\nproperty double x\nproperty double y\nproperty double z\n"
                  : "\nproperty float x\nproperty float y\nproperty float z\n");
  if (cloud.HasColor()) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  std::vector<std::pair<std::string, const std::vector<float>*>> extra;
  for (const auto& [name, values] : cloud.fields) {
    if (values.empty()) continue;
    out << "property float " << name << "\n";
    extra.emplace_back(name, &values);
  }
  out << "end_header\n";
  char buf[96];
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    out.write(buf, text.Print(buf, sizeof(buf), cloud.points_mm[i]));
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
  // A shifted cloud is written as text with its shift added back: PCL's binary writer stores floats.
  if (!options.ply_binary || !cloud.offset.isZero()) return WritePlyAscii(path, cloud, options.ascii_precision);
  const pcl::PCLPointCloud2 blob = ToPclBlob(cloud);
  if (LoadPclIo(path).write_ply(path.c_str(), &blob) != 0) {
    throw Error(path + ": write failed; check free space and permissions");
  }
}

}  // namespace

CloudFormat PlyFormat() { return {"ply", "PLY (ascii or binary)", {".ply"}, ReadPly, WritePly, {"binary", "precision"}}; }

}  // namespace hedgefit::cloud::internal
