// The Python module `hedgefit` (pybind11): clouds as numpy arrays, every fitter, `measure` on
// a pair of numpy images with a rig file, the trim plan, and JSON pipelines. It wraps the same
// library code as the `hedgefit` command; errors raise hedgefit.Error (a ValueError) with the
// command's one-line message.

#include <sstream>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "cloud/cloud_io.hpp"
#include "cloud/describe.hpp"
#include "pipeline/error.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/registry.hpp"
#include "pipeline/version.hpp"
#include "eval/evaluation.hpp"
#include "fitting/fit_fields.hpp"
#include "fitting/methods.hpp"
#include "fitting/trim.hpp"
#include "around/around_report.hpp"
#include "around/fusion.hpp"
#include "around/views.hpp"
#include "scene/find_report.hpp"
#include "scene/finder.hpp"
#include "cloud/describe.hpp"
#include "stereo/capture.hpp"
#include "stereo/rig.hpp"
#include "stereo/stereo_stages.hpp"
#include "stereo/rig_check.hpp"
#include "measure/measure_capture.hpp"
#include "measure/modules.hpp"

namespace py = pybind11;
using namespace hedgefit;

namespace {

const pipeline::Registry& Stages() {
  static pipeline::Registry& registry = [] () -> pipeline::Registry& {
    pipeline::Registry& r = pipeline::Registry::Global();
    measure::AddStageModules(r);
    return r;
  }();
  return registry;
}

py::object ToPython(const pipeline::OptionValue& v) {
  return std::visit([](const auto& x) -> py::object { return py::cast(x); }, v);
}

pipeline::OptionValue FromPython(const std::string& name, const py::handle& v) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>();
  if (py::isinstance<py::int_>(v)) return v.cast<std::int64_t>();
  if (py::isinstance<py::float_>(v)) return v.cast<double>();
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::sequence>(v) || py::isinstance<py::array>(v)) return v.cast<std::vector<double>>();
  throw Error("option '" + name + "': give a bool, a number, a string or a list of numbers");
}

py::dict FitDict(const fitting::SphereFitResult& f) {
  py::dict d;
  d["hedge"] = f.hedge_id ? f.hedge_id : 1;
  for (const auto& [key, value] : fitting::FitFields(f)) {
    if (key != "hedge_id") d[py::str(key)] = ToPython(value);
  }
  return d;
}

// (N, 3) points in mm from any numeric array.
std::vector<Eigen::Vector3d> Points(const py::array_t<double, py::array::c_style | py::array::forcecast>& xyz) {
  if (xyz.ndim() != 2 || xyz.shape(1) != 3) throw Error("xyz: give an (N, 3) array of points in mm");
  std::vector<Eigen::Vector3d> pts(static_cast<std::size_t>(xyz.shape(0)));
  const double* p = xyz.data();
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  return pts;
}

py::dict CloudDict(const cloud::PointCloud& c) {
  py::dict d;
  if (c.offset.isZero()) {
    py::array_t<float> xyz({static_cast<py::ssize_t>(c.size()), py::ssize_t(3)});
    for (std::size_t i = 0; i < c.size(); ++i) std::memcpy(xyz.mutable_data(py::ssize_t(i), 0), c.points_mm[i].data(), 12);
    d["xyz"] = xyz;
  } else {
    // Shifted on reading (coordinates too large for single precision): float64, the shift added back.
    py::array_t<double> xyz({static_cast<py::ssize_t>(c.size()), py::ssize_t(3)});
    for (std::size_t i = 0; i < c.size(); ++i) {
      const Eigen::Vector3d p = c.points_mm[i].cast<double>() + c.offset;
      std::memcpy(xyz.mutable_data(py::ssize_t(i), 0), p.data(), 24);
    }
    d["xyz"] = xyz;
  }
  if (c.HasColor()) {
    py::array_t<std::uint8_t> rgb({static_cast<py::ssize_t>(c.size()), py::ssize_t(3)});
    for (std::size_t i = 0; i < c.size(); ++i) std::memcpy(rgb.mutable_data(py::ssize_t(i), 0), c.colors[i].data(), 3);
    d["rgb"] = rgb;
  }
  for (const auto& [name, values] : c.fields) {
    if (!values.empty()) d[py::str(name)] = py::array_t<float>(py::ssize_t(values.size()), values.data());
  }
  return d;
}

