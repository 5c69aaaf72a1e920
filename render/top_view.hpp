#pragma once
/// The top view of a cloud after `find`: every point from above (ground grey, objects in the
/// colour of their verdict, shaded by height), each ball's circle and number in green, each
/// object that is not a ball outlined (its points' convex hull) and numbered in orange.

#include <Eigen/Core>

#include <string>
#include <vector>

#include "cloud/point_cloud.hpp"
#include "scene/finder.hpp"

namespace hedgefit::render {

/// Draws `result` over `cloud` (the cloud it was found in) to a PNG of about `size` px on its
/// longer side; throws hedgefit::Error naming `path` when it cannot be written. `marks` (the
/// cloud's x, y in mm, e.g. a map's topiary for comparison) are drawn as black crosses.
void WriteTopView(const cloud::PointCloud& cloud, const scene::FindResult& result, const std::string& path,
                  int size = 1200, const std::vector<Eigen::Vector2d>& marks = {});

/// Marks for WriteTopView from a text file: one "x y" (or "x,y") per line in the cloud's units,
/// times `scale` (to mm); # starts a comment. A line that is not two numbers is an error naming it.
std::vector<Eigen::Vector2d> ReadTopViewMarks(const std::string& path, double scale);

}  // namespace hedgefit::render
