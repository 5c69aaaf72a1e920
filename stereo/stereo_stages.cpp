// Thin adapters from declared options (each struct's OptionTable) to the capture functions.

#include "stereo/stereo_stages.hpp"

#include <opencv2/imgcodecs.hpp>  // the IMREAD_ flags
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>

#include "cloud/cloud_io.hpp"
#include "pipeline/option_table.hpp"
#include "pipeline/parallel.hpp"
#include "cloud/point_cloud.hpp"
#include "stereo/capture.hpp"
#include "stereo/image_io.hpp"
#include "stereo/rig_uncertainty.hpp"
#include "stereo/row_check.hpp"

namespace hedgefit::stereo {

namespace {

using pipeline::Context;
using pipeline::Options;

cv::Mat ReadImage(const std::string& path, const std::string& which) {
  if (path.empty()) throw Error("stage 'readers.stereo', option '" + which + "': give the " + which + " image");
  return ReadCaptureImage(path);
}

// Every segmentation stage ends here: an empty mask is "no hedge", never an empty cloud later.
void PutMask(Context& ctx, const cv::Mat& mask) {
  const int pixels = cv::countNonZero(mask);
  if (pixels == 0) throw Error("no hedge found: the segmentation mask is empty");
  ctx.Note("mask_pixels", static_cast<std::int64_t>(pixels));
  ctx.Put("mask", mask);
}

const StereoRig& RigOf(Context& ctx) { return ctx.Get<StereoRig>("rig"); }

cv::Mat ReadCaptureImageOrThrow(const std::string& path, int flags) {
  const std::vector<unsigned char> bytes = ReadFileBytes(path);
  const std::string format = SniffImageFormat(bytes.data(), bytes.size());
  RequireCaptureFormat(path, format);
  // A PNG ends with its IEND chunk, a JPEG with its EOI marker (FF D9; some cameras append data
  // after it, so the end's last 64 KiB are searched). Without them the file was cut short.
  if (format == "png" || format == "jpeg") {
    const std::size_t tail = std::min<std::size_t>(bytes.size(), 65536);
    const std::string end(bytes.end() - std::ptrdiff_t(tail), bytes.end());
    const bool png = format == "png";
    if (end.find(png ? "IEND" : "\xFF\xD9") == std::string::npos) {
      throw Error(path + ": the " + (png ? "PNG" : "JPEG") + " file is cut short (no " +
                  (png ? "IEND chunk" : "end-of-image marker") + "); copy it from the camera again");
    }
  }
  cv::Mat m;
  try {
    m = DecodeImage(bytes, flags, path);
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + "; give a PNG or JPEG file");
  }
  if (m.depth() != CV_8U) throw Error(path + ": not an 8-bit image; give an 8-bit PNG or JPEG file");
  if (flags == cv::IMREAD_COLOR && m.channels() == 1) cv::cvtColor(m, m, cv::COLOR_GRAY2BGR);
  return m;
}

}  // namespace

cv::Mat ReadCaptureImage(const std::string& path, int flags) {
  // Whatever is wrong with the file, it is the input's fault, wherever in a pipeline it is read.
  try {
    return ReadCaptureImageOrThrow(path, flags);
  } catch (const Error& e) {
    throw InputError(e.what());
  }
}

void RequireCaptureFormat(const std::string& path, const std::string& format) {
  // Only the formats cameras write are decoded: OpenCV's imgcodecs (the module that reads TIFF,
  // BMP and PNM) hands what it does not recognise to decoders such as GDCM's DICOM reader, which
  // fuzzing showed abort()s on bad input.
  if (format.empty() || format == "pfm") {
    throw Error(path + ": not a PNG, JPEG, TIFF, BMP or PNM image; give the camera's PNG or JPEG file");
  }
}