cloud::PointCloud CloudFrom(const py::array_t<double, py::array::c_style | py::array::forcecast>& xyz, const py::object& rgb,
                            const py::dict& fields) {
  cloud::PointCloud c;
  cloud::SetPoints(Points(xyz), &c);  // shifted when too large for single precision, as the readers do
  if (!rgb.is_none()) {
    const auto a = rgb.cast<py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>>();
    if (a.ndim() != 2 || a.shape(1) != 3 || std::size_t(a.shape(0)) != c.size()) {
      throw Error("rgb: give an (N, 3) uint8 array, one colour per point");
    }
    c.colors.resize(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) std::memcpy(c.colors[i].data(), a.data(py::ssize_t(i), 0), 3);
  }
  for (const auto& [key, value] : fields) {
    const auto a = value.cast<py::array_t<float, py::array::c_style | py::array::forcecast>>();
    const std::string name = key.cast<std::string>();
    if (a.ndim() != 1 || std::size_t(a.shape(0)) != c.size()) throw Error("field '" + name + "': give one value per point");
    c.fields[name] = std::vector<float>(a.data(), a.data() + a.shape(0));
  }
  c.Flatten();
  return c;
}

// An image array as OpenCV's 8-bit BGR (or grey). Only uint8 is taken: pybind11 would cast any
// other dtype silently, and a 0..1 float image would arrive all black.
cv::Mat ImageFrom(const py::array& any, const char* what) {
  if (!any.dtype().is(py::dtype::of<std::uint8_t>())) {
    throw Error(std::string(what) + ": give a uint8 array (got " + std::string(py::str(any.dtype())) +
                "); a 0..1 float image is (image * 255).round().astype(numpy.uint8)");
  }
  const auto a = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>::ensure(any);
  if (!a || !(a.ndim() == 2 || (a.ndim() == 3 && a.shape(2) == 3))) {
    throw Error(std::string(what) + ": give an (H, W, 3) BGR or (H, W) grey uint8 array");
  }
  const cv::Mat view(int(a.shape(0)), int(a.shape(1)), a.ndim() == 3 ? CV_8UC3 : CV_8UC1,
                     const_cast<std::uint8_t*>(a.data()));
  return view.clone();
}

// Runs a pipeline on a context; returns its fits, its cloud and its metadata.
py::dict RunAndCollect(pipeline::Pipeline& p, pipeline::Context& ctx) {
  pipeline::RunReport report;
  {
    py::gil_scoped_release release;
    report = p.Run(ctx);
  }
  py::dict out;
  py::list fits;
  if (const auto* f = ctx.Find<std::vector<fitting::SphereFitResult>>("fits")) {
    for (const auto& r : *f) fits.append(FitDict(r));
  }
  out["fits"] = fits;
  if (const auto* c = ctx.Find<cloud::PointCloud>("cloud")) out["cloud"] = CloudDict(*c);
  out["metadata"] = py::module_::import("json").attr("loads")(p.MetadataJson(report, ctx));
  return out;
}

// Clouds as numpy arrays: read_cloud, write_cloud.
void AddCloudFunctions(py::module_& m) {
  m.def("read_cloud", [](const std::string& path) { return CloudDict(cloud::ReadCloud(path)); }, py::arg("path"),
        "Reads a PCD, PLY or XYZ file: a dict with 'xyz' ((N, 3) float32, mm), 'rgb' ((N, 3) uint8) when the file "
        "has colour, and one (N,) float32 array per extra field (e.g. 'hedge_id', 'cut_depth').");
  m.def(
      "write_cloud",
      [](const std::string& path, const py::array_t<double, py::array::c_style | py::array::forcecast>& xyz,
         const py::object& rgb, const py::dict& fields) { cloud::WriteCloud(path, CloudFrom(xyz, rgb, fields)); },
      py::arg("path"), py::arg("xyz"), py::arg("rgb") = py::none(), py::arg("fields") = py::dict(),
      "Writes points ((N, 3), mm), optional colours ((N, 3) uint8) and fields ({name: (N,)}) to PCD, PLY or XYZ by "
      "extension, atomically.");
}

