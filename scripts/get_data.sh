#!/usr/bin/env bash
# Fetches the public real data sets docs/data.md lists into data/ (git-ignored), for the examples
# and the real-data tests. Needs internet access and curl and unzip (apt-get install curl unzip).
# UNTESTED: the machine hedgefit is built and tested on has no internet access. If a source has
# moved, docs/data.md names it; the tests skip, saying why, for any set that is missing.
# The TrimBot2020 garden model is not fetched: it has no licence file (docs/data.md).
set -euo pipefail
cd "$(dirname "$0")/.."
get() { mkdir -p "$(dirname "$2")"; [ -s "$2" ] || curl -fsSL "$1" -o "$2"; echo "data/${2#data/}"; }
GH=https://raw.githubusercontent.com

# OpenCV's samples (4.6.0): the chessboard stereo pairs and Middlebury's Aloe.
for i in 01 02 03 04 05 06 07 08 09 11 12 13 14; do
  get $GH/opencv/opencv/4.6.0/samples/data/left$i.jpg data/calib_chessboard/left$i.jpg
  get $GH/opencv/opencv/4.6.0/samples/data/right$i.jpg data/calib_chessboard/right$i.jpg
done
for f in aloeL.jpg aloeR.jpg aloeGT.png; do get $GH/opencv/opencv/4.6.0/samples/data/$f data/stereo_gt/aloe/$f; done

# Middlebury 2014 Motorcycle at quarter size, with its ground truth (MiddEval3 training set Q).
M=data/stereo_gt/middlebury2014_motorcycle_Q
get https://vision.middlebury.edu/stereo/submit3/zip/MiddEval3-data-Q.zip data/.cache/MiddEval3-data-Q.zip
get https://vision.middlebury.edu/stereo/submit3/zip/MiddEval3-GT0-Q.zip data/.cache/MiddEval3-GT0-Q.zip
mkdir -p $M
unzip -joq data/.cache/MiddEval3-data-Q.zip 'MiddEval3/trainingQ/Motorcycle/*' -d $M
unzip -joq data/.cache/MiddEval3-GT0-Q.zip 'MiddEval3/trainingQ/Motorcycle/*' -d $M

# Middlebury 2003 Cones as CNES/Pandora's tests ship it (the images saved under the names the
# tests read; OpenCV reads an image by its content, not its extension).
P=$GH/CNES/Pandora/HEAD/tests/pandora
C=data/stereo_gt/middlebury2003_cones_pandora
get $P/left.png $C/left.tif
get $P/right.png $C/right.tif
for f in disp_left.tif disp_right.tif occlusion.png; do get $P/$f $C/$f; done

# PCL's test clouds (the outdoor stereo pair's PNGs in stereo_plants/ are not made here).
for f in table_scene_mug_stereo_textured milk_cartoon_all_small_clorox five_people sac_plane_test \
         noisy_slice_displaced lamppost bun0 milk_color stereo_left stereo_right; do
  get $GH/PointCloudLibrary/pcl/master/test/$f.pcd data/pcl_test/$f.pcd
done

# Real Velodyne scans of a calibration sphere (tothtekla/SphereCalib, example 2).
for i in 1 2 3 4 5; do
  get $GH/tothtekla/SphereCalib/HEAD/examples/example2/data3D/L1_S$i.xyz data/sphere_scans/example2/L1_S$i.xyz
done
# The same sphere on a stand in another room (example 3).
for i in 1 2 3 4 5 6 7 8; do
  get $GH/tothtekla/SphereCalib/HEAD/examples/example3/data3D/L1_S$i.xyz data/sphere_scans/example3/L1_S$i.xyz
done
echo "get_data: done; see docs/data.md for each set's licence"
