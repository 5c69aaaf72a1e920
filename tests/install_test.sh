#!/usr/bin/env bash
# Installs hedgefit into a scratch prefix, builds the example out-of-tree plugin against
# it with find_package(hedgefit), and checks the installed hedgefit loads that plugin.
set -euo pipefail
build_dir=$1
source_dir=$2
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
cmake --install "$build_dir" --prefix "$scratch/prefix" > /dev/null
cmake -S "$source_dir/examples/plugin_decimate" -B "$scratch/plugin" -DCMAKE_PREFIX_PATH="$scratch/prefix" \
  -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$scratch/plugin" > /dev/null
out=$(HEDGEFIT_PLUGIN_PATH="$scratch/plugin" "$scratch/prefix/bin/hedgefit" plugins)
echo "$out" | grep -q "^loaded   $scratch/plugin/libhedgefit_decimate.so (decimate 1.0): filters.decimate" || {
  echo "installed hedgefit did not load the plugin built with find_package(hedgefit):"; echo "$out" | tail -5; exit 1; }
echo "install + find_package(hedgefit) + plugin load: ok"
# stream's video module (apps/video.hpp) is found by the installed binary: a file that is no
# video gets OpenCV's refusal, not "cannot be loaded".
err=$("$scratch/prefix/bin/hedgefit" stream --left "$source_dir/README.md" --right "$source_dir/README.md" \
  --rig "$source_dir/fuzz/corpus/rig_yaml/simulated.yaml" 2>&1 || true)
echo "$err" | grep -q "OpenCV cannot open it as a video" || {
  echo "installed hedgefit stream did not load its video module:"; echo "$err"; exit 1; }
echo "installed stream loads its video module: ok"
# The image module (stereo/image_io.hpp: TIFF, BMP, PNM through imgcodecs) is found beside the
# installed library: a BMP is decoded and only then judged (here: too small for the rig).
err=$("$scratch/prefix/bin/hedgefit" measure --left "$source_dir/fuzz/corpus/capture_image/colour.bmp" \
  --right "$source_dir/fuzz/corpus/capture_image/colour.bmp" --rig "$source_dir/fuzz/corpus/rig_yaml/simulated.yaml" 2>&1 || true)
echo "$err" | grep -q "images are 16x12 but the rig was calibrated at" || {
  echo "installed hedgefit did not read a BMP through its image module:"; echo "$err"; exit 1; }
echo "installed hedgefit reads BMP through its image module: ok"
# PCL's I/O (cloud/formats/pcl_io_module.hpp: a compressed PCD's LZF) and VTK (render/vtk_module.hpp)
# are modules found beside the installed library: the installed hedgefit reads a sample cloud and
# draws it. Neither loads at start-up: the executable does not need VTK's libraries.
"$scratch/prefix/bin/hedgefit" render "$source_dir/sample_clouds/cap_z2300_a60_o10.pcd" -o "$scratch/cap.png" > /dev/null || {
  echo "installed hedgefit could not read a compressed PCD and draw it through its modules"; exit 1; }
[ -s "$scratch/cap.png" ] || { echo "installed hedgefit render wrote no picture"; exit 1; }
if ldd "$scratch/prefix/bin/hedgefit" | grep -q "libvtk\|libpcl_io"; then
  echo "the installed hedgefit loads VTK or pcl_io at start-up; they belong in its modules"; exit 1
fi
echo "installed hedgefit reads PCD and draws through its modules, and loads neither at start: ok"