// The fitters: methods, fit.
void AddFitFunctions(py::module_& m) {
  m.def("methods", &fitting::FitMethodNames, "The fit methods, e.g. 'kasa', 'ransac_geometric', 'envelope'.");
  m.def(
      "fit",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& xyz, const std::string& method,
         std::uint64_t seed, const py::object& pixel_mm, const py::kwargs& options) {
        std::map<std::string, pipeline::OptionValue> given;
        const fitting::FitMethod& fm = fitting::FindFitMethod(method, "method");
        for (const auto& [key, value] : options) {
          const std::string name = key.cast<std::string>();
          const bool declared = std::any_of(fm.options.begin(), fm.options.end(), [&](const auto& s) { return s.name == name; });
          if (!declared) throw Error("fit(method='" + method + "'): unknown option '" + name + "'; see `hedgefit plugins`");
          given[name] = FromPython(name, value);
        }
        const std::vector<Eigen::Vector3d> pts = Points(xyz);
        // The units policy (cloud/describe.hpp): points in metres are refused with the fix.
        if (const std::string why = cloud::MetresReason(cloud::LargestExtent(pts), "multiply the points by 1000");
            !why.empty()) {
          throw Error("fit: " + why);
        }
        std::vector<double> pixel;
        if (!pixel_mm.is_none()) {
          const auto a = pixel_mm.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
          if (a.ndim() != 1 || std::size_t(a.shape(0)) != pts.size()) {
            throw Error("fit(pixel_mm=...): give one value per point, shape (" + std::to_string(pts.size()) + ",)");
          }
          pixel.assign(a.data(), a.data() + a.shape(0));
        }
        fitting::SphereFitResult r;
        {
          py::gil_scoped_release release;
          r = fitting::RunFitMethod(method, pts, given, seed, false, pixel.empty() ? nullptr : &pixel);
        }
        return FitDict(r);
      },
      py::arg("xyz"), py::arg("method") = "ransac_geometric", py::arg("seed") = 42, py::arg("pixel_mm") = py::none(),
      "Fits a sphere to (N, 3) points in mm with any method of hedgefit.methods(); keyword arguments are the "
      "method's options (as in a pipeline). pixel_mm: optional (N,) footprint of one pixel at each point (a capture "
      "cloud's 'pixel_mm' field), which the envelope fit uses. Returns a dict: converged, center_mm, radius_mm, "
      "rms_mm, std_error_mm, inliers, ...");
}

// Stereo captures: read_image, measure, check_rig.
void AddCaptureFunctions(py::module_& m) {
  m.def("read_image",
        [](const std::string& path) {
          const cv::Mat img = stereo::ReadCaptureImage(path, 1 /* cv::IMREAD_COLOR */);
          py::array_t<std::uint8_t> a({py::ssize_t(img.rows), py::ssize_t(img.cols), py::ssize_t(3)});
          for (int y = 0; y < img.rows; ++y) std::memcpy(a.mutable_data(y, 0, 0), img.ptr(y), std::size_t(img.cols) * 3);
          return a;
        },
        py::arg("path"), "Reads a capture image (PNG, JPEG, TIFF, BMP, PNM) as an (H, W, 3) uint8 BGR array.");
  m.def(
      "measure",
      [](const py::array& left, const py::array& right, const std::string& rig_path,
         const std::string& method, bool garden, bool clean, const py::kwargs& options) {
        measure::MeasureRequest request;
        if (garden) request.capture.mode = stereo::SegmentMode::kGarden;
        request.methods = {method};
        request.clean = clean;
        // Each keyword sets that option in every capture stage that declares it (as a
        // `hedgefit measure` flag does); one no stage declares is an error.
        for (const auto& [key, value] : options) {
          const std::string name = key.cast<std::string>();
          request.capture_options[name] = FromPython(name, value);
        }
        const cv::Mat l = ImageFrom(left, "left"), r = ImageFrom(right, "right");
        const stereo::StereoRig rig = stereo::ReadRig(rig_path);
        measure::MeasureResult result;
        {
          py::gil_scoped_release release;
          result = measure::MeasureCapture(l, r, rig, request, Stages());
        }
        // What `hedgefit measure` prints as warnings (the rig check's, the colour mask's) as a
        // Python warning; an unusable hedge's dict also says why under "unusable".
        if (!result.hint.empty()) {
          if (PyErr_WarnEx(PyExc_RuntimeWarning, ("hedgefit.measure: " + result.hint).c_str(), 1) != 0) throw py::error_already_set();
        }
        py::list fits;
        for (const auto& f : result.fits) fits.append(FitDict(f));
        return fits;
      },
      py::arg("left"), py::arg("right"), py::arg("rig"), py::arg("method") = "ransac_ray",
      py::arg("garden") = false, py::arg("clean") = true,
      "Measures every hedge of a stereo pair: left and right as (H, W, 3) uint8 BGR arrays (hedgefit.read_image), "
      "the rig file from `hedgefit calibrate`. Runs what `hedgefit measure` runs; keyword arguments set capture "
      "options (min_z=1000, max_z=3500, erode=3, ...). Hedges are found by the colour mask where it isolates them and "
      "by depth where it does not (a garden; garden_above=0.4 of the frame), or always by depth with garden=True. "
      "Returns one dict per hedge (hedge, center_mm, radius_mm, std_error_mm, inliers, rms_mm, wall_ms, ...), with "
      "the capture's rig check (rig_check: ok, widened, unusable; 'unusable' says why, and a RuntimeWarning is "
      "raised: a robot must not act on such a hedge).");
  m.def(
      "check_rig",
      [](const py::array& left, const py::array& right, const std::string& rig_path,
         double min_z, double max_z) {
        if (!(min_z > 0 && max_z > min_z)) throw Error("check_rig: need 0 < min_z < max_z (mm)");
        const stereo::StereoRig rig = stereo::ReadRig(rig_path);
        stereo::CheckRowSearchRange(rig, min_z, max_z, "check_rig: min_z", "max_z");
        const stereo::VerticalDisparity v =
            stereo::MeasureRowAgreement(rig, ImageFrom(left, "left"), ImageFrom(right, "right"), min_z, max_z);
        py::dict d;
        d["offset_px"] = v.offset_px;
        d["slope_x_px"] = v.slope_x_px;
        d["slope_y_px"] = v.slope_y_px;
        d["max_abs_px"] = v.samples > 0 ? v.MaxAbs(rig.image_size) : std::numeric_limits<double>::quiet_NaN();
        d["windows"] = v.samples;
        return d;
      },
      py::arg("left"), py::arg("right"), py::arg("rig"), py::arg("min_z") = 1000.0, py::arg("max_z") = 20000.0,
      "How far apart a rig leaves a pair's rectified rows, as `hedgefit check-rig`: a dict with offset_px (at the "
      "centre), slope_x_px and slope_y_px (across the width and down the height), max_abs_px and windows (0: too "
      "little texture to tell; NaN max_abs_px).");
}

