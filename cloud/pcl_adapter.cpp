#include "cloud/pcl_adapter.hpp"

#include <pcl/common/io.h>
#include <pcl/console/print.h>

#include <cstring>
#include <limits>

#include "pipeline/error.hpp"

namespace hedgefit::cloud {

namespace {

double ReadScalar(const std::uint8_t* p, std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::INT8: { std::int8_t v; std::memcpy(&v, p, 1); return v; }
    case pcl::PCLPointField::UINT8: return *p;
    case pcl::PCLPointField::INT16: { std::int16_t v; std::memcpy(&v, p, 2); return v; }
    case pcl::PCLPointField::UINT16: { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
    case pcl::PCLPointField::INT32: { std::int32_t v; std::memcpy(&v, p, 4); return v; }
    case pcl::PCLPointField::UINT32: { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
    case pcl::PCLPointField::FLOAT32: { float v; std::memcpy(&v, p, 4); return v; }
    case pcl::PCLPointField::FLOAT64: { double v; std::memcpy(&v, p, 8); return v; }
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

const pcl::PCLPointField* FindField(const pcl::PCLPointCloud2& blob, const char* name) {
  for (const auto& f : blob.fields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

}  // namespace

void QuietPcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

PointCloud FromPclBlob(const pcl::PCLPointCloud2& blob, const std::string& source) {
  const std::size_t n = static_cast<std::size_t>(blob.width) * blob.height;
  if (blob.point_step == 0 && n > 0) throw Error(source + ": point size is 0; the header's SIZE/COUNT are wrong");
  if (blob.height > 0 && blob.row_step < static_cast<std::size_t>(blob.width) * blob.point_step) {
    throw Error(source + ": row size smaller than width * point size; the header is inconsistent");
  }
  if (blob.data.size() < static_cast<std::size_t>(blob.row_step) * blob.height) {
    throw Error(source + ": holds " + std::to_string(blob.data.size()) + " bytes of point data but the header needs " +
                std::to_string(static_cast<std::size_t>(blob.row_step) * blob.height) + "; the file is truncated");
  }
  const pcl::PCLPointField* fx = FindField(blob, "x");
  const pcl::PCLPointField* fy = FindField(blob, "y");
  const pcl::PCLPointField* fz = FindField(blob, "z");
  if (!fx || !fy || !fz) {
    throw Error(source + ": has no x, y and z fields; hedgefit needs 3-D points");
  }
  for (const auto& f : blob.fields) {
    const std::size_t size = pcl::getFieldSize(f.datatype);
    if (size == 0) throw Error(source + ": field '" + f.name + "' has an unknown type");
    if (f.offset + size * std::max<std::uint32_t>(f.count, 1) > blob.point_step) {
      throw Error(source + ": field '" + f.name + "' lies outside the point; the header is inconsistent");
    }
  }

  PointCloud out;
  out.points_mm.resize(n);
  out.width = blob.width;
  out.height = blob.height;
  auto at = [&](std::size_t i) {
    const std::size_t row = blob.width ? i / blob.width : 0;
    const std::size_t col = blob.width ? i % blob.width : 0;
    return blob.data.data() + row * blob.row_step + col * blob.point_step;
  };
  // Coordinates stored wider than a float (doubles, 32-bit integers: a survey's or a
  // georeferenced model's) are read as doubles and shifted where they are large (SetPoints);
  // floats are kept as they are, as nothing a shift could save is in them.
  auto wide = [](const pcl::PCLPointField* f) {
    return f->datatype == pcl::PCLPointField::FLOAT64 || f->datatype == pcl::PCLPointField::INT32 ||
           f->datatype == pcl::PCLPointField::UINT32;
  };
  std::vector<Eigen::Vector3d> xyz(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* p = at(i);
    xyz[i] = Eigen::Vector3d(ReadScalar(p + fx->offset, fx->datatype), ReadScalar(p + fy->offset, fy->datatype),
                             ReadScalar(p + fz->offset, fz->datatype));
  }
  if (wide(fx) || wide(fy) || wide(fz)) {
    SetPoints(xyz, &out);
  } else {
    for (std::size_t i = 0; i < n; ++i) out.points_mm[i] = xyz[i].cast<float>();
  }

  const pcl::PCLPointField* packed = FindField(blob, "rgb");
  if (!packed) packed = FindField(blob, "rgba");
  const pcl::PCLPointField* fr = FindField(blob, "r");
  const pcl::PCLPointField* fg = FindField(blob, "g");
  const pcl::PCLPointField* fb = FindField(blob, "b");
  if (packed && pcl::getFieldSize(packed->datatype) == 4) {
    out.colors.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      std::uint32_t v;
      std::memcpy(&v, at(i) + packed->offset, 4);
      out.colors[i] = Rgb{static_cast<std::uint8_t>((v >> 16) & 0xff), static_cast<std::uint8_t>((v >> 8) & 0xff),
                          static_cast<std::uint8_t>(v & 0xff)};
    }
  } else if (fr && fg && fb) {
    out.colors.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint8_t* p = at(i);
      auto c = [&](const pcl::PCLPointField* f) {
        const double v = ReadScalar(p + f->offset, f->datatype);
        return static_cast<std::uint8_t>(std::isfinite(v) ? std::clamp(v, 0.0, 255.0) : 0.0);
      };
      out.colors[i] = Rgb{c(fr), c(fg), c(fb)};
    }
    packed = nullptr;
  }

  for (const auto& f : blob.fields) {
    const std::string& name = f.name;
    if (name == "x" || name == "y" || name == "z" || name == "_" || f.count != 1) continue;
    if (&f == packed || name == "rgb" || name == "rgba") continue;
    if (out.HasColor() && (name == "r" || name == "g" || name == "b")) continue;
    std::vector<float>& values = out.fields[name];
    values.resize(n);
    for (std::size_t i = 0; i < n; ++i) values[i] = static_cast<float>(ReadScalar(at(i) + f.offset, f.datatype));
  }
  return out;
}

pcl::PCLPointCloud2 ToPclBlob(const PointCloud& cloud, bool file_frame) {
  pcl::PCLPointCloud2 blob;
  std::uint32_t offset = 0;
  auto add = [&](const std::string& name, std::uint8_t type) {
    pcl::PCLPointField f;
    f.name = name;
    f.offset = offset;
    f.datatype = type;
    f.count = 1;
    blob.fields.push_back(f);
    offset += type == pcl::PCLPointField::FLOAT64 ? 8 : 4;
  };
  const bool doubles = file_frame && !cloud.offset.isZero();
  const std::uint8_t xyz_type = doubles ? pcl::PCLPointField::FLOAT64 : pcl::PCLPointField::FLOAT32;
  add("x", xyz_type);
  add("y", xyz_type);
  add("z", xyz_type);
  if (cloud.HasColor()) add("rgb", pcl::PCLPointField::FLOAT32);  // PCL's packed-float convention
  std::vector<const std::vector<float>*> extra;
  for (const auto& [name, values] : cloud.fields) {
    if (values.empty()) continue;
    add(name, pcl::PCLPointField::FLOAT32);
    extra.push_back(&values);
  }
  blob.point_step = offset;
  blob.width = cloud.width;
  blob.height = cloud.height;
  blob.row_step = blob.point_step * blob.width;
  blob.is_dense = CountNonFinite(cloud) == 0;
  blob.data.resize(static_cast<std::size_t>(blob.point_step) * cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    std::uint8_t* p = blob.data.data() + i * blob.point_step;
    std::size_t o = 12;
    if (doubles) {
      const Eigen::Vector3d v = cloud.points_mm[i].cast<double>() + cloud.offset;
      std::memcpy(p, v.data(), 24);
      o = 24;
    } else {
      std::memcpy(p, cloud.points_mm[i].data(), 12);
    }
    if (cloud.HasColor()) {
      const Rgb& c = cloud.colors[i];
      const std::uint32_t v = (0xffu << 24) | (std::uint32_t{c[0]} << 16) | (std::uint32_t{c[1]} << 8) | c[2];
      std::memcpy(p + o, &v, 4);
      o += 4;
    }
    for (const auto* values : extra) {
      std::memcpy(p + o, &(*values)[i], 4);
      o += 4;
    }
  }
  return blob;
}

pcl::PointCloud<pcl::PointXYZ> ToPclXyz(const PointCloud& cloud) {
  pcl::PointCloud<pcl::PointXYZ> pc;
  pc.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    pc[i].x = cloud.points_mm[i].x();
    pc[i].y = cloud.points_mm[i].y();
    pc[i].z = cloud.points_mm[i].z();
  }
  pc.width = cloud.width;
  pc.height = cloud.height;
  pc.is_dense = CountNonFinite(cloud) == 0;
  return pc;
}

pcl::PointCloud<pcl::PointXYZRGB> ToPclXyzRgb(const PointCloud& cloud) {
  pcl::PointCloud<pcl::PointXYZRGB> pc;
  pc.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    auto& q = pc[i];
    q.x = cloud.points_mm[i].x();
    q.y = cloud.points_mm[i].y();
    q.z = cloud.points_mm[i].z();
    if (cloud.HasColor()) {
      q.r = cloud.colors[i][0];
      q.g = cloud.colors[i][1];
      q.b = cloud.colors[i][2];
    }
  }
  pc.width = cloud.width;
  pc.height = cloud.height;
  pc.is_dense = CountNonFinite(cloud) == 0;
  return pc;
}

PointCloud FromPclXyz(const pcl::PointCloud<pcl::PointXYZ>& pc) {
  PointCloud out;
  out.points_mm.reserve(pc.size());
  for (const auto& q : pc) out.points_mm.emplace_back(q.x, q.y, q.z);
  out.width = pc.width;
  out.height = pc.height;
  return out;
}

PointCloud FromPclXyzRgb(const pcl::PointCloud<pcl::PointXYZRGB>& pc) {
  PointCloud out;
  out.points_mm.reserve(pc.size());
  out.colors.reserve(pc.size());
  for (const auto& q : pc) {
    out.points_mm.emplace_back(q.x, q.y, q.z);
    out.colors.push_back(Rgb{q.r, q.g, q.b});
  }
  out.width = pc.width;
  out.height = pc.height;
  return out;
}

}  // namespace hedgefit::cloud
