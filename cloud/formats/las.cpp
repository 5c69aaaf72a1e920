// LAS (ASPRS LAS 1.0-1.4, point formats 0-10, uncompressed): the format airborne and terrestrial
// LiDAR, and most photogrammetry exports of survey work, come in. Read by hand from the
// specification (no LAS library is packaged in Debian 12): each coordinate is a 32-bit integer
// times the header's scale plus its offset, so georeferenced data keep their digits through the
// global shift (SetPoints). LAZ (LASzip-compressed) is refused with what to do instead.
//
// Written as LAS 1.2, point format 0 (or 2 with colour), in the cloud's own units and its file
// frame (the shift added back through the header's offsets), with intensity and classification
// when the cloud has those fields. LAS holds no NaN: non-finite points are left out, so an
// organised cloud is written unorganised.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <vector>

#include "cloud/formats/formats.hpp"
#include "pipeline/error.hpp"

namespace hedgefit::cloud::internal {

namespace {

namespace fs = std::filesystem;

// The public header's fields hedgefit reads, at their offsets in every version (1.4's point
// count at 247 when the legacy 32-bit one is 0).
constexpr std::size_t kHeaderMin = 227;      // LAS 1.0-1.2
constexpr std::size_t kHeader14Count = 247;  // LAS 1.4: uint64 number of point records

// The smallest record of each point format 0-10 (the specification's sizes; extra bytes may follow).
constexpr int kRecordSize[11] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
// Where a format's red, green and blue lie in its record (-1: none).
constexpr int kRgbAt[11] = {-1, -1, 20, 28, -1, 28, -1, 30, 30, -1, 30};

template <typename T>
T At(const std::vector<char>& b, std::size_t offset) {
  T v;
  std::memcpy(&v, b.data() + offset, sizeof(T));
  return v;
}

template <typename T>
void Put(std::vector<char>* b, std::size_t offset, T v) {
  std::memcpy(b->data() + offset, &v, sizeof(T));
}

PointCloud ReadLas(const std::string& path, CloudFileHeader* header) {
  std::ifstream in(path, std::ios::binary);
  const auto file_size = static_cast<std::uint64_t>(fs::file_size(path));
  if (file_size < kHeaderMin) throw Error(path + ": too short for a LAS header (" + std::to_string(file_size) + " bytes)");
  std::vector<char> h(kHeaderMin);
  in.read(h.data(), std::streamsize(h.size()));
  if (!in || std::memcmp(h.data(), "LASF", 4) != 0) throw Error(path + ": not a LAS file (no 'LASF' signature)");
  const int major = std::uint8_t(h[24]), minor = std::uint8_t(h[25]);
  const auto header_size = At<std::uint16_t>(h, 94);
  const auto data_at = At<std::uint32_t>(h, 96);
  const auto format_byte = At<std::uint8_t>(h, 104);
  const auto record = At<std::uint16_t>(h, 105);
  std::uint64_t points = At<std::uint32_t>(h, 107);
  if (format_byte & 0xC0) {
    throw Error(path + ": is LAZ (LASzip-compressed), which hedgefit does not read; decompress it first "
                "(`laszip -i IN.laz -o OUT.las`, or `pdal translate IN.laz OUT.las`)");
  }
  const int format = format_byte;
  if (major != 1 || minor > 4) {
    throw Error(path + ": LAS version " + std::to_string(major) + "." + std::to_string(minor) + "; hedgefit reads 1.0-1.4");
  }
  if (format > 10) throw Error(path + ": point format " + std::to_string(format) + " is not a LAS format (0-10)");
  if (header_size < kHeaderMin || header_size > file_size) {
    throw Error(path + ": header size " + std::to_string(header_size) + " is not within the file; the header is corrupt");
  }
  if (record < kRecordSize[format]) {
    throw Error(path + ": records of " + std::to_string(record) + " bytes, but point format " + std::to_string(format) +
                " needs " + std::to_string(kRecordSize[format]) + "; the header is corrupt");
  }
  if (points == 0 && minor >= 4 && header_size >= kHeader14Count + 8) {
    std::vector<char> h14(8);
    in.seekg(std::streamoff(kHeader14Count));
    in.read(h14.data(), 8);
    if (!in) throw Error(path + ": truncated LAS 1.4 header");
    points = At<std::uint64_t>(h14, 0);
  }
  if (data_at < header_size || data_at > file_size) {
    throw Error(path + ": its point data start at byte " + std::to_string(data_at) + ", outside the file; the header is corrupt");
  }
  if (points > (file_size - data_at) / record) {
    throw Error(path + ": truncated: the header promises " + std::to_string(points) + " points of " + std::to_string(record) +
                " bytes but " + std::to_string(file_size - data_at) + " bytes follow the header");
  }
  Eigen::Vector3d scale, offset;
  for (int k = 0; k < 3; ++k) scale(k) = At<double>(h, 131 + 8 * std::size_t(k)), offset(k) = At<double>(h, 155 + 8 * std::size_t(k));
  if (!scale.allFinite() || (scale.array() == 0).any() || !offset.allFinite()) {
    throw Error(path + ": its scale or offset is zero or not a number; the header is corrupt");
  }
  std::vector<char> data(std::size_t(points) * record);
  in.seekg(std::streamoff(data_at));
  in.read(data.data(), std::streamsize(data.size()));
  if (!in) throw Error(path + ": truncated point data");

  PointCloud cloud;
  std::vector<Eigen::Vector3d> xyz(static_cast<std::size_t>(points));
  std::vector<float>& intensity = cloud.fields["intensity"];
  std::vector<float>& classification = cloud.fields["classification"];
  intensity.resize(xyz.size()), classification.resize(xyz.size());
  const int rgb = kRgbAt[format];
  std::vector<std::array<std::uint16_t, 3>> colour(rgb >= 0 ? xyz.size() : 0);
  std::uint16_t brightest = 0;
  for (std::size_t i = 0; i < xyz.size(); ++i) {
    const std::size_t r = i * record;
    for (int k = 0; k < 3; ++k) xyz[i](k) = double(At<std::int32_t>(data, r + 4 * std::size_t(k))) * scale(k) + offset(k);
    intensity[i] = float(At<std::uint16_t>(data, r + 12));
    classification[i] = float(format >= 6 ? At<std::uint8_t>(data, r + 16) : (At<std::uint8_t>(data, r + 15) & 0x1F));
    if (rgb >= 0) {
      for (int k = 0; k < 3; ++k) colour[i][std::size_t(k)] = At<std::uint16_t>(data, r + std::size_t(rgb) + 2 * std::size_t(k));
      brightest = std::max({brightest, colour[i][0], colour[i][1], colour[i][2]});
    }
  }
  SetPoints(xyz, &cloud);
  // The specification's colours are 16-bit; some writers store 8-bit values in them.
  if (rgb >= 0) {
    cloud.colors.resize(colour.size());
    const int shift = brightest > 255 ? 8 : 0;
    for (std::size_t i = 0; i < colour.size(); ++i) {
      for (int k = 0; k < 3; ++k) cloud.colors[i][k] = std::uint8_t(colour[i][std::size_t(k)] >> shift);
    }
  }
  cloud.Flatten();
  header->encoding = "LAS " + std::to_string(major) + "." + std::to_string(minor) + ", point format " + std::to_string(format);
  header->fields = {"x", "y", "z", "intensity", "classification"};
  if (rgb >= 0) header->fields.insert(header->fields.end(), {"red", "green", "blue"});
  return cloud;
}

void WriteLas(const std::string& path, const PointCloud& cloud, const WriteOptions&) {
  if (fs::path(path).extension() == ".laz") {
    throw Error(path + ": hedgefit writes LAS, not LAZ (compressed); name it .las, and compress it with `laszip` if needed");
  }
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.points_mm[i].allFinite()) kept.push_back(i);
  }
  if (kept.empty()) throw Error(path + ": every point is NaN or infinite; LAS holds none of them");
  if (kept.size() > std::numeric_limits<std::uint32_t>::max()) throw Error(path + ": too many points for LAS 1.2");
  // The stored integers reach 2^31 at most: the scale is the finest power of ten that keeps the
  // farthest point (from the shift's offset) within 10^9, and at most 10^-4 of a unit.
  double reach = 1;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t i : kept) {
    const Eigen::Vector3d p = cloud.points_mm[i].cast<double>();
    reach = std::max(reach, p.cwiseAbs().maxCoeff());
    lo = lo.cwiseMin(p + cloud.offset), hi = hi.cwiseMax(p + cloud.offset);
  }
  const double scale = std::pow(10.0, std::max(-4.0, std::ceil(std::log10(reach / 1e9))));
  const bool colour = cloud.HasColor();
  const int format = colour ? 2 : 0;
  const std::uint16_t record = std::uint16_t(kRecordSize[format]);
  const auto intensity = cloud.fields.find("intensity");
  const auto classification = cloud.fields.find("classification");
  const bool has_intensity = intensity != cloud.fields.end() && !intensity->second.empty();
  const bool has_class = classification != cloud.fields.end() && !classification->second.empty();

  std::vector<char> h(kHeaderMin, 0);
  std::memcpy(h.data(), "LASF", 4);
  h[24] = 1, h[25] = 2;
  std::strncpy(h.data() + 26, "hedgefit", 32);
  std::strncpy(h.data() + 58, "hedgefit", 32);
  Put<std::uint16_t>(&h, 94, std::uint16_t(kHeaderMin));
  Put<std::uint32_t>(&h, 96, std::uint32_t(kHeaderMin));
  Put<std::uint8_t>(&h, 104, std::uint8_t(format));
  Put<std::uint16_t>(&h, 105, record);
  Put<std::uint32_t>(&h, 107, std::uint32_t(kept.size()));
  Put<std::uint32_t>(&h, 111, std::uint32_t(kept.size()));  // every point a first return
  for (int k = 0; k < 3; ++k) {
    Put<double>(&h, 131 + 8 * std::size_t(k), scale);
    Put<double>(&h, 155 + 8 * std::size_t(k), cloud.offset(k));
    Put<double>(&h, 179 + 16 * std::size_t(k), hi(k));
    Put<double>(&h, 187 + 16 * std::size_t(k), lo(k));
  }
  std::vector<char> data(kept.size() * record, 0);
  for (std::size_t n = 0; n < kept.size(); ++n) {
    const std::size_t i = kept[n], r = n * record;
    for (int k = 0; k < 3; ++k) {
      Put<std::int32_t>(&data, r + 4 * std::size_t(k), std::int32_t(std::llround(double(cloud.points_mm[i](k)) / scale)));
    }
    if (has_intensity) Put<std::uint16_t>(&data, r + 12, std::uint16_t(std::clamp(std::lround(intensity->second[i]), 0L, 65535L)));
    data[r + 14] = 0x09;  // return 1 of 1
    if (has_class) Put<std::uint8_t>(&data, r + 15, std::uint8_t(std::clamp(std::lround(classification->second[i]), 0L, 31L)));
    if (colour) {
      for (int k = 0; k < 3; ++k) Put<std::uint16_t>(&data, r + 20 + 2 * std::size_t(k), std::uint16_t(cloud.colors[i][k] * 257));
    }
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error(path + ": cannot be opened for writing");
  out.write(h.data(), std::streamsize(h.size()));
  out.write(data.data(), std::streamsize(data.size()));
  out.flush();
  if (!out) throw Error(path + ": write failed (disk full?)");
}

}  // namespace

CloudFormat LasFormat() {
  return {"las", "ASPRS LAS 1.0-1.4 (point formats 0-10; LAZ is refused)", {".las", ".laz"}, ReadLas, WriteLas, {}};
}

}  // namespace hedgefit::cloud::internal
