#include "render/render.hpp"

#include "fitting/methods.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "pipeline/error.hpp"
#include "render/vtk_module.hpp"

namespace hedgefit::render {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::array<double, 3> Normalized(std::array<double, 3> v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return {v[0] / n, v[1] / n, v[2] / n};
}

}  // namespace

ColorMode ParseColorMode(const std::string& name) {
  if (name == "own") return ColorMode::kOwn;
  if (name == "distance") return ColorMode::kDistance;
  if (name == "depth") return ColorMode::kDepth;
  if (name == "field") return ColorMode::kField;
  throw Error("'" + name + "' is not a colouring; use own, distance, depth or field");
}

View ParseView(const std::string& name) {
  if (name == "front") return View::kFront;
  if (name == "side") return View::kSide;
  if (name == "top") return View::kTop;
  if (name == "iso") return View::kIso;
  throw Error("'" + name + "' is not a view; use front, side, top, iso, a comma list of them, or all");
}

const pipeline::OptionTable<RenderOptions>& RenderOptions::Table() {
  using O = RenderOptions;
  static const char* const kViewNames[] = {"front", "side", "top", "iso"};
  static const auto table =
      pipeline::OptionTable<O>()
          .Add("width", &O::width, "width of each view", "px").Range(16, 8192)
          .Add("height", &O::height, "height of each view", "px").Range(16, 8192)
          .AddEnum("color", &O::color,
                   {{"own", ColorMode::kOwn},
                    {"distance", ColorMode::kDistance},
                    {"depth", ColorMode::kDepth},
                    {"field", ColorMode::kField}},
                   "point colours: own, distance (signed, to the best fit drawn), depth, or field (option 'field')")
          .Add("field", &O::field, "per-point field for color field, on a diverging map about 0 (e.g. cut_depth)")
          .AddCustom(
              "view", pipeline::OptionType::kString, "front (the left camera's view), side, top, iso, a comma list, or all (tiled)",
              "",
              [](const O& o) -> pipeline::OptionValue {
                std::string out;
                for (View v : o.views) out += (out.empty() ? "" : ",") + std::string(kViewNames[int(v)]);
                return out;
              },
              [](O& o, const pipeline::OptionValue& v) {
                const std::string& text = std::get<std::string>(v);
                std::stringstream vs(text == "all" ? std::string("front,side,top,iso") : text);
                o.views.clear();
                try {
                  for (std::string name; std::getline(vs, name, ',');) o.views.push_back(ParseView(name));
                } catch (const Error& e) {
                  throw Error(std::string("option 'view': ") + e.what());
                }
              })
          .Add("point_size", &O::point_size, "point size", "px").Range(0.1, 50)
          .Add("wireframe", &O::wireframe, "draw fitted spheres as wireframes")
          .Add("sphere_opacity", &O::sphere_opacity, "opacity of translucent spheres").Range(0.01, 1)
          .Add("distance_range", &O::distance_range_mm, "colour-map half range for color distance or field (0 = automatic)", "mm")
          .Min(0)
          .AddCustom(
              "background", pipeline::OptionType::kDoubleList, "background colour [r, g, b], each in [0, 1]", "",
              [](const O& o) -> pipeline::OptionValue {
                return std::vector<double>{o.background[0], o.background[1], o.background[2]};
              },
              [](O& o, const pipeline::OptionValue& v) {
                const auto& l = std::get<std::vector<double>>(v);
                for (std::size_t k = 0; k < 3 && k < l.size(); ++k) o.background[k] = l[k];
              })
          .Range(0, 1)
          .ListSize(3);
  return table;
}

void RenderOptions::Check() const {
  Table().Validate(*this);
  if (views.empty()) throw Error("option 'view': give at least one view");
}

std::array<double, 3> OverlayColor(std::size_t index) {
  static const std::array<std::array<double, 3>, 8> palette = {{{0.89, 0.10, 0.11},
                                                                 {0.22, 0.49, 0.72},
                                                                 {0.30, 0.69, 0.29},
                                                                 {0.60, 0.31, 0.64},
                                                                 {1.00, 0.50, 0.00},
                                                                 {0.65, 0.34, 0.16},
                                                                 {0.97, 0.51, 0.75},
                                                                 {0.40, 0.40, 0.40}}};
  return palette[index % palette.size()];
}