void PutCapture(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const StereoRig& rig, pipeline::Context* ctx) {
  if (left_bgr.size() != right_bgr.size()) {
    throw Error("the left image is " + std::to_string(left_bgr.cols) + "x" + std::to_string(left_bgr.rows) +
                " but the right one is " + std::to_string(right_bgr.cols) + "x" + std::to_string(right_bgr.rows) +
                "; give the two views of one capture");
  }
  ctx->Put("left_image", left_bgr);
  ctx->Put("right_image", right_bgr);
  ctx->Put("rig", rig);
  ctx->Put("rectified", false);
  // A calibrated rig's uncertainty, for the fitting stages to carry into each hedge's fit.
  if (!rig.covariance.empty()) ctx->Put("point_perturbation", RigPerturbation(rig));
  // And the matcher's: a disparity offset common to a hedge, as measured on real images.
  ctx->Put("disparity_perturbation", DisparityOffsetPerturbation(rig));
}

namespace {

// Every hedge by depth: the garden segmentation's artifacts and notes (stereo.segment_garden, and
// stereo.segment_auto when the colour mask cannot isolate the hedge).
void PutGardenSegmentation(const GardenSegmentOptions& p, Context& ctx) {
  const bool* rectified = ctx.Find<bool>("rectified");
  if (rectified && !*rectified) {
    throw Error("stage '" + ctx.current_stage + "': the images are not rectified; add stereo.rectify before it");
  }
  GardenSegmentation g = FindHedges(RigOf(ctx), ctx.Get<cv::Mat>("left_image"), ctx.Get<cv::Mat>("right_image"), p);
  ctx.Note("hedges", static_cast<std::int64_t>(g.hedges.size()));
  for (const HedgeRegion& h : g.hedges) {
    const std::string key = "hedge" + std::to_string(h.id) + ".";
    ctx.Note(key + "image_box", std::vector<double>{double(h.image_box.x), double(h.image_box.y),
                                                    double(h.image_box.width), double(h.image_box.height)});
    ctx.Note(key + "approx_radius_mm", h.approx_radius_mm);
    ctx.Note(key + "depth_range_mm", std::vector<double>{h.min_z_mm, h.max_z_mm});
    if (h.touches_border) ctx.Note(key + "cut_by_frame", true);
  }
  ctx.Note("ground_found", g.ground_found);
  std::string rejected;
  for (const auto& why : g.rejected) rejected += (rejected.empty() ? "" : "; ") + why;
  if (!rejected.empty()) ctx.Note("rejected", rejected);
  PutMask(ctx, g.labels != 0);
  if (g.ground_found) {
    // The ground in the unrectified left frame (the cloud's): n_u = R1^T n, d unchanged.
    const cv::Matx33d R1(RigOf(ctx).R1);
    const cv::Vec3d n = R1.t() * cv::Vec3d(g.ground[0], g.ground[1], g.ground[2]);
    ctx.Put("ground_plane", cv::Vec4d(n[0], n[1], n[2], g.ground[3]));
    ctx.Put("ground_clearance", p.ground_clearance_mm);
  }
  ctx.Put("hedge_labels", g.labels);
  ctx.Put("hedges", g.hedges);
}

}  // namespace

namespace {

using namespace hedgefit::cloud;
using namespace hedgefit::pipeline;

// readers.stereo: the pair and its rig
void AddReader(pipeline::Registry& r) {
  r.Add(StageInfo{"readers.stereo", "Reads a stereo capture (left and right images) and its rig file",
                  {StringOption("left", "", "left image"), StringOption("right", "", "right image"),
                   StringOption("rig", "", "rig file from `hedgefit calibrate`")},
                  {},
                  {"left_image", "right_image", "rig"},
                  {}},
        MakeFactory([](const Options& o, Context& ctx) {
          if (o.GetString("rig").empty()) throw Error("stage 'readers.stereo', option 'rig': give the rig file");
          // A reader that cannot read its files has bad input (exit 1), not a failed run: the
          // commands read each file here once, without a check of their own first.
          StereoRig rig;
          try {
            rig = ReadRig(o.GetString("rig"));
          } catch (const InputError&) {
            throw;
          } catch (const Error& e) {
            throw InputError(e.what());
          }
          // The two images decode side by side.
          cv::Mat images[2];
          std::exception_ptr errors[2];
          pipeline::ParallelFor(2, 0, 1, [&](std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i) {
              try {
                images[i] = ReadImage(o.GetString(i == 0 ? "left" : "right"), i == 0 ? "left" : "right");
              } catch (const InputError&) {
                errors[i] = std::current_exception();
              } catch (const Error& err) {
                errors[i] = std::make_exception_ptr(InputError(err.what()));
              }
            }
          });
          for (const std::exception_ptr& err : errors) {
            if (err) std::rethrow_exception(err);
          }
          PutCapture(images[0], images[1], rig, &ctx);
        }));
}

