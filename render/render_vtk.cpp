// libhedgefit_vtk.so's renderer (render/vtk_module.hpp): the cloud and its fitted shapes drawn
// off-screen by VTK and written to PNG. render.cpp checks the request and calls in here.

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkColorTransferFunction.h>
#include <vtkConeSource.h>
#include <vtkCubeSource.h>
#include <vtkCylinderSource.h>
#include <vtkFloatArray.h>
#include <vtkLegendBoxActor.h>
#include <vtkNew.h>
#include <vtkObject.h>
#include <vtkPNGWriter.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>
#include <vtkSmartPointer.h>
#include <vtkScalarBarActor.h>
#include <vtkSphereSource.h>
#include <vtkTextActor.h>
#include <vtkTransform.h>
#include <vtkTransformPolyDataFilter.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <map>
#include <sstream>

#include "fitting/shape_fit.hpp"
#include "pipeline/error.hpp"
#include "render/render.hpp"
#include "render/virtual_display.hpp"
#include "render/vtk_module.hpp"

namespace hedgefit::render {

namespace {

// The cloud as one actor, coloured as asked, and the scene's bounds (points and spheres).
struct CloudLayer {
  vtkSmartPointer<vtkActor> actor;
  vtkSmartPointer<vtkColorTransferFunction> lut;  // null for the points' own colours
  std::string bar_title;
  std::array<double, 6> bounds = {1e300, -1e300, 1e300, -1e300, 1e300, -1e300};
};

// A field's name with its unit where hedgefit knows it, for the colour bar's title.
std::string FieldTitle(const std::string& field) {
  static const std::map<std::string, std::string> kFieldTitles = {
      {"cut_depth", "cut depth (mm, + = cut)"}, {"pixel_mm", "pixel footprint (mm)"}, {"hedge_id", "hedge"}};
  const auto known = kFieldTitles.find(field);
  return known != kFieldTitles.end() ? known->second : field;
}

CloudLayer MakeCloudLayer(const cloud::PointCloud& cloud, const std::vector<SphereOverlay>& spheres,
                          const RenderOptions& options, const std::string& png_path) {
  CloudLayer layer;
  vtkNew<vtkPoints> points;
  vtkNew<vtkCellArray> verts;
  vtkNew<vtkUnsignedCharArray> rgb;
  rgb->SetNumberOfComponents(3);
  vtkNew<vtkFloatArray> scalar;
  if (options.color == ColorMode::kDistance && !options.distance_sphere && spheres.empty()) {
    throw Error("color: 'distance' needs a fitted sphere; give --fits (or --truth)");
  }
  const std::vector<float>* field = nullptr;
  if (options.color == ColorMode::kField) {
    const auto it = cloud.fields.find(options.field);
    if (it == cloud.fields.end() || it->second.size() != cloud.size()) {
      std::string names;
      for (const auto& [name, values] : cloud.fields) names += (names.empty() ? "" : ", ") + name;
      throw Error("color field: the cloud has no field '" + options.field + "'" +
                  (names.empty() ? " (it has none)" : "; its fields: " + names));
    }
    field = &it->second;
  }
  // Sphere for signed distances (unused unless colouring by distance).
  const fitting::Sphere ref = options.distance_sphere ? *options.distance_sphere
                              : spheres.empty()       ? fitting::Sphere{}
                                                      : spheres.front().sphere;
  auto& bounds = layer.bounds;
  auto grow = [&](double x, double y, double z) {
    bounds[0] = std::min(bounds[0], x), bounds[1] = std::max(bounds[1], x);
    bounds[2] = std::min(bounds[2], y), bounds[3] = std::max(bounds[3], y);
    bounds[4] = std::min(bounds[4], z), bounds[5] = std::max(bounds[5], z);
  };
  std::vector<float> magnitudes;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points_mm[i];
    if (!cloud::IsFinite(p)) continue;
    const vtkIdType id = points->InsertNextPoint(p.x(), p.y(), p.z());
    verts->InsertNextCell(1, &id);
    grow(p.x(), p.y(), p.z());
    if (options.color == ColorMode::kOwn) {
      const cloud::Rgb c = cloud.HasColor() ? cloud.colors[i] : cloud::Rgb{90, 90, 90};
      rgb->InsertNextTuple3(c[0], c[1], c[2]);
    } else if (options.color == ColorMode::kDistance) {
      const double d = (p.cast<double>() - ref.center_mm).norm() - ref.radius_mm;
      scalar->InsertNextValue(static_cast<float>(d));
      magnitudes.push_back(static_cast<float>(std::abs(d)));
    } else if (field) {
      const float v = (*field)[i];
      scalar->InsertNextValue(v);
      if (std::isfinite(v)) magnitudes.push_back(std::abs(v));
    } else {
      scalar->InsertNextValue(p.z());
    }
  }
  if (points->GetNumberOfPoints() == 0) throw Error(png_path + ": the cloud has no finite points to render");
  for (const auto& s : spheres) {
    const auto& c = s.sphere.center_mm;
    grow(c.x() - s.sphere.radius_mm, c.y() - s.sphere.radius_mm, c.z() - s.sphere.radius_mm);
    grow(c.x() + s.sphere.radius_mm, c.y() + s.sphere.radius_mm, c.z() + s.sphere.radius_mm);
  }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(points);
  poly->SetVerts(verts);
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(poly);
  if (options.color == ColorMode::kOwn) {
    poly->GetPointData()->SetScalars(rgb);
    mapper->SetColorModeToDirectScalars();
  } else {
    layer.lut = vtkSmartPointer<vtkColorTransferFunction>::New();
    poly->GetPointData()->SetScalars(scalar);
    double lo, hi;
    if (options.color == ColorMode::kDistance) {
      double range = options.distance_range_mm;
      if (range <= 0) {
        // 3 robust sigmas of the residuals (1.4826 x median |d|): the sphere's own noise
        // spans the map, and outliers saturate instead of washing it out.
        std::nth_element(magnitudes.begin(), magnitudes.begin() + std::ptrdiff_t(magnitudes.size() / 2), magnitudes.end());
        range = std::max(1.0, 3.0 * 1.4826 * double(magnitudes[magnitudes.size() / 2]));
      }
      lo = -range, hi = range;
      // Cool-warm diverging map: inside blue, on the sphere white, outside red.
      layer.lut->AddRGBPoint(lo, 0.23, 0.30, 0.75);
      layer.lut->AddRGBPoint(0.0, 0.87, 0.87, 0.87);
      layer.lut->AddRGBPoint(hi, 0.71, 0.02, 0.15);
      layer.bar_title = "signed distance (mm)";
    } else if (field) {
      double range = options.distance_range_mm;
      if (range <= 0 && !magnitudes.empty()) {
        const std::size_t k = magnitudes.size() * 99 / 100;
        std::nth_element(magnitudes.begin(), magnitudes.begin() + std::ptrdiff_t(k), magnitudes.end());
        range = double(magnitudes[k]);
      }
      range = std::max(range, 1e-6);
      lo = -range, hi = range;
      layer.lut->AddRGBPoint(lo, 0.23, 0.30, 0.75);
      layer.lut->AddRGBPoint(0.0, 0.87, 0.87, 0.87);
      layer.lut->AddRGBPoint(hi, 0.71, 0.02, 0.15);
      layer.lut->SetNanColor(0.5, 0.5, 0.5);
      layer.bar_title = FieldTitle(options.field);
    } else {
      lo = bounds[4], hi = std::max(bounds[4] + 1, bounds[5]);
      const double pts[5][3] = {{0.27, 0.00, 0.33}, {0.23, 0.32, 0.55}, {0.13, 0.57, 0.55}, {0.37, 0.79, 0.38},
                                {0.99, 0.91, 0.15}};  // viridis
      for (int k = 0; k < 5; ++k) layer.lut->AddRGBPoint(lo + (hi - lo) * k / 4.0, pts[k][0], pts[k][1], pts[k][2]);
      layer.bar_title = "depth z (mm)";
    }
    layer.lut->ClampingOn();
    mapper->SetLookupTable(layer.lut);
    mapper->SetScalarRange(lo, hi);
    mapper->SetColorModeToMapScalars();
  }
  mapper->ScalarVisibilityOn();
  layer.actor = vtkSmartPointer<vtkActor>::New();
  layer.actor->SetMapper(mapper);
  layer.actor->GetProperty()->SetPointSize(static_cast<float>(options.point_size));
  layer.actor->GetProperty()->LightingOff();
  return layer;
}

// The spheres (fitted: coloured; truth: black wireframe) and their legend.
struct SphereLayer {
  std::vector<vtkSmartPointer<vtkActor>> actors;
  vtkSmartPointer<vtkLegendBoxActor> legend;
};

// A shape overlay's transform: unit sphere -> its semi-axes along the heading (from x laid flat
// about `up`), across it and along `up`, at its centre (as fitting::PlanTrim reads them).
Eigen::Matrix4d ShapeFromUnit(const SphereOverlay& s) {
  const Eigen::Matrix3d axes = fitting::ShapeAxes(s.up, s.heading_deg);
  const Eigen::Vector3d along = axes.col(0), across = axes.col(1), z = axes.col(2);
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.block<3, 1>(0, 0) = along * s.axes_mm.x();
  t.block<3, 1>(0, 1) = across * s.axes_mm.y();
  t.block<3, 1>(0, 2) = z * s.axes_mm.z();
  t.block<3, 1>(0, 3) = s.sphere.center_mm;
  return t;
}

SphereLayer MakeSphereLayer(const std::vector<SphereOverlay>& spheres, const RenderOptions& options) {
  SphereLayer layer;
  layer.legend = vtkSmartPointer<vtkLegendBoxActor>::New();
  vtkLegendBoxActor* legend = layer.legend;
  legend->SetNumberOfEntries(static_cast<int>(spheres.size()));
  std::size_t fitted = 0;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const auto& s = spheres[i];
    const bool shaped = s.axes_mm != Eigen::Vector3d::Zero();
    vtkNew<vtkSphereSource> sphere_src;
    sphere_src->SetCenter(shaped ? 0 : s.sphere.center_mm.x(), shaped ? 0 : s.sphere.center_mm.y(), shaped ? 0 : s.sphere.center_mm.z());
    sphere_src->SetRadius(shaped ? 1 : s.sphere.radius_mm);
    const bool lines = s.truth || options.wireframe;
    sphere_src->SetThetaResolution(lines ? 24 : 64);  // wireframes: few enough lines to see through
    sphere_src->SetPhiResolution(lines ? 12 : 48);
    // A drum or a box: the unit cylinder (radius 1, height 2, about VTK's y, turned to z) or cube.
    vtkNew<vtkCylinderSource> drum;
    drum->SetRadius(1), drum->SetHeight(2), drum->SetResolution(lines ? 24 : 64);
    vtkNew<vtkCubeSource> box;
    box->SetXLength(2), box->SetYLength(2), box->SetZLength(2);
    vtkNew<vtkConeSource> cone;  // base radius 1 at z = -1, apex at z = +1
    cone->SetRadius(1), cone->SetHeight(2), cone->SetDirection(0, 0, 1), cone->SetResolution(lines ? 24 : 64);
    vtkPolyDataAlgorithm* src = !shaped || (s.form != "cylinder" && s.form != "cuboid" && s.form != "cone")
                                    ? static_cast<vtkPolyDataAlgorithm*>(sphere_src)
                                : s.form == "cylinder" ? static_cast<vtkPolyDataAlgorithm*>(drum)
                                : s.form == "cone"     ? static_cast<vtkPolyDataAlgorithm*>(cone)
                                                       : static_cast<vtkPolyDataAlgorithm*>(box);
    src->Update();
    vtkNew<vtkPolyDataMapper> m;
    // A clipped shape: the unit sphere scaled by its semi-axes, turned to its heading about its up.
    vtkNew<vtkTransform> shape_from_unit;
    vtkNew<vtkTransformPolyDataFilter> shaped_src;
    if (shaped) {
      // VTK's matrices are row-major.
      Eigen::Matrix4d unit_to_shape = ShapeFromUnit(s);
      if (s.form == "cylinder") {
        Eigen::Matrix4d y_to_z = Eigen::Matrix4d::Identity();
        y_to_z.block<3, 3>(0, 0) << 1, 0, 0, 0, 0, -1, 0, 1, 0;
        unit_to_shape = unit_to_shape * y_to_z;
      }
      const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> t = unit_to_shape;
      shape_from_unit->SetMatrix(t.data());
      shaped_src->SetTransform(shape_from_unit);
      shaped_src->SetInputConnection(src->GetOutputPort());
      shaped_src->Update();
      m->SetInputConnection(shaped_src->GetOutputPort());
    } else {
      m->SetInputConnection(src->GetOutputPort());
    }
    m->ScalarVisibilityOff();
    auto actor = vtkSmartPointer<vtkActor>::New();
    actor->SetMapper(m);
    const std::array<double, 3> color = s.truth ? std::array<double, 3>{0, 0, 0} : OverlayColor(fitted++);
    actor->GetProperty()->SetColor(color[0], color[1], color[2]);
    if (s.truth || options.wireframe) {
      actor->GetProperty()->SetRepresentationToWireframe();
      actor->GetProperty()->SetOpacity(s.truth ? 0.35 : 0.8);
      actor->GetProperty()->LightingOff();
    } else {
      actor->GetProperty()->SetOpacity(options.sphere_opacity);
    }
    layer.actors.push_back(actor);
    char text[200];
    const Eigen::Vector3d c = s.sphere.center_mm + options.label_offset_mm;
    if (shaped) {
      std::snprintf(text, sizeof(text), "%s  %.0f x %.0f x %.0f  c (%.1f, %.1f, %.1f) mm", s.label.c_str(), s.axes_mm.x(),
                    s.axes_mm.y(), s.axes_mm.z(), c.x(), c.y(), c.z());
    } else {
      std::snprintf(text, sizeof(text), "%s  r %.1f  c (%.1f, %.1f, %.1f) mm", s.label.c_str(), s.sphere.radius_mm, c.x(),
                    c.y(), c.z());
    }
    vtkNew<vtkSphereSource> symbol;
    symbol->Update();
    double col[3] = {color[0], color[1], color[2]};
    legend->SetEntry(static_cast<int>(i), symbol->GetOutput(), text, col);
  }
  legend->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  // An entry about 24 px tall at the default size, so its text (scaled to the entry) reads at
  // 14 px or more.
  const double entry = std::max(0.045, 24.0 / double(options.height));
  legend->GetPositionCoordinate()->SetValue(0.01, 0.99 - entry * double(spheres.size()));
  legend->GetPosition2Coordinate()->SetCoordinateSystemToNormalizedViewport();
  legend->GetPosition2Coordinate()->SetValue(0.62, entry * double(spheres.size()));
  legend->BorderOff();
  legend->GetEntryTextProperty()->SetColor(1 - options.background[0], 1 - options.background[1], 1 - options.background[2]);
  return layer;
}

