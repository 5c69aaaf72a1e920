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
echo "== hedgefit render (the last step writes a picture)"
./build/apps/hedgefit compare sample_clouds/scene_ground_z2300.pcd --format json > build/demo/fits.json
./build/apps/hedgefit render sample_clouds/scene_ground_z2300.pcd --fits build/demo/fits.json \
  --methods hyper,ransac_geometric --color distance --view front,side --size 640x480 -o build/demo/render.png