CameraSetup CameraFor(View view, const std::array<double, 6>& b) {
  const std::array<double, 3> c = {(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2};
  const double s = std::max(1.0, 0.5 * std::sqrt((b[1] - b[0]) * (b[1] - b[0]) + (b[3] - b[2]) * (b[3] - b[2]) +
                                                  (b[5] - b[4]) * (b[5] - b[4])));
  CameraSetup cam;
  cam.focal_point = c;
  const double dist = 3.0 * s;
  cam.view_angle_deg = 2 * std::atan(1.1 / 3.0) * 180 / kPi;
  switch (view) {
    case View::kFront: {
      // The left camera's own view: from the origin, y down on screen as in the image.
      const double d = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
      if (d > 1.5 * s) {
        cam.position = {0, 0, 0};
        cam.view_angle_deg = std::clamp(2 * std::atan(1.1 * s / d) * 180 / kPi, 1.0, 120.0);
      } else {
        cam.position = {c[0], c[1], c[2] - dist};
      }
      cam.view_up = {0, -1, 0};
      break;
    }
    case View::kSide:
      cam.position = {c[0] + dist, c[1], c[2]};
      cam.view_up = {0, -1, 0};
      break;
    case View::kTop:
      cam.position = {c[0], c[1] - dist, c[2]};
      cam.view_up = {0, 0, 1};
      break;
    case View::kIso: {
      const auto d = Normalized({1, -1, -1});
      cam.position = {c[0] + dist * d[0], c[1] + dist * d[1], c[2] + dist * d[2]};
      cam.view_up = {0, -1, 0};
      break;
    }
  }
  return cam;
}

void RenderToPng(const cloud::PointCloud& cloud, const std::vector<SphereOverlay>& spheres,
                 const RenderOptions& options, const std::string& png_path) {
  options.Check();
  namespace fs = std::filesystem;
  const fs::path target(png_path);
  std::error_code ec;
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  if (!fs::is_directory(dir, ec)) throw Error(png_path + ": directory '" + dir.string() + "' does not exist; create it first");
  char why[1024] = "";
  if (LoadVtkModule(png_path).render_png(&cloud, &spheres, &options, png_path.c_str(), why, sizeof(why)) != 0) throw Error(why);
}

std::optional<fitting::Sphere> MostTrustedSphere(const std::vector<SphereOverlay>& spheres) {
  std::vector<std::string> drawn;
  for (const auto& s : spheres) {
    if (!s.truth) drawn.push_back(s.label);
  }
  const fitting::FitMethod* best = fitting::MostTrusted(drawn);
  for (const auto& s : spheres) {
    if (!s.truth && (!best || s.label == best->name)) return s.sphere;
  }
  return std::nullopt;
}

SphereOverlay OverlayOf(const fitting::SphereFitResult& fit, const std::string& label) {
  SphereOverlay o;
  o.label = label, o.sphere = fit.sphere, o.dashed = fit.not_a_ball.has_value();
  if (fit.method != "shape") return o;
  auto extra = [&](const std::string& name) -> const std::vector<double>* {
    for (const auto& [key, values] : fit.extras) {
      if (key == name && values.size() == 3) return &values;
    }
    return nullptr;
  };
  if (const auto* axes = extra("axes_mm")) o.axes_mm = Eigen::Vector3d((*axes)[0], (*axes)[1], (*axes)[2]);
  if (const auto* up = extra("up")) o.up = Eigen::Vector3d((*up)[0], (*up)[1], (*up)[2]);
  o.heading_deg = fit.Extra("heading_deg").value_or(0);
  if (fit.message == "cylinder" || fit.message == "cuboid" || fit.message == "cone") o.form = fit.message;
  return o;
}

void RenderTrimPlan(const cloud::PointCloud& cloud, const std::vector<fitting::TrimPlan>& plans, const std::string& png_path) {
  RenderOptions ro;
  ro.color = ColorMode::kField;
  ro.field = "cut_depth";
  ro.views = {View::kFront, View::kSide};
  ro.wireframe = true;
  std::vector<SphereOverlay> spheres;
  for (const auto& t : plans) {
    spheres.push_back({"target" + (t.hedge_id ? " hedge " + std::to_string(t.hedge_id) : std::string()), t.target, false, false,
                       t.target_axes_mm, t.target_heading_deg, t.pole, t.target_shape});
  }
  RenderToPng(cloud, spheres, ro, png_path);
}

}  // namespace hedgefit::render