// stereo.rectify
void AddRectification(pipeline::Registry& r) {
  r.Add(StageInfo{"stereo.rectify", "Undistorts and rectifies the pair with the rig (Bouguet)", {},
                  {"left_image", "right_image", "rig"}, {"left_image", "right_image", "raw_left_image", "raw_right_image"}, {}},
        MakeFactory([](const Options&, Context& ctx) {
          cv::Mat l, rt;
          RectifyPair(RigOf(ctx), ctx.Get<cv::Mat>("left_image"), ctx.Get<cv::Mat>("right_image"), &l, &rt);
          // The originals stay: stereo.sgbm resamples its region again from them with B-splines.
          ctx.Put("raw_left_image", ctx.Get<cv::Mat>("left_image"));
          ctx.Put("raw_right_image", ctx.Get<cv::Mat>("right_image"));
          ctx.Put("left_image", l);
          ctx.Put("right_image", rt);
          ctx.Put("rectified", true);
        }));
}

// stereo.segment, stereo.mask, stereo.segment_depth, stereo.segment_garden
void AddSegmenters(pipeline::Registry& r) {
  r.Add(StageInfo{"stereo.segment",
                  "The paper's hedge mask: excess green, bilateral filter, gamma, Otsu, largest region, holes filled",
                  TableOptions<SegmentOptions>(), {"left_image"}, {"mask"}, {}},
        TableFactory<SegmentOptions>("stereo.segment", [](const SegmentOptions& p, const Options&, Context& ctx) {
          PutMask(ctx, SegmentHedge(ctx.Get<cv::Mat>("left_image"), p));
        }));
  r.Add(StageInfo{"stereo.mask", "The hedge mask from a file drawn on the original left image, rectified and eroded",
                  TableOptions<MaskOptions>(), {"left_image", "rig"}, {"mask"}, {}},
        TableFactory<MaskOptions>("stereo.mask", [](const MaskOptions& p, const Options&, Context& ctx) {
          PutMask(ctx, SegmentFromMaskFile(RigOf(ctx), p));
          ctx.Put("mask_given", true);  // the user's own: no hint about what the colour mask covers
        }));
  r.Add(StageInfo{"stereo.segment_depth",
                  "The hedge mask by depth inside a box: coarse match of the box, the connected region at the depth of "
                  "its middle; for grey images",
                  TableOptions<DepthSegmentOptions>(), {"left_image", "right_image", "raw_left_image", "rig"}, {"mask"}, {}},
        TableFactory<DepthSegmentOptions>("stereo.segment_depth",
                                          [](const DepthSegmentOptions& p, const Options&, Context& ctx) {
                                            cv::Mat& l = ctx.Get<cv::Mat>("left_image");
                                            cv::Mat& rt = ctx.Get<cv::Mat>("right_image");
                                            PutMask(ctx, SegmentByDepthInBox(RigOf(ctx), ctx.Get<cv::Mat>("raw_left_image"),
                                                                             ctx.Get<cv::Mat>("raw_right_image"), &l, &rt, p));
                                          }));
  r.Add(StageInfo{"stereo.segment_garden",
                  "Every hedge by depth, for gardens (green on green) and rows of hedges: coarse whole-frame match, "
                  "ground plane removed, compact round blobs standing on it; ids left to right",
                  TableOptions<GardenSegmentOptions>(), {"left_image", "right_image", "rig"},
                  {"mask", "hedge_labels", "hedges"}, {}},
        TableFactory<GardenSegmentOptions>("stereo.segment_garden",
                                           [](const GardenSegmentOptions& p, const Options&, Context& ctx) {
          PutGardenSegmentation(p, ctx);
        }));
}

