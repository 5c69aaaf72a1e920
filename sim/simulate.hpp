#pragma once
/// What `hedgefit simulate` renders, as one request with its options declared once (the
/// command's flags are made from them): a preset (the paper's lab, the gardens, the wide
/// boards), one sphere or one board, by either renderer, through either camera model.

#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/option_table.hpp"

namespace hedgefit::sim {

struct SimulateRequest {
  std::string preset;              ///< paper-lab, garden, wide-boards, or "" for sphere or board
  std::string renderer = "hedgefit";
  std::vector<double> sphere;      ///< X, Y, Z, R (mm, left camera frame)
  std::vector<double> board;       ///< RX, RY, RZ (rad), TX, TY, TZ (mm)
  std::string squares = "13x12";   ///< board squares COLSxROWS
  std::string charuco;             ///< an ArUco dictionary: a ChArUco board
  double marker = 0;               ///< ChArUco marker side, mm (0 = 0.75 square)
  double square = 30;              ///< board square, mm
  std::string output = "simulated";
  double scale = 1, blur = 0.5, noise = 0;
  int supersample = 3, jpeg = 0;
  std::int64_t seed = 1;
  std::string camera = "ideal";    ///< ideal or real (CameraModel's defaults)

  static const pipeline::OptionTable<SimulateRequest>& Table();
};

/// Renders what `r` asks for into r.output (created); returns the line that says what was
/// written. Throws hedgefit::Error naming the option ("option 'sphere': ...") before writing
/// anything when the request is inconsistent.
std::string Simulate(const SimulateRequest& r);

}  // namespace hedgefit::sim
