// The drifted-rig suite (bench/rig_drift.hpp) on captures with truth:
//   bench_rig_drift --rig RIG LEFT_IMAGE... [--method M]
// e.g. the demo's lab: ./build/bench/bench_rig_drift --rig build/demo/rig.yaml build/demo/lab/sphere_2*_left.png

#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "bench/rig_drift.hpp"

int main(int argc, char** argv) {
  hedgefit::bench::DriftOptions o;
  std::string write_rigs;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--rig") && i + 1 < argc) {
      o.rig = argv[++i];
    } else if (!std::strcmp(argv[i], "--write-rigs") && i + 1 < argc) {
      write_rigs = argv[++i];
    } else if (!std::strcmp(argv[i], "--method") && i + 1 < argc) {
      o.method = argv[++i];
    } else {
      o.lefts.push_back(argv[i]);
    }
  }
  if (!write_rigs.empty() && !o.rig.empty()) {
    // Each drifted rig as a file, to measure with by hand: DIR/NN.yaml, in DriftSuite's order.
    const auto rig = hedgefit::stereo::ReadRig(o.rig);
    int n = 0;
    for (const auto& d : o.drifts) {
      char name[32];
      std::snprintf(name, sizeof(name), "/%02d.yaml", n++);
      hedgefit::stereo::WriteRig(write_rigs + name, hedgefit::sim::DriftRig(rig, d));
      std::printf("%s%s  %s\n", write_rigs.c_str(), name, d.name.c_str());
    }
    return 0;
  }
  if (o.rig.empty() || o.lefts.empty()) {
    std::fprintf(stderr, "usage: bench_rig_drift --rig RIG [--method M] NAME_left.png...\n");
    return 1;
  }
  try {
    hedgefit::bench::PrintRigDrift(hedgefit::bench::RunRigDrift(o));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_rig_drift: %s\n", e.what());
    return 1;
  }
  return 0;
}