// stereo.segment_auto: the colour mask, or every hedge by depth where it fails
void AddAutoSegmenter(pipeline::Registry& r) {
  r.Add(StageInfo{"stereo.segment_auto",
                  "The default: the paper's colour mask where it isolates the hedge (a lab), every hedge by depth "
                  "(stereo.segment_garden) where the colour mask covers more than garden_above of the frame or finds "
                  "nothing green (a garden)",
                  TableOptions<AutoSegmentOptions>(), {"left_image", "right_image", "rig"},
                  {"mask", "hedge_labels", "hedges"}, {}},
        TableFactory<AutoSegmentOptions>("stereo.segment_auto", [](const AutoSegmentOptions& p, const Options&,
                                                                   Context& ctx) {
          const cv::Mat& left = ctx.Get<cv::Mat>("left_image");
          auto share_of = [](const cv::Mat& m) { return double(cv::countNonZero(m)) / double(m.total()); };
          auto too_much = [&](double share) {
            return "the colour mask covers " + std::to_string(int(std::lround(100 * share))) + "% of the frame";
          };
          std::string why;
          cv::Mat colour;
          // The share first from a quarter-size image (a lab's few per cent and a garden's 54-69 % lie
          // far either side of garden_above): in a garden the full-size colour mask is never made.
          if (p.garden_above > 0 && left.cols >= 64 && left.rows >= 64) {
            cv::Mat small;
            cv::resize(left, small, cv::Size(left.cols / 4, left.rows / 4), 0, 0, cv::INTER_AREA);
            SegmentOptions quarter = p.colour;
            quarter.bilateral_diameter = quarter.bilateral_diameter > 0 ? std::max(1, quarter.bilateral_diameter / 4) : 0;
            quarter.bilateral_sigma_space /= 4;
            quarter.erode_px = 0;
            quarter.coarse = false;  // a share, from a small frame already
            try {
              const double share = share_of(SegmentHedge(small, quarter));
              if (share > p.garden_above) why = too_much(share);
            } catch (const Error&) {  // decided on the full-size mask below
            }
          }
          if (why.empty()) {
            try {
              colour = SegmentHedge(left, p.colour);
              const double share = share_of(colour);
              if (p.garden_above > 0 && share > p.garden_above) why = too_much(share);
            } catch (const Error& e) {
              if (p.garden_above <= 0) throw;
              why = e.what();  // nothing green, or all of it: depth may still find the hedge
            }
          }
          if (!why.empty()) {
            GardenSegmentOptions g = p.garden;
            g.erode_px = p.colour.erode_px;
            try {
              PutGardenSegmentation(g, ctx);
              ctx.Note("segmentation", "by depth (" + why + ")");
              return;
            } catch (const Error& e) {
              // Depth found nothing either: the colour mask stands (measure warns that it covers
              // too much), or, with none, both reasons.
              if (colour.empty()) {
                try {
                  colour = SegmentHedge(left, p.colour);
                } catch (const Error&) {
                  throw Error(why + "; by depth: " + e.what());
                }
              }
              ctx.Note("segmentation", "colour (by depth: " + std::string(e.what()) + ")");
              ctx.Put("depth_segmentation_failed", std::string(e.what()));  // for measure's warning
            }
          } else {
            ctx.Note("segmentation", std::string("colour"));
          }
          PutMask(ctx, colour);
        }));
}