// The trim plan and JSON pipelines: trim, run_pipeline.
void AddPlanFunctions(py::module_& m) {
  m.def(
      "trim",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& xyz, const std::vector<double>& center,
         double radius, double tolerance, const std::vector<double>& axes, double heading, const std::string& shape,
         const std::vector<double>& up, double bin_deg) {
        if (center.size() != 3) throw Error("trim: center: give [x, y, z] in mm");
        if (!(bin_deg >= 0)) throw Error("trim: bin_deg: give the cut bins' size in degrees, or 0 for automatic");
        if (!axes.empty() && axes.size() != 3) throw Error("trim: axes: give [a, b, c] semi-axes in mm, or none for a sphere");
        if (up.size() != 3) throw Error("trim: up: give the vertical as [x, y, z]");
        if (axes.empty() && !(radius > 0)) throw Error("trim: give the target's radius (mm), or a clipped shape's axes");
        fitting::TrimOptions to;
        to.tolerance_mm = tolerance;
        if (!axes.empty()) to.axes_mm = Eigen::Vector3d(axes[0], axes[1], axes[2]);
        to.heading_deg = heading;
        to.shape = shape;
        to.bin_deg = bin_deg;
        const fitting::TrimPlan t =
            fitting::PlanTrim(Points(xyz), fitting::Sphere{Eigen::Vector3d(center[0], center[1], center[2]), axes.empty() ? radius : 1},
                              to, Eigen::Vector3d(up[0], up[1], up[2]));
        py::dict d;
        d["cut_depth"] = py::array_t<float>(py::ssize_t(t.depth_mm.size()), t.depth_mm.data());
        d["points_to_cut"] = t.points_to_cut;
        d["cut_share"] = t.cut_share;
        d["cut_p50_mm"] = t.cut_p50_mm;
        d["cut_p90_mm"] = t.cut_p90_mm;
        d["cut_p99_mm"] = t.cut_p99_mm;
        d["cut_max_mm"] = t.cut_max_mm;
        d["seen_share"] = t.seen_share;
        d["volume_seen_l"] = t.volume_seen_l;
        d["volume_all_round_l"] = t.volume_all_round_l;
        d["volume_binning_l"] = t.volume_binning_l;
        d["bin_deg"] = t.bin_deg;
        for (const std::string& w : t.warnings) {
          if (PyErr_WarnEx(PyExc_UserWarning, ("hedgefit.trim: " + w).c_str(), 1) != 0) throw py::error_already_set();
        }
        return d;
      },
      py::arg("xyz"), py::arg("center"), py::arg("radius") = 0.0, py::arg("tolerance") = 5.0,
      py::arg("axes") = std::vector<double>{}, py::arg("heading") = 0.0, py::arg("shape") = "ellipsoid",
      py::arg("up") = std::vector<double>{0, -1, 0}, py::arg("bin_deg") = 0.0,
      "The trim plan of (N, 3) points against a target sphere of `radius`, or a clipped shape of semi-axes `axes` "
      "(along `heading`, degrees about `up` from x; across it; along `up`) that is an 'ellipsoid', a 'cylinder' (R, R, "
      "half-height), a 'cuboid' (half-sides) or a 'cone' (base R, R, half-height): per-point cut depth (mm, + = cut, along the ray from the centre), share "
      "to cut, depth percentiles, volume to remove (litres), as `hedgefit trim`. `up` is the vertical (a camera's "
      "cloud: [0, -1, 0]); `bin_deg` the cut bins' size (0: from the points' spacing; give a few degrees on boxes and "
      "cones, whose radius changes fast across a bin: see volume_binning_l).");
  m.def(
      "run_pipeline",
      [](const std::string& pipeline, std::uint64_t seed) {
        const bool text = pipeline.find_first_of("[{") != std::string::npos;
        pipeline::Pipeline p = text ? pipeline::Pipeline::FromJson(pipeline, "pipeline", Stages())
                                 : pipeline::Pipeline::FromFile(pipeline, Stages());
        pipeline::Context ctx;
        ctx.quiet = true;
        ctx.seed = seed;
        return RunAndCollect(p, ctx);
      },
      py::arg("pipeline"), py::arg("seed") = 42,
      "Runs a JSON pipeline (its text, or a file name) as `hedgefit pipeline` does; returns a dict with 'fits' (one "
      "dict per fit), 'cloud' (the final cloud, as read_cloud gives it) and 'metadata'.");
}

}  // namespace

