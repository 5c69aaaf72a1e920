// The drifted-rig suite (bench/rig_drift.hpp) on captures with truth:
//   bench_rig_drift --rig RIG LEFT_IMAGE... [--method M]
// e.g. the demo's lab: ./build/bench/bench_rig_drift --rig build/demo/rig.yaml build/demo/lab/sphere_2*_left.png

#include <cstdio>
#include <exception>
#include <string>

#include "bench/bench_util.hpp"
#include "bench/rig_drift.hpp"

int main(int argc, char** argv) {
  hedgefit::bench::DriftOptions o;
  std::string write_rigs;
  const char* usage = "--rig RIG [--method M] [--write-rigs DIR] NAME_left.png...";
  const int done = hedgefit::bench::ParseOptions(
      argc, argv, "bench_rig_drift", usage,
      [&](const std::string& a, const char* v) {
        if (a == "--rig") o.rig = v;
        else if (a == "--write-rigs") write_rigs = v;
        else if (a == "--method") o.method = v;
        else return false;
        return true;
      },
      [&](const std::string& a) {
        if (a.empty() || a[0] == '-') return false;
        o.lefts.push_back(a);
        return true;
      });
  if (done >= 0) return done;
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
    std::fprintf(stderr, "bench_rig_drift: give --rig and at least one left image\nusage: bench_rig_drift %s\n", usage);
    return 2;
  }
  try {
    hedgefit::bench::PrintRigDrift(hedgefit::bench::RunRigDrift(o));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_rig_drift: %s\n", e.what());
    return 1;
  }
  return 0;
}
