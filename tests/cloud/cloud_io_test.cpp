// Cloud I/O: round trips for every format and encoding, colour and organisation
// preserved, bad files rejected with one-line messages naming the file, and writes
// that never leave half a file behind. PCL's own loader is the reference on real data.

#include "cloud/cloud_io.hpp"
#include "cloud/describe.hpp"
#include "cloud/outline_io.hpp"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstring>
#include <limits>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <fstream>
#include <cstdio>
#include <random>

#include "pipeline/error.hpp"
#include "tests/test_data.hpp"

namespace hedgefit::cloud {
using namespace hedgefit::pipeline;  // the framework's types, as before 0.3
namespace {

namespace fs = std::filesystem;

PointCloud RandomCloud(std::size_t n, bool color, std::uint32_t height, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(-3000.f, 3000.f);
  std::uniform_int_distribution<int> c(0, 255);
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    cloud.points_mm.emplace_back(u(rng), u(rng), u(rng));
    if (color) {
      cloud.colors.push_back(
          {static_cast<std::uint8_t>(c(rng)), static_cast<std::uint8_t>(c(rng)), static_cast<std::uint8_t>(c(rng))});
    }
  }
  cloud.height = height;
  cloud.width = static_cast<std::uint32_t>(n / height);
  return cloud;
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// Binary formats store float32 exactly; text formats print 8 significant digits,
// which recovers a float to within one unit in the last place.
void ExpectSamePoints(const PointCloud& a, const PointCloud& b, bool exact) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (exact) {
      ASSERT_EQ(a.points_mm[i], b.points_mm[i]) << "point " << i;
    } else {
      for (int k = 0; k < 3; ++k) {
        ASSERT_NEAR(a.points_mm[i][k], b.points_mm[i][k], std::abs(a.points_mm[i][k]) * 2e-7f + 1e-6f) << "point " << i;
      }
    }
  }
}

struct RoundTripCase {
  std::string extension;
  PcdEncoding encoding;
  bool ply_binary;
  bool exact;
};

void PrintTo(const RoundTripCase& c, std::ostream* os) { *os << c.extension; }

class RoundTrip : public ::testing::TestWithParam<RoundTripCase> {};