// stereo.sgbm: SGBM, left-right check, sub-pixel refinement
void AddMatcher(pipeline::Registry& r) {
  r.Add(StageInfo{"stereo.sgbm",
                  "Improved semi-global matching: SGBM, left-right check, background-side hole filling, sub-pixel "
                  "refinement; only over the mask's region and the working range's disparities",
                  TableOptions<MatchOptions>(), {"left_image", "right_image", "rig"},
                  {"disparity", "filled", "disparity_sigma", "matched_region"}, {}},
        TableFactory<MatchOptions>("stereo.sgbm", [](const MatchOptions& p, const Options&, Context& ctx) {
          const bool* rectified = ctx.Find<bool>("rectified");
          if (rectified && !*rectified) {
            throw Error("stage 'stereo.sgbm': the images are not rectified; add stereo.rectify before it");
          }
          const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
          // Headers: the matched region is re-rendered in place in the rectified images.
          cv::Mat l = ctx.Get<cv::Mat>("left_image"), rt = ctx.Get<cv::Mat>("right_image");
          // Several hedges: each matched over its own region.
          const cv::Mat* labels = ctx.Find<cv::Mat>("hedge_labels");
          const auto* hedges = ctx.Find<std::vector<HedgeRegion>>("hedges");
          const MatchResult m =
              labels ? MatchHedges(RigOf(ctx), ctx.Find<cv::Mat>("raw_left_image"), ctx.Find<cv::Mat>("raw_right_image"),
                                   &l, &rt, *labels, p, hedges ? *hedges : std::vector<HedgeRegion>())
                     : MatchHedge(RigOf(ctx), ctx.Find<cv::Mat>("raw_left_image"), ctx.Find<cv::Mat>("raw_right_image"),
                                  &l, &rt, mask ? *mask : cv::Mat(), p);
          ctx.Note("matched_fraction", double(m.matched_area) / double(l.total()));
          ctx.Put("matched_area", m.matched_area);
          if (m.stride > 1) ctx.Note("stride", static_cast<std::int64_t>(m.stride));
          ctx.Note("filled", static_cast<std::int64_t>(m.filled_count));
          if (m.less_certain_dropped > 0) ctx.Note("less_certain_dropped", static_cast<std::int64_t>(m.less_certain_dropped));
          ctx.Note("disparity_range", std::vector<double>{double(m.min_disparity), double(m.min_disparity + m.num_disparities)});
          if (m.rectify_region_ms > 0) ctx.Note("rectify_region_ms", m.rectify_region_ms);
          ctx.Note("sgbm_ms", m.sgbm_ms);
          ctx.Note("refine_ms", m.refine_ms);
          if (m.vertical.samples > 0) {
            ctx.Note("vertical_disparity_px", m.vertical_max_px);
            ctx.Put("vertical_disparity_px", m.vertical_max_px);
          }
          // Views that do not match at all (two unrelated images, left given for right, a rig of
          // other cameras) leave a few hundred chance survivors of the left-right check out of a
          // hedge of tens of thousands of pixels (0.4-2.2 % on unrelated noise and on swapped lab and
          // garden pairs), and a sphere fitted to them means nothing. A real hedge keeps over half
          // (the lab sphere with all but its front 50 mm beyond --max-z: 41 %), so under a tenth is
          // refused.
          // A hedge thinned to every stride-th pixel and row (max_points) is judged on the pixels kept.
          if (mask && !mask->empty()) {
            const int hedge = cv::countNonZero(*mask) / (m.stride * m.stride);
            // Over the matched region: outside it every disparity is NaN.
            const cv::Rect in = m.matched_region & cv::Rect(0, 0, m.disparity.cols, m.disparity.rows);
            const cv::Mat d = m.disparity(in);
            const cv::Mat measured = (d == d) & (m.filled(in) == 0) & ((*mask)(in) != 0);
            const int matched = cv::countNonZero(measured) + m.less_certain_dropped;  // judged before the cut
            if (hedge >= 500 && matched < hedge / 10) {
              char buf[160];
              std::snprintf(buf, sizeof(buf), "only %d of the hedge's %d pixels (%.1f %%) match between the views", matched,
                            hedge, 100.0 * matched / hedge);
              throw Error("stage 'stereo.sgbm': " + std::string(buf) +
                          ": the images are not a stereo pair of this rig, left and right are swapped, or the hedge "
                          "lies outside --min-z/--max-z");
            }
          }
          ctx.Put("hedge_matches", m.hedges);
          ctx.Put("disparity", m.disparity);
          ctx.Put("filled", m.filled);
          ctx.Put("disparity_sigma", m.disparity_sigma);
          ctx.Put("matched_region", m.matched_region);
        }));
}