// Hedges in any cloud: find.
void AddFindFunctions(py::module_& m) {
  m.def(
      "find",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& xyz, double scale, std::uint64_t seed,
         const py::object& viewpoints, const py::kwargs& options) {
        std::map<std::string, pipeline::OptionValue> given;
        const auto specs = scene::FindOptions::Table().Specs();
        for (const auto& [key, value] : options) {
          const std::string name = key.cast<std::string>();
          const bool declared = std::any_of(specs.begin(), specs.end(), [&](const auto& s) { return s.name == name; });
          if (!declared) throw Error("find: unknown option '" + name + "'; see `hedgefit plugins` (segment.hedges)");
          given[name] = FromPython(name, value);
        }
        scene::FindOptions o;
        scene::FindOptions::Table().Apply(given, &o);
        o.seed = seed;
        cloud::PointCloud c = CloudFrom(xyz, py::none(), py::dict());
        scene::FindReport rep;
        rep.scale = scale > 0 ? scale : cloud::GuessScale(c);
        rep.scale_source = scale > 0 ? "given" : (rep.scale == 1000.0 ? "metres, guessed" : "mm, guessed");
        if (rep.scale != 1.0) {
          for (auto& p : c.points_mm) p *= float(rep.scale);
          c.offset *= rep.scale;
        }
        rep.offset_mm = c.offset;
        if (!viewpoints.is_none()) {
          const auto v = viewpoints.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
          if (v.ndim() != 2 || v.shape(1) != 3) throw Error("find: viewpoints must be a (K, 3) array of where the sensor stood, in xyz's units");
          const auto r = v.unchecked<2>();
          for (py::ssize_t i = 0; i < r.shape(0); ++i) {
            o.viewpoints_mm.push_back(Eigen::Vector3d(r(i, 0), r(i, 1), r(i, 2)) * rep.scale - c.offset);
          }
        }
        std::ostringstream text;
        std::vector<float> hedge_id;
        {
          py::gil_scoped_release release;
          rep.result = scene::FindHedges(c, o);
          hedge_id = scene::LabelCloud(c, rep.result).fields[cloud::kHedgeIdField];
          scene::WriteFindJson(text, {rep});
        }
        py::dict out = py::module_::import("json").attr("loads")(text.str())["clouds"][py::int_(0)];
        out["hedge_id"] = py::array_t<float>(py::ssize_t(hedge_id.size()), hedge_id.data());
        return out;
      },
      py::arg("xyz"), py::arg("scale") = 0.0, py::arg("seed") = 42, py::arg("viewpoints") = py::none(),
      "`hedgefit find` on (N, 3) points: the ground, the objects on it, every hedge ball and every clipped topiary "
      "shape among them. scale: multiplies the points (1000 for metres; 0 = guessed from their span and spacing). "
      "viewpoints: (K, 3) positions the sensor stood at, in xyz's units (find's --viewpoint). "
      "Keyword arguments are segment.hedges' options (min_radius=300, up='-y', max_roughness=3.5, ...). Returns the "
      "dict `find --format json` gives per cloud ('hedges': id, verdict, ball, topiary, shape, center_mm, radius_mm, "
      "...) and 'hedge_id', each point's ball or topiary (0: none).");
}