TEST_P(RoundTrip, PointsAndColourSurvive) {
  const RoundTripCase& c = GetParam();
  const fs::path dir = testing::ScratchDir();
  for (bool color : {false, true}) {
    const PointCloud in = RandomCloud(600, color, 1, 7);
    WriteOptions w;
    w.pcd_encoding = c.encoding;
    w.ply_binary = c.ply_binary;
    const std::string path = (dir / ("cloud" + c.extension)).string();
    WriteCloud(path, in, w);
    const PointCloud out = ReadCloud(path);
    ExpectSamePoints(in, out, c.exact);
    ASSERT_EQ(out.HasColor(), color);
    if (color) {
      EXPECT_EQ(in.colors, out.colors);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    Formats, RoundTrip,
    ::testing::Values(RoundTripCase{".pcd", PcdEncoding::kAscii, true, false},
                      RoundTripCase{".pcd", PcdEncoding::kBinary, true, true},
                      RoundTripCase{".pcd", PcdEncoding::kBinaryCompressed, true, true},
                      RoundTripCase{".ply", PcdEncoding::kBinary, true, true},
                      RoundTripCase{".ply", PcdEncoding::kBinary, false, false},
                      RoundTripCase{".xyz", PcdEncoding::kBinary, true, false}),
    [](const auto& test_info) {
      const auto& c = test_info.param;
      std::string name = c.extension.substr(1);
      if (c.extension == ".pcd") {
        name += c.encoding == PcdEncoding::kAscii ? "_ascii" : c.encoding == PcdEncoding::kBinary ? "_binary" : "_compressed";
      }
      if (c.extension == ".ply") name += c.ply_binary ? "_binary" : "_ascii";
      return name;
    });

TEST(CloudIo, OrganisedPcdKeepsStructureNansAndExtraFields) {
  const fs::path dir = testing::ScratchDir();
  PointCloud in = RandomCloud(40 * 30, true, 30, 3);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  in.points_mm[17] = Eigen::Vector3f(nan, nan, nan);
  in.fields["disparity"].resize(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) in.fields["disparity"][i] = 0.0625f * float(i);
  for (PcdEncoding e : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    WriteOptions w;
    w.pcd_encoding = e;
    const std::string path = (dir / "organised.pcd").string();
    WriteCloud(path, in, w);
    const PointCloud out = ReadCloud(path);
    EXPECT_EQ(out.width, 40u);
    EXPECT_EQ(out.height, 30u);
    EXPECT_TRUE(out.IsOrganized());
    EXPECT_FALSE(IsFinite(out.points_mm[17]));
    EXPECT_EQ(CountNonFinite(out), 1u);
    ASSERT_EQ(out.fields.count("disparity"), 1u);
    EXPECT_EQ(out.fields.at("disparity"), in.fields.at("disparity"));  // multiples of 1/16 print exactly
    EXPECT_EQ(out.colors, in.colors);
  }
}

TEST(CloudIo, ScaleConvertsMetresToMillimetres) {
  const fs::path dir = testing::ScratchDir();
  WriteText(dir / "m.xyz", "# metres\n1.5 -0.25 2.0\n0.001, 0.002, 0.003\n");
  ReadOptions r;
  r.scale = 1000;
  const PointCloud c = ReadCloud((dir / "m.xyz").string(), r);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_FLOAT_EQ(c.points_mm[0].x(), 1500.f);
  EXPECT_FLOAT_EQ(c.points_mm[0].y(), -250.f);
  EXPECT_FLOAT_EQ(c.points_mm[1].z(), 3.f);
  r.scale = -1;
  EXPECT_THROW(ReadCloud((dir / "m.xyz").string(), r), Error);
}

// The text layouts scanners and CloudCompare write: Leica's PTS (a count line before each scan,
// then 'x y z intensity r g b'), 'x y z intensity', and a header naming the columns in any order
// (CloudCompare's '//X,Y,Z,R,G,B', or names with semicolons). Each file holds the same two
// points, so every reading must give them exactly.
TEST(CloudIo, TextLayoutsOfScannersAndCloudCompare) {
  const fs::path dir = testing::ScratchDir();
  const std::vector<std::pair<std::string, std::string>> files = {
      {"scan.pts", "2\n1.5 -0.25 2 -1200 10 20 30\n4 5 6 -900 40 50 60\n"},
      {"two_scans.pts", "1\n1.5 -0.25 2 -1200 10 20 30\n1\n4 5 6 -900 40 50 60\n"},
      {"intensity.txt", "1.5 -0.25 2 0.7\n4 5 6 0.1\n"},
      {"cloudcompare.txt", "//X,Y,Z,R,G,B\n1.5,-0.25,2,10,20,30\n4,5,6,40,50,60\n"},
      {"named.csv", "Intensity;Z;Red;Green;Blue;X;Y\n0.7;2;10;20;30;1.5;-0.25\n0.1;6;40;50;60;4;5\n"},
      {"comment.xyz", "// exported by a scanner\n1.5 -0.25 2\n4 5 6\n"},
  };
  for (const auto& [name, text] : files) {
    WriteText(dir / name, text);
    const PointCloud c = ReadCloud((dir / name).string());
    ASSERT_EQ(c.size(), 2u) << name;
    EXPECT_EQ(c.points_mm[0], Eigen::Vector3f(1.5f, -0.25f, 2.f)) << name;
    EXPECT_EQ(c.points_mm[1], Eigen::Vector3f(4.f, 5.f, 6.f)) << name;
    const bool colour = name != "intensity.txt" && name != "comment.xyz";
    ASSERT_EQ(c.HasColor(), colour) << name;
    if (colour) {
      EXPECT_EQ(c.colors[0], (Rgb{10, 20, 30})) << name;
      EXPECT_EQ(c.colors[1], (Rgb{40, 50, 60})) << name;
    }
  }
}

// Every bad input: an Error whose one-line message names the file.
void ExpectReadError(const std::string& path, const std::string& fragment) {
  try {
    ReadCloud(path);
    FAIL() << "no error for " << path;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
  }
}

// A survey's export: metres in UTM, 0.1 mm in the text. A float steps by 0.5 m at 5.7e6; shifted
// on reading by a round offset (to 1000 m: the shifted points reach 242 m, where a float steps by
// 15 um), the points keep the text's 0.1 mm, and every text writer adds the shift back (printing
// 10 um digits). A PCD is written with double x y z (TYPE F SIZE 8) in each encoding, and read
// back shifted the same way.
TEST(CloudIo, UtmCoordinatesAreShiftedOnReadingAndWrittenBack) {
  const auto dir = hedgefit::testing::ScratchDir();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-8.0, 8.0);
  std::vector<Eigen::Vector3d> truth;
  {
    std::ofstream out(dir / "utm.xyz");
    char line[96];
    for (int i = 0; i < 500; ++i) {
      const Eigen::Vector3d p = Eigen::Vector3d(500123.0, 5701234.0, 48.0) + Eigen::Vector3d(u(rng), u(rng), u(rng) / 4);
      const int n = std::snprintf(line, sizeof(line), "%.4f %.4f %.4f\n", p.x(), p.y(), p.z());
      out.write(line, n);
      Eigen::Vector3d written;  // the text's value, 0.1 mm
      ASSERT_EQ(std::sscanf(line, "%lf %lf %lf", &written.x(), &written.y(), &written.z()), 3);
      truth.push_back(written);
    }
  }
  const PointCloud c = ReadCloud((dir / "utm.xyz").string());
  EXPECT_EQ(c.offset, Eigen::Vector3d(500000.0, 5701000.0, 0.0));  // the box's centre to the nearest 1000
  auto worst = [&](const PointCloud& cloud) {
    double w = 0;
    for (std::size_t i = 0; i < truth.size(); ++i) w = std::max(w, (cloud.points_mm[i].cast<double>() + cloud.offset - truth[i]).cwiseAbs().maxCoeff());
    return w;
  };
  EXPECT_LT(worst(c), 8e-6);  // half a float's step at 242
  for (const std::string name : {"back.ply", "back.xyz"}) {
    WriteCloud((dir / name).string(), c);
    const PointCloud b = ReadCloud((dir / name).string());
    EXPECT_LT(worst(b), 8e-6 + 5e-6) << name;  // and half the printed last digit
  }
  for (const PcdEncoding encoding : {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    WriteOptions o;
    o.pcd_encoding = encoding;
    WriteCloud((dir / "back.pcd").string(), c, o);
    const PointCloud b = ReadCloud((dir / "back.pcd").string());
    EXPECT_EQ(b.offset, c.offset) << int(encoding);
    EXPECT_LT(worst(b), 8e-6) << int(encoding);  // doubles: nothing lost but the float's own step
  }
  // PCL's reader makes them floats: 0.5 m steps at 5.7e6. hedgefit's keeps them.
  {
    std::ofstream(dir / "survey.pcd") << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\n"
                                         "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n"
                                         "500123.1234 5701234.5678 48.25\n500124.0001 5701235.0002 48.5\n";
    const PointCloud s = ReadCloud((dir / "survey.pcd").string());
    EXPECT_EQ(s.offset, Eigen::Vector3d(500000.0, 5701000.0, 0.0));
    EXPECT_NEAR(double(s.points_mm[0].y()) + s.offset.y(), 5701234.5678, 1e-5);
    EXPECT_NEAR(double(s.points_mm[1].x()) + s.offset.x(), 500124.0001, 1e-5);
  }
  // A garden in a local grid, metres 30 km from its origin: a float steps by 2 mm there, so it
  // is shifted though under 10^5, being far from the origin for its 40 m.
  {
    std::ofstream grid(dir / "grid.xyz");
    grid << "31234.5678 18765.4321 12.3456\n31274.5678 18745.4321 14.5\n";
  }
  const PointCloud g = ReadCloud((dir / "grid.xyz").string());
  EXPECT_EQ(g.offset, Eigen::Vector3d(31000.0, 19000.0, 0.0));
  EXPECT_NEAR(double(g.points_mm[0].x()) + g.offset.x(), 31234.5678, 1e-5);
  EXPECT_NEAR(double(g.points_mm[0].y()) + g.offset.y(), 18765.4321, 1e-5);
  // A camera's cloud (mm, 60 m at most) is not shifted: it reaches about as far as it spans.
  std::ofstream(dir / "local.xyz") << "-1500.25 300.5 2400.75\n2000 -800 59999.5\n";
  const PointCloud local = ReadCloud((dir / "local.xyz").string());
  EXPECT_TRUE(local.offset.isZero());
  EXPECT_EQ(local.points_mm[1].z(), 59999.5f);
}

// A LAS 1.4 file as the specification lays it out (a 375-byte header, point format 7: 36-byte
// records with 16-bit colour), built here byte by byte rather than by hedgefit's writer.
std::string Las14Format7(const std::vector<std::array<std::int32_t, 3>>& xyz, const Eigen::Vector3d& scale,
                         const Eigen::Vector3d& offset, std::uint8_t format_byte = 7, std::uint64_t promised = 0) {
  std::string h(375, '\0');
  auto put = [&](std::size_t at, const void* v, std::size_t n) { std::memcpy(&h[at], v, n); };
  h.replace(0, 4, "LASF");
  h[24] = 1, h[25] = 4;
  const std::uint16_t header_size = 375, record = 36;
  const std::uint32_t data_at = 375;
  put(94, &header_size, 2), put(96, &data_at, 4), put(104, &format_byte, 1), put(105, &record, 2);
  for (int k = 0; k < 3; ++k) put(131 + 8 * std::size_t(k), &scale(k), 8), put(155 + 8 * std::size_t(k), &offset(k), 8);
  const std::uint64_t n = promised ? promised : xyz.size();  // LAS 1.4: the 64-bit count, the legacy one 0
  put(247, &n, 8);
  for (std::size_t i = 0; i < xyz.size(); ++i) {
    std::string r(36, '\0');
    std::memcpy(&r[0], xyz[i].data(), 12);
    const std::uint16_t intensity = std::uint16_t(100 * (i + 1));
    std::memcpy(&r[12], &intensity, 2);
    r[16] = char(i % 2 ? 2 : 5);  // ground, high vegetation
    const std::uint16_t rgb[3] = {std::uint16_t(0xFF00), std::uint16_t(0x8000), std::uint16_t(0x0100 * i)};
    std::memcpy(&r[30], rgb, 6);
    h += r;
  }
  return h;
}

// LAS, the format survey LiDAR and photogrammetry exports come in: coordinates are integers
// times a scale plus an offset, read in double precision and shifted as the other readers do;
// 16-bit colour to 8 bits; intensity and classification as fields. A LAZ file is refused with
// what to do, a truncated one says so.
// A PCD's VIEWPOINT (tx ty tz qw qx qy qz) says where the sensor stood; PCL writes the origin
// when it does not know, so only a translation away from it is taken, in the file's units.
TEST(CloudIo, APcdsViewpointIsReadWhenItIsNotTheOrigin) {
  const fs::path dir = testing::ScratchDir();
  auto header_of = [&](const std::string& viewpoint) {
    WriteText(dir / "v.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n" + viewpoint +
                                 "POINTS 2\nDATA ascii\n1 2 3\n4 5 6\n");
    CloudFileHeader h;
    ReadCloud((dir / "v.pcd").string(), {}, &h);
    return h;
  };
  const CloudFileHeader at = header_of("VIEWPOINT 2.5 -1.5 1.6 1 0 0 0\n");
  ASSERT_TRUE(at.viewpoint.has_value());
  EXPECT_EQ(*at.viewpoint, Eigen::Vector3d(2.5, -1.5, 1.6));
  EXPECT_FALSE(header_of("VIEWPOINT 0 0 0 1 0 0 0\n").viewpoint.has_value());
  EXPECT_FALSE(header_of("").viewpoint.has_value());
  EXPECT_FALSE(header_of("VIEWPOINT 2.5 x 1.6 1 0 0 0\n").viewpoint.has_value());
}

// A spinning LiDAR's scan in its own frame: 16 lasers at -15..15 degrees, every 0.2 degrees about
// a room 4 x 6 m and 3 m high, 1.2 m above its floor, with 10 mm of range noise. Its rings are
// seen from the origin; the same points moved 2 m, or points spread over the same room, show none.
TEST(CloudIo, AScannersRingsAreSeenFromItsOrigin) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 0.010);
  PointCloud scan;
  for (int k = 0; k < 16; ++k) {
    const double el = (-15 + 2 * k) * M_PI / 180;
    for (double az = 0; az < 2 * M_PI; az += 0.2 * M_PI / 180) {
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      // The nearest of the room's walls, floor and ceiling along the beam.
      double t = 1e9;
      for (int a = 0; a < 3; ++a) {
        const double lo[3] = {-2.0, -3.0, -1.2}, hi[3] = {2.0, 3.0, 1.8};
        if (d[a] > 1e-9) t = std::min(t, hi[a] / d[a]);
        if (d[a] < -1e-9) t = std::min(t, lo[a] / d[a]);
      }
      scan.points_mm.push_back(((t + noise(rng)) * d).cast<float>());
    }
  }
  EXPECT_EQ(ScannerRings(scan), 16);
  PointCloud moved = scan;
  for (auto& p : moved.points_mm) p += Eigen::Vector3f(2.0f, -1.0f, 0.3f);
  EXPECT_EQ(ScannerRings(moved), 0);
  // The reader's shift is undone: the origin is the file's.
  PointCloud shifted = scan;
  shifted.offset = Eigen::Vector3d(100, 200, 10);
  for (auto& p : shifted.points_mm) p -= shifted.offset.cast<float>();
  EXPECT_EQ(ScannerRings(shifted), 16);
  std::uniform_real_distribution<double> u(0, 1);
  PointCloud spread;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    spread.points_mm.emplace_back(float(-2 + 4 * u(rng)), float(-3 + 6 * u(rng)), float(-1.2 + 3 * u(rng)));
  }
  EXPECT_EQ(ScannerRings(spread), 0);
}

