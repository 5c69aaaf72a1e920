#!/usr/bin/env bash
# Command 1: install dependencies, build hedgefit (Release), run the main job on the
# bundled sample data.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2 --target hedgefit
mkdir -p build/demo
echo "== hedgefit info sample_clouds/scene_ground_z2300.pcd"
./build/apps/hedgefit info sample_clouds/scene_ground_z2300.pcd
echo "== hedgefit pipeline examples/clean.json --metadata build/demo/metadata.json"
./build/apps/hedgefit pipeline examples/clean.json --metadata build/demo/metadata.json
echo "== wrote build/demo/cleaned.pcd and build/demo/metadata.json"
echo "== hedgefit compare sample_clouds/*.pcd"
./build/apps/hedgefit compare sample_clouds/*.pcd
echo "== hedgefit bench lab: simulated captures -> calibration -> PCD -> every fitter, Table 2"
./build/apps/hedgefit bench lab --dir build/demo/lab
echo "== the same path with the separate commands: calibrate from the boards, convert one capture, compare with its truth"
L=build/demo/lab
./build/apps/hedgefit calibrate --left "$L/board_*_left.png" --right "$L/board_*_right.png" --board 12x11 --square 30 \
  -o build/demo/rig.yaml | tail -1
./build/apps/hedgefit convert --left $L/sphere_2300_left.png --right $L/sphere_2300_right.png --rig build/demo/rig.yaml \
  -o build/demo/sphere_2300.pcd
./build/apps/hedgefit compare build/demo/sphere_2300.pcd --truth $L/sphere_2300.truth.json
echo "== the same capture in one step, as a robot would ask: hedgefit measure (one JSON line per hedge)"
./build/apps/hedgefit measure --rig build/demo/rig.yaml --left $L/sphere_2300_left.png --right $L/sphere_2300_right.png \
  --overlay build/demo/sphere_2300_measure.png
echo "== the same capture as one pipeline: examples/capture_to_fit.json"
./build/apps/hedgefit pipeline examples/capture_to_fit.json
echo "== hedgefit render (the last step writes a picture of the reconstruction and its fits)"
./build/apps/hedgefit compare build/demo/sphere_2300.pcd --method kasa,ransac_geometric --format json > build/demo/fits.json
./build/apps/hedgefit render build/demo/sphere_2300.pcd --fits build/demo/fits.json --truth $L/sphere_2300.truth.json \
  --color distance --view front,side --size 640x480 --wireframe -o build/demo/render.png