// Text on a picture: at least 14 px at the default size, in the background's contrasting grey.
constexpr int kTitlePx = 16;
constexpr int kLabelPx = 14;

double TextGrey(const RenderOptions& options) {
  return options.background[0] + options.background[1] + options.background[2] > 1.5 ? 0.0 : 1.0;
}

// Each view says which it is, at its top right.
vtkSmartPointer<vtkTextActor> ViewLabel(View view, const RenderOptions& options) {
  static const char* const kLabels[] = {"front (as the camera sees it)", "side (from the right)", "top (from above)",
                                        "iso"};
  auto label = vtkSmartPointer<vtkTextActor>::New();
  label->SetInput(kLabels[int(view)]);
  const double tc = TextGrey(options);
  label->GetTextProperty()->SetColor(tc, tc, tc);
  label->GetTextProperty()->SetFontSize(kLabelPx);
  label->GetTextProperty()->SetJustificationToRight();
  label->GetTextProperty()->SetVerticalJustificationToBottom();
  label->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  label->GetPositionCoordinate()->SetValue(0.98, 0.02);
  return label;
}

// The colour bar of a mapped colouring, in the background's contrasting grey.
vtkSmartPointer<vtkScalarBarActor> MakeScalarBar(const CloudLayer& cloud, const RenderOptions& options) {
  auto bar = vtkSmartPointer<vtkScalarBarActor>::New();
  bar->SetLookupTable(cloud.lut);
  // The title over two lines ("signed distance" / "(mm)"), so it fits above the bar at a size
  // that can be read at the picture's default size.
  std::string title = cloud.bar_title;
  if (const auto paren = title.find(" ("); paren != std::string::npos) title.replace(paren, 1, "\n");
  bar->SetTitle(title.c_str());
  bar->SetNumberOfLabels(5);
  bar->SetLabelFormat("%.1f");
  bar->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  bar->GetPositionCoordinate()->SetValue(0.80, 0.08);  // room for the title centred above the bar
  bar->SetWidth(0.15);
  bar->SetHeight(0.78);
  bar->SetBarRatio(0.3);
  bar->SetVerticalTitleSeparation(6);
  // Fixed pixel sizes: VTK otherwise scales the text with the bar, which made the title 5 px tall.
  bar->SetUnconstrainedFontSize(true);
  const double tc = TextGrey(options);
  for (vtkTextProperty* text : {bar->GetTitleTextProperty(), bar->GetLabelTextProperty()}) {
    text->SetColor(tc, tc, tc);
    text->ItalicOff();
    text->ShadowOff();
  }
  bar->GetTitleTextProperty()->SetFontSize(kTitlePx);
  bar->GetTitleTextProperty()->BoldOff();
  bar->GetLabelTextProperty()->SetFontSize(kLabelPx);
  return bar;
}