TEST(CloudIo, LasIsReadToItsScaleAndWrittenBack) {
  const auto dir = hedgefit::testing::ScratchDir();
  const Eigen::Vector3d scale(0.001, 0.001, 0.01), offset(500000, 5700000, 0);
  const std::vector<std::array<std::int32_t, 3>> ints = {{123456, 234567, 4812}, {-5000, 1000, 4900}, {0, 0, 5000}};
  WriteText(dir / "survey.las", Las14Format7(ints, scale, offset));
  const PointCloud c = ReadCloud((dir / "survey.las").string());
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c.offset, Eigen::Vector3d(500000.0, 5700000.0, 0.0));
  for (std::size_t i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) {
      const double truth = ints[i][std::size_t(k)] * scale(k) + offset(k);  // the specification's formula
      EXPECT_NEAR(double(c.points_mm[i](k)) + c.offset(k), truth, 1e-5) << i << " " << k;
    }
    EXPECT_EQ(c.fields.at("intensity")[i], float(100 * (i + 1)));
    EXPECT_EQ(c.fields.at("classification")[i], i % 2 ? 2.f : 5.f);
    EXPECT_EQ(c.colors[i][0], 255);
    EXPECT_EQ(c.colors[i][1], 128);
    EXPECT_EQ(c.colors[i][2], std::uint8_t(i));
  }
  // Written back (LAS 1.2, point format 2) with a NaN point, which LAS cannot hold: left out.
  PointCloud w = c;
  w.points_mm.push_back(Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  w.colors.push_back({1, 2, 3});
  for (auto& [name, v] : w.fields) v.push_back(0);
  w.Flatten();
  WriteCloud((dir / "back.las").string(), w);
  const PointCloud b = ReadCloud((dir / "back.las").string());
  ASSERT_EQ(b.size(), 3u);
  EXPECT_EQ(b.offset, c.offset);
  for (std::size_t i = 0; i < 3; ++i) {
    // The writer's scale is 10^-4 of a unit here: half of it, and a float's step at 250 units.
    EXPECT_LT((b.points_mm[i] - c.points_mm[i]).cwiseAbs().maxCoeff(), 5e-5f + 3e-5f) << i;
    EXPECT_EQ(b.colors[i], c.colors[i]);
    EXPECT_EQ(b.fields.at("intensity")[i], c.fields.at("intensity")[i]);
    EXPECT_EQ(b.fields.at("classification")[i], c.fields.at("classification")[i]);
  }
  auto refused = [&](const std::string& name, const std::string& bytes, const std::string& fragment) {
    WriteText(dir / name, bytes);
    try {
      ReadCloud((dir / name).string());
      ADD_FAILURE() << name << " was read";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(name), std::string::npos) << what;
      EXPECT_NE(what.find(fragment), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  };
  refused("compressed.laz", Las14Format7(ints, scale, offset, 7 | 0x80), "LAZ");
  refused("short.las", Las14Format7(ints, scale, offset, 7, 4), "truncated");
  refused("eleven.las", Las14Format7(ints, scale, offset, 11), "point format 11");
  refused("plain.las", std::string(300, 'x'), "LASF");
}

TEST(CloudIo, BadFilesGiveOneLineErrors) {
  const fs::path dir = testing::ScratchDir();
  ExpectReadError((dir / "missing.pcd").string(), "no such file");
  fs::create_directories(dir / "adir.pcd");
  ExpectReadError((dir / "adir.pcd").string(), "is a directory");
  WriteText(dir / "empty.pcd", "");
  ExpectReadError((dir / "empty.pcd").string(), "empty");
  WriteText(dir / "garbage.pcd", "this is not a point cloud\n\x01\x02\x03");
  ExpectReadError((dir / "garbage.pcd").string(), "PCD");
  WriteText(dir / "bad_header.pcd",
            "VERSION .7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n");
  ExpectReadError((dir / "bad_header.pcd").string(), "PCD");
  WriteText(dir / "short_ascii.pcd",
            "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n");
  ExpectReadError((dir / "short_ascii.pcd").string(), "the header promises 3 points");
  // Bad values are errors naming the line, never points at the origin (PCL reads "x" as 0
  // and pads a short row with zeros).
  const std::string head3 = "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n";
  WriteText(dir / "word.pcd", head3 + "1 2 3\n4 x 6\n7 8 9\n");
  ExpectReadError((dir / "word.pcd").string(), "word.pcd:11: 'x' is not a number");
  WriteText(dir / "short_row.pcd", head3 + "1 2 3\n4 6\n7 8 9\n");
  ExpectReadError((dir / "short_row.pcd").string(), "short_row.pcd:11: 2 values, but the header's fields need 3 per point");
  WriteText(dir / "extra_rows.pcd", head3 + "1 2 3\n4 5 6\n7 8 9\n1 1 1\n");
  ExpectReadError((dir / "extra_rows.pcd").string(), "promises 3 points but the file holds 4 rows");
  // A 200-byte file claiming a billion points is refused before anything is allocated.
  WriteText(dir / "huge.pcd", "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1000000000\n"
                              "HEIGHT 1\nPOINTS 1000000000\nDATA ascii\n1 2 3\n");
  ExpectReadError((dir / "huge.pcd").string(), "the header promises 1000000000 points");
  // PLY: the same classes, each with its own message.
  const auto ply = [](int n) {
    return "ply\nformat ascii 1.0\nelement vertex " + std::to_string(n) +
           "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  };
  WriteText(dir / "word.ply", ply(2) + "1 2 3\nabc 5 6\n");
  ExpectReadError((dir / "word.ply").string(), "word.ply:9: 'abc' is not a number");
  WriteText(dir / "few.ply", ply(2) + "1 2 3\n4 5 6\n7 8 9\n");
  ExpectReadError((dir / "few.ply").string(), "more rows than the 2 vertices the header lists");
  WriteText(dir / "many.ply", ply(3) + "1 2 3\n4 5 6\n");
  ExpectReadError((dir / "many.ply").string(), "the header lists 3 vertices but the file holds 2 rows");
  WriteText(dir / "short.ply", ply(2) + "1 2 3\n4 5\n");
  ExpectReadError((dir / "short.ply").string(), "short.ply:9: 2 values, but a vertex has 3 properties");
  WriteText(dir / "huge.ply", ply(500000000) + "1 2 3\n");
  ExpectReadError((dir / "huge.ply").string(), "the header promises 500000000 vertices");
  WriteText(dir / "huge_bin.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 500000000\nproperty float x\n"
                                  "property float y\nproperty float z\nend_header\n0123456789");
  ExpectReadError((dir / "huge_bin.ply").string(), "truncated: the header promises 500000000 vertices");
  WriteText(dir / "zero.pcd",
            "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 0\nHEIGHT 1\nPOINTS 0\nDATA ascii\n");
  ExpectReadError((dir / "zero.pcd").string(), "no points");
  WriteText(dir / "no_xyz.pcd",
            "VERSION .7\nFIELDS a b\nSIZE 4 4\nTYPE F F\nCOUNT 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2\n");
  ExpectReadError((dir / "no_xyz.pcd").string(), "x, y and z");
  WriteText(dir / "bad.xyz", "1 2 3\n4 five 6\n");
  ExpectReadError((dir / "bad.xyz").string(), "bad.xyz:2");
  WriteText(dir / "five.xyz", "1 2 3 4 5\n");
  ExpectReadError((dir / "five.xyz").string(), "five.xyz:1: 5 values; lines are");
  WriteText(dir / "no_z.csv", "x,y,intensity\n1,2,3\n");
  ExpectReadError((dir / "no_z.csv").string(), "no_z.csv:1: the header names no x, y and z columns");
  WriteText(dir / "mixed.xyz", "1 2 3\n1 2 3 4 5 6\n");
  ExpectReadError((dir / "mixed.xyz").string(), "mixed.xyz:2: 6 values but the file's layout has 3");
  WriteText(dir / "bad.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n");
  ExpectReadError((dir / "bad.ply").string(), "PLY");
  WriteText(dir / "cloud.e57", "x");
  ExpectReadError((dir / "cloud.e57").string(), "unknown cloud format");

  // Binary and compressed files cut short, at several lengths (PCL pads files to a page,
  // so cuts stay within the first 60 %, which is all point data).
  const PointCloud in = RandomCloud(500, true, 1, 11);
  for (PcdEncoding e : {PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    WriteOptions w;
    w.pcd_encoding = e;
    const fs::path full = dir / "full.pcd";
    WriteCloud(full.string(), in, w);
    std::ifstream f(full, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    for (double keep : {0.2, 0.4, 0.6}) {
      const fs::path cut = dir / "cut.pcd";
      WriteText(cut, bytes.substr(0, static_cast<std::size_t>(double(bytes.size()) * keep)));
      ExpectReadError(cut.string(), "");
    }
  }
}

// A binary PLY element without properties holds no bytes, so its count (here 7.7 billion, as a
// fuzzer's file declared) must cost nothing: the read takes milliseconds, not the 20 s it did.
TEST(CloudIo, PropertylessPlyElementCostsNothing) {
  const auto dir = hedgefit::testing::ScratchDir();
  std::string bytes = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                      "property float z\nelement nothing 7777777777\nend_header\n";
  const float xyz[3] = {1, 2, 3};
  bytes.append(reinterpret_cast<const char*>(xyz), sizeof(xyz));
  WriteText(dir / "empty_element.ply", bytes);
  const auto t0 = std::chrono::steady_clock::now();
  const PointCloud c = ReadCloud((dir / "empty_element.ply").string());
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c.points_mm[0].z(), 3.0f);
  EXPECT_LT(s, 1.0);  // stepping through the count took 20 s
}

TEST(CloudIo, FailedWriteLeavesNoFileAndKeepsTheOldOne) {
  const fs::path dir = testing::ScratchDir();
  const std::string target = (dir / "out.pcd").string();
  const PointCloud good = RandomCloud(100, false, 1, 5);
  WriteCloud(target, good);
  const auto size_before = fs::file_size(target);

  PointCloud inconsistent = good;
  inconsistent.colors.resize(3);  // wrong length: rejected before anything is written
  EXPECT_THROW(WriteCloud(target, inconsistent), Error);
  EXPECT_THROW(WriteCloud(target, PointCloud{}), Error);
  EXPECT_EQ(fs::file_size(target), size_before);
  EXPECT_EQ(ReadCloud(target).size(), 100u);

  EXPECT_THROW(WriteCloud((dir / "no_such_dir" / "x.pcd").string(), good), Error);
  EXPECT_FALSE(fs::exists(dir / "no_such_dir"));
  // No temporary files are left behind by any of the above.
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u);
}

TEST(CloudIo, RealStereoCloudMatchesPclLoader) {
  HEDGEFIT_REQUIRE_DATA("pcl_test/table_scene_mug_stereo_textured.pcd");
  const std::string path = testing::DataPath("pcl_test/table_scene_mug_stereo_textured.pcd");
  CloudFileHeader header;
  const PointCloud ours = ReadCloud(path, {}, &header);
  pcl::PointCloud<pcl::PointXYZRGBA> reference;
  ASSERT_EQ(pcl::io::loadPCDFile(path, reference), 0);
  ASSERT_EQ(ours.size(), reference.size());
  EXPECT_EQ(ours.width, reference.width);
  EXPECT_EQ(ours.height, reference.height);
  EXPECT_EQ(header.encoding, "binary_compressed");
  ASSERT_TRUE(ours.HasColor());
  std::size_t nan = 0;
  for (std::size_t i = 0; i < ours.size(); ++i) {
    const auto& r = reference[i];
    if (!std::isfinite(r.x)) {
      ++nan;
      EXPECT_FALSE(IsFinite(ours.points_mm[i]));
      continue;
    }
    ASSERT_EQ(ours.points_mm[i], Eigen::Vector3f(r.x, r.y, r.z)) << i;
    ASSERT_EQ(ours.colors[i], (Rgb{r.r, r.g, r.b})) << i;
  }
  EXPECT_EQ(CountNonFinite(ours), nan);
}

}  // namespace
}  // namespace hedgefit::cloud