// Around the hedge: several captures with poses, fused.
void AddAroundFunctions(py::module_& m) {
  m.def(
      "fuse",
      [](const std::string& manifest, const std::string& rig, const std::string& captures, const py::kwargs& options) {
        std::map<std::string, pipeline::OptionValue> given;
        const auto specs = around::FuseOptions::Table().Specs();
        for (const auto& [key, value] : options) {
          const std::string name = key.cast<std::string>();
          const bool declared = std::any_of(specs.begin(), specs.end(), [&](const auto& sp) { return sp.name == name; });
          if (!declared) throw Error("fuse: unknown option '" + name + "'; see `hedgefit measure --help` (Fusing)");
          given[name] = FromPython(name, value);
        }
        around::FuseOptions o;
        around::FuseOptions::Table().Apply(given, &o);
        o.Check();
        const bool tum = manifest.size() > 4 && manifest.substr(manifest.size() - 4) != "json";
        if (tum && captures.empty()) throw Error("fuse: a TUM trajectory needs captures='DIR' (TIME_left.png, TIME_right.png)");
        std::vector<std::string> lines;
        around::FuseResult r;
        {
          py::gil_scoped_release release;
          const std::vector<around::PosedCapture> caps =
              tum ? around::ReadTumCaptures(manifest, captures) : around::ReadManifest(manifest);
          for (const auto& c : caps) {
            if (c.rig.empty() && rig.empty()) throw Error(manifest + ": capture " + c.name + " has no rig: give rig=");
          }
          stereo::ConvertOptions co;
          r = around::Fuse(around::MeasureViews(caps, rig, co), o);
          lines = around::FuseJsonLines(r, false);
        }
        const py::object loads = py::module_::import("json").attr("loads");
        py::list hedges, poses;
        for (const std::string& line : lines) {
          py::dict d = loads(line);
          (d.contains("hedge") ? hedges : poses).append(d);
        }
        for (const std::string& w : r.warnings) PyErr_WarnEx(PyExc_UserWarning, w.c_str(), 1);
        py::dict out;
        out["hedges"] = hedges;
        out["captures"] = poses;
        out["cloud"] = CloudDict(r.cloud);
        return out;
      },
      py::arg("manifest"), py::arg("rig") = "", py::arg("captures") = "",
      "`hedgefit measure --manifest` (or a TUM trajectory with captures='DIR'): each capture measured, the poses "
      "registered and each hedge fitted to all its points. Keyword arguments are the fusing options "
      "(registration='none', match_gate=0.6, ...). Returns {'hedges': [...], 'captures': [...], 'cloud': the fused "
      "cloud as read_cloud gives it}; a capture left out is a warning.");
}

PYBIND11_MODULE(hedgefit, m) {
  m.doc() = "hedgefit: measure spherical hedges from a binocular camera (clouds as numpy arrays, sphere fits, "
            "stereo measurement, trim plans, JSON pipelines)";
  m.attr("__version__") = kVersion;
  hedgefit::fitting::QuietSolverWarnings();  // errors reach Python as exceptions and results, not as glog lines
  static py::exception<Error> error(m, "Error", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      error(e.what());
    }
  });
  AddCloudFunctions(m);
  AddFitFunctions(m);
  AddFindFunctions(m);
  AddAroundFunctions(m);
  AddCaptureFunctions(m);
  AddPlanFunctions(m);
}
