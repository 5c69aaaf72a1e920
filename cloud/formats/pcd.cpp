// PCD: read by hand into PCL's blob layout (PCL's reader trusts its input), written by PCL's
// writer (from libhedgefit_pclio.so, pcl_io.hpp).

#include <pcl/PCLPointCloud2.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cloud/formats/formats.hpp"
#include "cloud/formats/pcl_io.hpp"
#include "pipeline/error.hpp"
#include "cloud/pcl_adapter.hpp"

namespace hedgefit::cloud::internal {

namespace fs = std::filesystem;

namespace {

// PCL's PCD reader trusts its input: a file with no header at all crashes it, and fuzzing found
// headers after blank "\r" lines that make it dereference null. So hedgefit reads PCD itself:
// the header checked (every field declared consistently, sizes and types known, enough bytes
// behind it for the points it promises), the data decoded into PCL's blob layout (LZF through
// PCL's lzfDecompress), and the blob converted as before.
struct PcdField {
  std::string name;
  std::uint64_t size = 4, count = 1;
  char type = 'F';
};

std::uint8_t PclType(char type, std::uint64_t size) {
  using F = pcl::PCLPointField;
  if (type == 'F') return size == 4 ? F::FLOAT32 : F::FLOAT64;
  if (type == 'I') return size == 1 ? F::INT8 : size == 2 ? F::INT16 : size == 4 ? F::INT32 : F::INT64;
  return size == 1 ? F::UINT8 : size == 2 ? F::UINT16 : size == 4 ? F::UINT32 : F::UINT64;
}

// Writes one text value into `out` as the field's binary type.
void StoreValue(const std::string& token, char type, std::uint64_t size, std::uint8_t* out) {
  const double v = std::strtod(token.c_str(), nullptr);
  auto put = [&](auto x) { std::memcpy(out, &x, sizeof(x)); };
  if (type == 'F') {
    if (size == 4) put(static_cast<float>(v)); else put(v);
    return;
  }
  // Integers: the text as an integer (strtoll keeps 64-bit values exact), clamped to the type.
  const bool is_signed = type == 'I';
  long double x = is_signed ? static_cast<long double>(std::strtoll(token.c_str(), nullptr, 10))
                            : static_cast<long double>(std::strtoull(token.c_str(), nullptr, 10));
  if (token.find_first_of(".eE") != std::string::npos || !std::isfinite(v)) x = std::isfinite(v) ? v : 0;
  auto clamp = [&](long double lo, long double hi) { return std::min(hi, std::max(lo, x)); };
  switch (size) {
    case 1: is_signed ? put(static_cast<std::int8_t>(clamp(-128, 127))) : put(static_cast<std::uint8_t>(clamp(0, 255))); break;
    case 2: is_signed ? put(static_cast<std::int16_t>(clamp(-32768, 32767))) : put(static_cast<std::uint16_t>(clamp(0, 65535))); break;
    case 4:
      is_signed ? put(static_cast<std::int32_t>(clamp(-2147483648.0L, 2147483647.0L)))
                : put(static_cast<std::uint32_t>(clamp(0, 4294967295.0L)));
      break;
    default:
      is_signed ? put(static_cast<std::int64_t>(clamp(-9.2e18L, 9.2e18L))) : put(static_cast<std::uint64_t>(clamp(0, 1.8e19L)));
  }
}

struct PcdHeader {
  std::map<std::string, std::vector<std::string>> entries;
  std::string data;  ///< ascii, binary or binary_compressed
};

// The header up to its DATA line (at most 64 lines); `line_no` counts the lines read.
PcdHeader ReadPcdHeader(std::istream& in, const std::string& path, std::size_t* line_no) {
  PcdHeader h;
  auto& entries = h.entries;
  std::string& data = h.data;
  std::string line;
  while (std::getline(in, line)) {
    ++*line_no;
    if (*line_no > 64) break;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    const bool known = key == "VERSION" || key == "FIELDS" || key == "SIZE" || key == "TYPE" || key == "COUNT" ||
                       key == "WIDTH" || key == "HEIGHT" || key == "VIEWPOINT" || key == "POINTS" || key == "DATA";
    if (!known) {
      throw Error(path + ": not a PCD file (line " + std::to_string(*line_no) + " starts with '" + key.substr(0, 20) +
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
  return h;
}

struct PcdLayout {
  std::vector<PcdField> fields;
  std::uint64_t point_size = 0, values_per_point = 0, width = 0, height = 0, points = 0;
};

// Checks the header's fields, sizes and counts, and lays the fields out in `blob`.
PcdLayout LayoutOf(PcdHeader& h, const std::string& path, pcl::PCLPointCloud2* blob) {
  auto& entries = h.entries;
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
  PcdLayout l;
  std::uint64_t& point_size = l.point_size;
  std::uint64_t& values_per_point = l.values_per_point;
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
  const std::uint64_t width = l.width = number(entries["WIDTH"][0], "WIDTH");
  const std::uint64_t height = l.height = number(entries["HEIGHT"][0], "HEIGHT");
  const std::uint64_t points = l.points = number(entries["POINTS"][0], "POINTS");
  if (width * height != points) {
    throw Error(path + ": malformed PCD header: WIDTH*HEIGHT = " + std::to_string(width * height) + " but POINTS = " +
                std::to_string(points));
  }
  if (width > 0xffffffffull || height > 0xffffffffull || point_size > (1u << 20)) {
    throw Error(path + ": malformed PCD header: WIDTH, HEIGHT or the point size is beyond what a PCD file can hold");
  }
  std::vector<PcdField>& fields = l.fields;
  blob->fields.clear();
  {
    std::uint64_t offset = 0;
    for (std::size_t i = 0; i < nf; ++i) {
      PcdField f;
      f.name = entries["FIELDS"][i];
      f.size = number(entries["SIZE"][i], "SIZE");
      f.type = entries["TYPE"][i][0];
      f.count = entries["COUNT"].empty() ? 1 : number(entries["COUNT"][i], "COUNT");
      pcl::PCLPointField pf;
      pf.name = f.name;
      pf.offset = static_cast<std::uint32_t>(offset);
      pf.datatype = PclType(f.type, f.size);
      pf.count = static_cast<std::uint32_t>(f.count);
      blob->fields.push_back(pf);
      offset += f.size * f.count;
      fields.push_back(f);
    }
  }
  return l;
}

// The text rows after the header into `blob`, each checked: PCL reads a token that is not a number
// as 0 and pads short rows with zeros. `bytes_left` is what follows the header.
void ReadAsciiPcd(std::istream& in, const std::string& path, std::size_t line_no, const PcdLayout& l,
                  std::uint64_t bytes_left, pcl::PCLPointCloud2* blob) {
  const std::uint64_t points = l.points, point_size = l.point_size, values_per_point = l.values_per_point;
  const std::vector<PcdField>& fields = l.fields;
  // Every value takes at least one byte: a header that promises
  // more points than the file can hold is refused before anything is allocated.
  if (points * values_per_point > bytes_left) {
    throw Error(path + ": truncated: the header promises " + std::to_string(points) + " points but only " +
                std::to_string(bytes_left) + " bytes of text follow it");
  }
  // PCL reads a token that is not a number as 0 and pads short rows with zeros: check each
  // row here, so bad values are an error naming the line, not points at the origin.
  std::string row;
  std::uint64_t rows = 0;  // line_no is at the DATA line
  blob->data.assign(std::size_t(points * point_size), 0);
  while (std::getline(in, row)) {
    ++line_no;
    if (!row.empty() && row.back() == '\r') row.pop_back();
    if (row.find_first_not_of(" \t") == std::string::npos) continue;
    std::istringstream ss(row);
    std::uint64_t n = 0;
    std::vector<std::string> tokens;
    for (std::string tok; ss >> tok; ++n) {
      char* end = nullptr;
      std::strtod(tok.c_str(), &end);
      const bool nan_word = tok == "nan" || tok == "NaN" || tok == "-nan" || tok == "inf" || tok == "-inf";
      if (!nan_word && (end == tok.c_str() || *end != '\0')) {
        throw Error(path + ":" + std::to_string(line_no) + ": '" + tok.substr(0, 20) + "' is not a number");
      }
      if (n < values_per_point) tokens.push_back(tok);
    }
    if (n == values_per_point && rows < points) {  // extra rows are counted, and refused below
      std::uint8_t* out = blob->data.data() + rows * point_size;
      std::size_t t = 0;
      for (const PcdField& f : fields) {
        for (std::uint64_t c = 0; c < f.count; ++c, ++t, out += f.size) StoreValue(tokens[t], f.type, f.size, out);
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

// LZF-compressed data, stored field by field, into `blob` one record per point.
void ReadCompressedPcd(std::istream& in, const std::string& path, std::uint64_t data_start, std::uint64_t file_size,
                       const PcdLayout& l, pcl::PCLPointCloud2* blob) {
  const std::uint64_t points = l.points, point_size = l.point_size;
  const std::vector<PcdField>& fields = l.fields;
  std::uint32_t sizes[2] = {0, 0};
  in.read(reinterpret_cast<char*>(sizes), sizeof(sizes));
  if (!in || data_start + 8 + sizes[0] > file_size) {
    throw Error(path + ": truncated: compressed point data ends before the size its header gives");
  }
  if (sizes[1] != points * point_size) {
    throw Error(path + ": corrupt: compressed data unpack to " + std::to_string(sizes[1]) + " bytes, but " +
                std::to_string(points) + " points need " + std::to_string(points * point_size));
  }
  std::vector<char> packed(sizes[0]), unpacked(sizes[1]);
  in.read(packed.data(), std::streamsize(packed.size()));
  if (!in) throw Error(path + ": truncated: compressed point data ends early");
  if (LoadPclIo(path).lzf_decompress(packed.data(), sizes[0], unpacked.data(), sizes[1]) != 0) {
    throw Error(path + ": corrupt: the compressed point data do not unpack (LZF)");
  }
  // Stored field by field (all points' x, then all y, ...): back to one record per point.
  blob->data.resize(std::size_t(points * point_size));
  std::uint64_t src = 0;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const std::uint64_t fsize = fields[i].size * fields[i].count, offset = blob->fields[i].offset;
    for (std::uint64_t k = 0; k < points; ++k, src += fsize) {
      std::memcpy(blob->data.data() + k * point_size + offset, unpacked.data() + src, std::size_t(fsize));
    }
  }
}

// The VIEWPOINT's translation (tx ty tz of tx ty tz qw qx qy qz), when given, finite and not the
// origin; else nothing.
std::optional<Eigen::Vector3d> ViewpointOf(const PcdHeader& h) {
  const auto it = h.entries.find("VIEWPOINT");
  if (it == h.entries.end() || it->second.size() < 3) return std::nullopt;
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k) {
    char* end = nullptr;
    v[k] = std::strtod(it->second[std::size_t(k)].c_str(), &end);
    if (end == it->second[std::size_t(k)].c_str() || *end != '\0') return std::nullopt;
  }
  if (!v.allFinite() || v.isZero()) return std::nullopt;
  return v;
}

void ParsePcd(const std::string& path, pcl::PCLPointCloud2* blob, std::string* encoding,
              std::optional<Eigen::Vector3d>* viewpoint) {
  std::ifstream in(path, std::ios::binary);
  const auto file_size = static_cast<std::uintmax_t>(fs::file_size(path));
  std::size_t line_no = 0;
  PcdHeader h = ReadPcdHeader(in, path, &line_no);
  *viewpoint = ViewpointOf(h);
  const std::string& data = h.data;
  const PcdLayout l = LayoutOf(h, path, blob);
  const std::uint64_t width = l.width, height = l.height, points = l.points, point_size = l.point_size;
  blob->width = static_cast<std::uint32_t>(width);
  blob->height = static_cast<std::uint32_t>(height);
  blob->point_step = static_cast<std::uint32_t>(point_size);
  blob->row_step = static_cast<std::uint32_t>(point_size * width);
  blob->is_bigendian = false;
  blob->is_dense = false;
  *encoding = data;
  const auto data_start = static_cast<std::uint64_t>(in.tellg());
  if (data == "binary" && file_size < data_start + points * point_size) {
    throw Error(path + ": truncated: the header promises " + std::to_string(points) + " points (" +
                std::to_string(points * point_size) + " bytes) but only " + std::to_string(file_size - data_start) +
                " bytes follow it");
  }
  if (data == "binary") {
    // PCL's writer pads the header to a page boundary in some versions: the data are the last
    // points * point_size bytes only when nothing else follows; PCL reads them right after the
    // header, and so does this.
    blob->data.resize(std::size_t(points * point_size));
    in.read(reinterpret_cast<char*>(blob->data.data()), std::streamsize(blob->data.size()));
    if (!in) throw Error(path + ": truncated binary point data");
  }
  if (data == "ascii") {
    ReadAsciiPcd(in, path, line_no, l, file_size - data_start, blob);
  }
  if (data == "binary_compressed" && points > 0) {
    ReadCompressedPcd(in, path, data_start, file_size, l, blob);
  } else if (data == "binary_compressed") {
    blob->data.clear();
  }
}

PointCloud ReadPcd(const std::string& path, CloudFileHeader* header) {
  pcl::PCLPointCloud2 blob;
  ParsePcd(path, &blob, &header->encoding, &header->viewpoint);
  return FromBlob(blob, path, header);
}

void WritePcd(const std::string& path, const PointCloud& cloud, const WriteOptions& options) {
  // A shifted cloud's coordinates are written as doubles in the file's frame (FIELDS x y z of
  // TYPE F SIZE 8, as PCL reads them), with the digits they need in text.
  const pcl::PCLPointCloud2 blob = ToPclBlob(cloud, true);
  const int precision = cloud.offset.isZero() ? options.ascii_precision : std::max(options.ascii_precision, 15);
  const int encoding = options.pcd_encoding == PcdEncoding::kAscii ? 0 : options.pcd_encoding == PcdEncoding::kBinary ? 1 : 2;
  const int status = LoadPclIo(path).write_pcd(path.c_str(), &blob, encoding, precision);
  if (status != 0) throw Error(path + ": write failed; check free space and permissions");
}

}  // namespace

CloudFormat PcdFormat() {
  return {"pcd", "PCD (ascii, binary, binary_compressed)", {".pcd"}, ReadPcd, WritePcd, {"encoding", "precision"}};
}

}  // namespace hedgefit::cloud::internal