// The outline beside a saved cloud (cloud/outline_io.hpp) reads back as written, to the last bit
// (the envelope fitted to it must be measure's to 0.1 mm); a damaged one is refused with the file
// and the fix named; no file beside a cloud is no outline.
TEST(OutlineFile, RoundTripsExactlyAndRefusesDamage) {
  namespace fs = std::filesystem;
  const auto dir = hedgefit::testing::ScratchDir();
  hedgefit::cloud::HedgeOutlines o;
  hedgefit::cloud::TangentRay a;
  a.origin_mm = Eigen::Vector3d(0.1, -0.2, 1.0 / 3);
  a.direction = Eigen::Vector3d(0.3, -0.4, std::sqrt(1 - 0.25)).normalized();
  a.focal_px = 933.3333333;
  a.view = 1;
  o[2] = {a, a};
  o[5] = {a};
  const std::string cloud = (dir / "row_1.pcd").string();
  EXPECT_FALSE(hedgefit::cloud::ReadOutlineSidecar(cloud, 1234).has_value());
  hedgefit::cloud::WriteOutlines(hedgefit::cloud::OutlineSidecarPath(cloud), o, 1234);
  // Written for another cloud (a run killed between the cloud and its outline): refused.
  EXPECT_THROW(hedgefit::cloud::ReadOutlineSidecar(cloud, 1233), hedgefit::InputError);
  const auto back = hedgefit::cloud::ReadOutlineSidecar(cloud, 1234);
  ASSERT_TRUE(back.has_value());
  ASSERT_EQ(back->size(), 2u);
  ASSERT_EQ(back->at(2).size(), 2u);
  EXPECT_EQ(back->at(2)[1].origin_mm, a.origin_mm);
  EXPECT_EQ(back->at(2)[1].direction, a.direction);
  EXPECT_EQ(back->at(2)[1].focal_px, a.focal_px);
  EXPECT_EQ(back->at(5)[0].view, 1);
  const std::string bad = (dir / "bad.outline.json").string();
  for (const std::string& text : {std::string("{"), std::string("{\"format\": \"other\"}"),
                                  std::string("{\"format\": \"hedgefit-outline\", \"version\": 1, \"cloud_points\": 1, \"hedges\": "
                                              "[{\"hedge_id\": 1, \"rays\": [[0, 0, 0, 2, 0, 0, 900, 0]]}]}")}) {
    std::ofstream(bad) << text;
    try {
      hedgefit::cloud::ReadOutlines(bad);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const hedgefit::InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(bad + ": ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find("hedgefit convert"), std::string::npos) << e.what();
    }
  }
}
