#!/usr/bin/env bash
# Regenerates the pictures in docs/ from the bundled sample data (run after a build).
set -euo pipefail
cd "$(dirname "$0")/.."
H=./build/apps/hedgefit
mkdir -p build/docs docs
$H compare sample_clouds/cap_z2300_a60_o30.pcd --format json > build/docs/fits_cap.json
$H render sample_clouds/cap_z2300_a60_o30.pcd --fits build/docs/fits_cap.json \
  --methods kasa,hyper,ransac_geometric --color distance --view front,side --size 640x480 --wireframe \
  -o docs/render_cap_z2300_o30.png
$H compare sample_clouds/cap_z2000_a60_o10.pcd sample_clouds/cap_z2300_a60_o10.pcd sample_clouds/cap_z2600_a60_o10.pcd \
  --methods kasa,hyper,ransac,geometric,ransac_geometric --plot docs/compare_plot.png > /dev/null
echo "wrote docs/render_cap_z2300_o30.png docs/compare_plot.png"
