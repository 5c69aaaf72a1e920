#pragma once
/// `hedgefit find`'s reports: a table a person reads, JSON and CSV a script reads. In JSON each
/// cloud holds a "hedges" array, one entry per object: id, verdict, ball (true for a ball or a
/// dome), center_mm and radius_mm (null for an object no sphere fits), the measures the verdict
/// rests on, and the fit's own fields as `compare` and `measure` write them (fitting::FitFields).

#include <ostream>
#include <string>
#include <vector>

#include "scene/finder.hpp"

namespace hedgefit::scene {

/// One cloud's result and how it was read.
struct FindReport {
  FindResult result;
  double scale = 1;           ///< coordinates were multiplied by it on read
  std::string scale_source;   ///< "given", "guessed: metres (...)", "guessed: mm"
  /// The cloud's global shift (cloud::PointCloud::offset, mm after scaling): the result's
  /// positions are in the shifted frame, and the reports add it back.
  Eigen::Vector3d offset_mm = Eigen::Vector3d::Zero();
  /// Where the viewpoints came from: "" (none), "given", "the PCD's VIEWPOINT", or "the origin: a
  /// spinning scanner's N rings about it".
  std::string viewpoint_source;
};

/// `find` on one cloud file: read (cloud/cloud_io.hpp), scaled to mm by `scale` (0: guessed from
/// its span and spacing, as `info` guesses), and searched with `options`. `cloud`, when given,
/// gets the cloud as searched (in mm), for the outputs drawn or written from it. `viewpoints`:
/// where the sensor stood, in the file's own units and frame (FindOptions::viewpoints_mm gets
/// them scaled and shifted as the points are); none given, a PCD's VIEWPOINT is taken when it is
/// not the origin, else the file's origin when the points lie on a spinning scanner's rings about
/// it (cloud::ScannerRings: a LiDAR's scan in its own frame).
FindReport FindInCloudFile(const std::string& file, double scale, const FindOptions& options,
                           cloud::PointCloud* cloud = nullptr, const std::vector<Eigen::Vector3d>& viewpoints = {});

void WriteFindTable(std::ostream& out, const std::vector<FindReport>& reports);
void WriteFindJson(std::ostream& out, const std::vector<FindReport>& reports);
void WriteFindCsv(std::ostream& out, const std::vector<FindReport>& reports);

}  // namespace hedgefit::scene