// One window (one X connection, one GL context) for the whole process: creating a fresh
// GLX window for every render intermittently aborts inside VTK under load.
vtkRenderWindow* SharedWindow() {
  static vtkSmartPointer<vtkRenderWindow> shared_window;
  if (!shared_window) {
    shared_window = vtkSmartPointer<vtkRenderWindow>::New();
    shared_window->SetOffScreenRendering(1);
    shared_window->SetMultiSamples(0);
  }
  return shared_window;
}

// One renderer per view, tiled; the legend and the bar on the first.
void RenderViews(const CloudLayer& cloud, const SphereLayer& spheres, vtkScalarBarActor* bar,
                 const RenderOptions& options, vtkRenderWindow* window) {
  const int n = static_cast<int>(options.views.size());
  const int cols = static_cast<int>(std::ceil(std::sqrt(double(n))));
  const int rows = (n + cols - 1) / cols;
  window->GetRenderers()->RemoveAllItems();
  window->SetSize(options.width * cols, options.height * rows);
  for (int k = 0; k < n; ++k) {
    vtkNew<vtkRenderer> ren;
    const int c = k % cols, r = k / cols;
    ren->SetViewport(double(c) / cols, 1.0 - double(r + 1) / rows, double(c + 1) / cols, 1.0 - double(r) / rows);
    ren->SetBackground(options.background[0], options.background[1], options.background[2]);
    ren->AddActor(cloud.actor);
    for (auto& a : spheres.actors) ren->AddActor(a);
    if (k == 0) {
      if (!spheres.actors.empty()) ren->AddViewProp(spheres.legend);
      if (bar != nullptr) ren->AddViewProp(bar);
    }
    ren->AddViewProp(ViewLabel(options.views[std::size_t(k)], options));
    const CameraSetup cam = CameraFor(options.views[std::size_t(k)], cloud.bounds);
    vtkCamera* camera = ren->GetActiveCamera();
    camera->SetPosition(cam.position.data());
    camera->SetFocalPoint(cam.focal_point.data());
    camera->SetViewUp(cam.view_up.data());
    camera->SetViewAngle(cam.view_angle_deg);
    ren->ResetCameraClippingRange();
    window->AddRenderer(ren);
  }
  window->Render();
}

void DrawToPng(const cloud::PointCloud& cloud, const std::vector<SphereOverlay>& spheres, const RenderOptions& options,
               const std::string& png_path) {
  EnsureDisplay();
  vtkObject::GlobalWarningDisplayOff();
  const CloudLayer points = MakeCloudLayer(cloud, spheres, options, png_path);
  const SphereLayer overlays = MakeSphereLayer(spheres, options);
  vtkSmartPointer<vtkScalarBarActor> bar;
  if (points.lut) bar = MakeScalarBar(points, options);
  vtkRenderWindow* window = SharedWindow();
  RenderViews(points, overlays, bar, options, window);
  WriteWindowPng(window, png_path);
}

}  // namespace
}  // namespace hedgefit::render

extern "C" int hedgefit_vtk_render_png_v1(const hedgefit::cloud::PointCloud* cloud,
                                           const std::vector<hedgefit::render::SphereOverlay>* spheres,
                                           const hedgefit::render::RenderOptions* options, const char* png_path, char* why,
                                           std::size_t why_size) {
  try {
    hedgefit::render::DrawToPng(*cloud, *spheres, *options, png_path);
    return 0;
  } catch (const std::exception& e) {
    std::snprintf(why, why_size, "%s", e.what());
    return 1;
  }
}
