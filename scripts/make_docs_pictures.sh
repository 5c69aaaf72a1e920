#!/usr/bin/env bash
# Regenerates the pictures in docs/ from the bundled sample data (run after a build).
set -euo pipefail
cd "$(dirname "$0")/.."
H=./build/apps/hedgefit
mkdir -p build/docs docs
$H compare sample_clouds/cap_z2300_a60_o30.pcd --format json > build/docs/fits_cap.json
$H render sample_clouds/cap_z2300_a60_o30.pcd --fits build/docs/fits_cap.json \
  --method kasa,hyper,ransac_geometric --color distance --view front,side --size 640x480 --wireframe \
  -o docs/render_cap_z2300_o30.png
$H compare sample_clouds/cap_z2000_a60_o10.pcd sample_clouds/cap_z2300_a60_o10.pcd sample_clouds/cap_z2600_a60_o10.pcd \
  --method kasa,hyper,ransac,geometric,ransac_geometric --plot docs/compare_plot.png > /dev/null
# A reconstruction from simulated captures of the paper's lab (calibrated from its boards).
L=build/docs/lab
[ -f $L/sphere_2300_right.png ] || $H simulate --preset paper-lab -o $L > /dev/null
$H calibrate --left "$L/board_*_left.png" --right "$L/board_*_right.png" --board 12x11 --square 30 -o build/docs/rig.yaml > /dev/null
$H convert --left $L/sphere_2300_left.png --right $L/sphere_2300_right.png --rig build/docs/rig.yaml \
  -o build/docs/sphere_2300.pcd -q
$H compare build/docs/sphere_2300.pcd --method kasa,ransac_geometric --format json > build/docs/fits_sphere.json
$H render build/docs/sphere_2300.pcd --fits build/docs/fits_sphere.json --truth $L/sphere_2300.truth.json \
  --color distance --view front,side --size 640x480 --wireframe -o docs/reconstruction_z2300.png
# The operator's overlay of the same capture, from the capture-to-fit pipeline.
$H pipeline examples/capture_to_fit.json -q \
  --set readers.stereo.left=$L/sphere_2300_left.png --set readers.stereo.right=$L/sphere_2300_right.png \
  --set readers.stereo.rig=build/docs/rig.yaml --set writers.overlay.filename=docs/overlay_z2300.png \
  --set writers.pcd.filename=build/docs/sphere_2300_pipeline.pcd --set writers.png.filename=build/docs/pipeline.png
# A garden: three leafy balls on a lawn, found by depth, one cloud and one envelope fit each
# (half the paper's resolution keeps the picture small).
G=build/docs/garden
[ -f $G/garden_row_right.png ] || $H simulate --preset garden --scale 0.5 -o $G > /dev/null
$H pipeline examples/garden_to_fit.json -q \
  --set readers.stereo.left=$G/garden_row_left.png --set readers.stereo.right=$G/garden_row_right.png \
  --set readers.stereo.rig=$G/rig.yaml --set "writers.pcd.filename=$G/row_#.pcd" \
  --set writers.overlay.filename=docs/garden_row_overlay.png
# The same row by POV-Ray (leaf discs, a real camera's noise and colour), the same pipeline.
P=build/docs/garden-povray
[ -f $P/garden_row_right.png ] || $H simulate --preset garden --renderer povray --camera real --scale 0.5 -o $P > /dev/null
$H pipeline examples/garden_to_fit.json -q \
  --set readers.stereo.left=$P/garden_row_left.png --set readers.stereo.right=$P/garden_row_right.png \
  --set readers.stereo.rig=$P/rig.yaml --set "writers.pcd.filename=$P/row_#.pcd" \
  --set writers.overlay.filename=docs/garden_row_povray_overlay.png
# Shrubs taken for hedges by depth, told not a ball (dashed): POV-Ray's hard 'shrubs' garden.
S=build/docs/garden-hard-povray
[ -f $S/garden_shrubs_right.png ] || $H bench garden --hard --renderer povray --camera real --scale 0.5 --dir $S > /dev/null
$H measure --method envelope --rig $S/rig.yaml --left $S/garden_shrubs_left.png --right $S/garden_shrubs_right.png \
  --overlay docs/garden_shrubs_povray_overlay.png > /dev/null 2>&1
# The trim plan of the middle ball (envelope 520 mm) against a 500 mm target.
$H trim $G/row_2.pcd --radius 500 --method envelope --render docs/trim_row2.png > /dev/null
# PCL's real outdoor pair (grey): the round shrub, segmented by depth inside a box.
D=data/stereo_plants/pcl_outdoor_stereo_pair
if [ -f $D/stereo_left.png ]; then
  $H rig --size 640x480 --focal 368.5347 --cx 318.1122 --cy 224.3349 --baseline 838.7445 -o build/docs/pcl_rig.yaml > /dev/null
  $H convert --left $D/stereo_left.png --right $D/stereo_right.png --rig build/docs/pcl_rig.yaml \
    -o build/docs/shrub.pcd --box 270,178,44,34 --erode 1 --min-z 10000 --max-z 60000 --debug -q
  $H compare build/docs/shrub.pcd --method kasa,geometric --format json > build/docs/fits_shrub.json
  $H render build/docs/shrub.pcd --fits build/docs/fits_shrub.json --view front,side --size 480x400 --wireframe \
    --point-size 4 -o docs/pcl_outdoor_shrub.png
fi
echo "wrote docs/render_cap_z2300_o30.png docs/compare_plot.png docs/reconstruction_z2300.png docs/garden_row_overlay.png docs/garden_row_povray_overlay.png docs/trim_row2.png docs/pcl_outdoor_shrub.png"
# Hedges in any cloud: a simulated 16-beam LiDAR drive past a garden, and a real Velodyne scan.
[ -f build/scans/lidar16_garden1.ply ] || $H bench find --sensors lidar16 --gardens 1 --dir build/scans > /dev/null
$H find build/scans/lidar16_garden1.ply --plot docs/find_lidar_garden.png > /dev/null
[ ! -f data/sphere_scans/example2/L1_S3.xyz ] || $H find data/sphere_scans/example2/L1_S3.xyz --plot docs/find_velodyne.png > /dev/null
# Around the hedge: a row of two balls fused from eight captures with odometry-like poses.
[ -f build/around/hedgefit/row_ring_8/manifest_odometry.json ] || \
  $H bench around --scenes row --layouts ring --captures 8 --poses odometry --dir build/around > /dev/null
$H measure --manifest build/around/hedgefit/row_ring_8/manifest_odometry.json --plot docs/around_row.png > /dev/null