// Where the rig check starts its search: the hedges' median disparity (every 7th pixel), else the
// middle of the default working range.
double ExpectedDisparity(Context& ctx) {
  const StereoRig& rig = RigOf(ctx);
  const double fb = rig.P1.at<double>(0, 0) * rig.baseline_mm;
  const cv::Mat* d = ctx.Find<cv::Mat>("disparity");
  std::vector<float> v;
  if (d && d->type() == CV_32F) {
    for (int y = 0; y < d->rows; y += 7) {
      const float* row = d->ptr<float>(y);
      for (int x = 0; x < d->cols; x += 7) {
        if (row[x] == row[x]) v.push_back(row[x]);
      }
    }
  }
  if (v.size() < 20) return fb / std::sqrt(kDefaultMinZmm * kDefaultMaxZmm);
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// stereo.rig_check: the rig against the capture's own images
void AddRigCheck(pipeline::Registry& r) {
  r.Add(StageInfo{"stereo.rig_check",
                  "Checks the rig against this capture's own images: how far apart the rectified rows are over the "
                  "frame (corners tracked in 2-D), over each hedge and how much of each hedge matched; widens each "
                  "hedge's interval by what a small drift can cost, marks every result unusable when the rig does "
                  "not fit the cameras",
                  TableOptions<RigCheckOptions>(), {"left_image", "right_image", "rig"}, {"input_checks"}, {}},
        // Each stage built keeps its own rows over the frames it runs on (a warm pipeline's).
        [](const Options& o) -> std::unique_ptr<pipeline::Stage> {
          const RigCheckOptions params = pipeline::CheckedParams(RigCheckOptions::Table().FromOptions(o), "stereo.rig_check");
          auto pool = std::make_shared<RowPool>();
          return std::make_unique<pipeline::LambdaStage>(o, [params, pool](const Options&, Context& ctx) {
          const RigCheckOptions& p = params;
          const bool* rectified = ctx.Find<bool>("rectified");
          if (rectified && !*rectified) {
            throw Error("stage 'stereo.rig_check': the images are not rectified; add stereo.rectify before it");
          }
          const StereoRig& rig = RigOf(ctx);
          const auto* hedges = ctx.Find<std::vector<HedgeMatch>>("hedge_matches");
          const cv::Mat* labels = ctx.Find<cv::Mat>("hedge_labels");
          const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
          const CaptureRigCheck c =
              CheckCaptureRig(ctx.Get<cv::Mat>("left_image"), ctx.Get<cv::Mat>("right_image"), rig,
                              hedges ? *hedges : std::vector<HedgeMatch>(), labels ? *labels : cv::Mat(),
                              mask ? *mask : cv::Mat(), ExpectedDisparity(ctx), p, pool.get());
          ctx.Note("rig_check", c.verdict);
          ctx.Note("rig_rows_frame_px", c.rows.max_abs_px);
          ctx.Note("rig_rows_plane_px", c.rows.plane_max_px);
          ctx.Note("rig_rows_off_plane_px", c.rows.off_plane_px);
          ctx.Note("rig_corners", static_cast<std::int64_t>(c.rows.samples.size()));
          if (c.verdict == "widened") ctx.Put("disparity_perturbation", DisparityErrorPerturbation(rig, c.field));
          ctx.Put("input_checks", c.checks);
          });
        });
}

// stereo.reproject: disparity to points
void AddReprojection(pipeline::Registry& r) {
  r.Add(StageInfo{"stereo.reproject",
                  "Disparity to points in the unrectified left camera frame (mm), coloured, inside the mask",
                  TableOptions<ReprojectOptions>(), {"disparity", "left_image", "rig"}, {"cloud"}, {}},
        TableFactory<ReprojectOptions>("stereo.reproject", [](const ReprojectOptions& p, const Options&, Context& ctx) {
          const cv::Mat* mask = ctx.Find<cv::Mat>("mask");
          const cv::Mat* filled = ctx.Find<cv::Mat>("filled");
          const cv::Mat* sigma = ctx.Find<cv::Mat>("disparity_sigma");
          const cv::Mat* labels = ctx.Find<cv::Mat>("hedge_labels");
          const cv::Rect* region = ctx.Find<cv::Rect>("matched_region");
          cloud::PointCloud pc = ReprojectMeasured(ctx.Get<cv::Mat>("disparity"), mask ? *mask : cv::Mat(),
                                                   filled ? *filled : cv::Mat(), ctx.Get<cv::Mat>("left_image"),
                                                   RigOf(ctx), p, sigma ? *sigma : cv::Mat(), labels ? *labels : cv::Mat(),
                                                   region ? *region : cv::Rect());
          // Garden segmentation found the ground: fine points on the lawn (at a hedge's foot, where
          // the coarse mask reaches down) are dropped as the coarse ones were.
          const cv::Vec4d* ground = ctx.Find<cv::Vec4d>("ground_plane");
          const double* clearance = ctx.Find<double>("ground_clearance");
          if (ground && clearance) {
            std::vector<bool> keep(pc.size());
            std::size_t dropped = 0;
            for (std::size_t i = 0; i < pc.size(); ++i) {
              const Eigen::Vector3f& q = pc.points_mm[i];
              const double h = (*ground)[0] * q.x() + (*ground)[1] * q.y() + (*ground)[2] * q.z() + (*ground)[3];
              keep[i] = !cloud::IsFinite(q) || h >= *clearance;
              dropped += keep[i] ? 0 : 1;
            }
            if (dropped > 0) {
              if (pc.IsOrganized()) {
                pc = cloud::MaskOrganized(pc, keep);
              } else {
                std::vector<std::size_t> idx;
                for (std::size_t i = 0; i < keep.size(); ++i) {
                  if (keep[i]) idx.push_back(i);
                }
                pc = cloud::Select(pc, idx);
              }
            }
            ctx.Note("below_ground_clearance", static_cast<std::int64_t>(dropped));
          }
          if (pc.size() == cloud::CountNonFinite(pc)) {
            throw Error("no hedge found: every point lies on the ground (within the ground clearance)");
          }
          ctx.Note("points", static_cast<std::int64_t>(pc.size() - cloud::CountNonFinite(pc)));
          ctx.Put("cloud", std::move(pc));
        }));
}

}  // namespace

void RegisterStereoStages(pipeline::Registry& r) {
  // One row per family of stages.
  for (auto add : {&AddReader, &AddRectification, &AddSegmenters, &AddAutoSegmenter, &AddMatcher, &AddRigCheck, &AddReprojection}) add(r);
}

void CheckCaptureImages(const std::string& left, const std::string& right) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const std::string& image : {left, right}) {
    if (fs::is_directory(image, ec)) throw Error(image + ": is a directory; give the image file in it");
    if (!fs::is_regular_file(image, ec)) throw Error(image + ": no such image file; check the path");
    unsigned char head[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    std::ifstream(image, std::ios::binary).read(reinterpret_cast<char*>(head), sizeof(head));
    RequireCaptureFormat(image, SniffImageFormat(head, sizeof(head)));
  }
}

}  // namespace hedgefit::stereo
