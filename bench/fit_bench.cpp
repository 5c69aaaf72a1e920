// Sphere fitters on 10k, 100k and 1M points, side by side with PCL's own
// SACSegmentation + SACMODEL_SPHERE as users call it, in one run.
// Usage: bench_fitters [--repeats N] [--max-points N]
// Data: a 60-degree cap of a r = 300 mm sphere at 2.3 m, sigma 3 mm, 10 % outliers.

#include <pcl/ModelCoefficients.h>
#include <pcl/console/print.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench/bench_util.hpp"
#include "fitting/algebraic_fit.hpp"
#include "fitting/envelope_fit.hpp"
#include "fitting/geometric_fit.hpp"
#include "fitting/ransac_fit.hpp"

namespace {

using hedgefit::fitting::Sphere;

constexpr double kPi = 3.14159265358979323846;
const Eigen::Vector3d kCenter(80, -40, 2300);

std::vector<Eigen::Vector3d> MakeCloud(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, 3.0);
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(n);
  const std::size_t inliers = n * 9 / 10;
  for (std::size_t i = 0; i < inliers; ++i) {
    const double c = 0.5 + 0.5 * u(rng), s = std::sqrt(1 - c * c), phi = 2 * kPi * u(rng);
    const Eigen::Vector3d normal(s * std::cos(phi), s * std::sin(phi), -c);
    pts.push_back(kCenter + (300.0 + noise(rng)) * normal);
  }
  while (pts.size() < n) {
    pts.push_back(kCenter + Eigen::Vector3d(u(rng) * 1000 - 500, u(rng) * 1000 - 500, -350 + u(rng) * 400));
  }
  return pts;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hedgefit::fitting;
  int repeats = 3;
  std::size_t max_points = 1000000;
  const int done = hedgefit::bench::ParseOptionPairs(argc, argv, "bench_fitters", "[--repeats N] [--max-points N]",
                                                     [&](const std::string& a, const char* v) {
                                                       if (a == "--repeats") repeats = std::max(1, std::atoi(v));
                                                       else if (a == "--max-points") max_points = std::strtoull(v, nullptr, 10);
                                                       else return false;
                                                       return true;
                                                     });
  if (done >= 0) return done;
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  std::printf("sphere fitters, median of %d runs, %u hardware threads; cap 60 deg, r 300 mm at 2.3 m, sigma 3 mm, "
              "10 %% outliers\n",
              repeats, std::thread::hardware_concurrency());
  std::printf("%-34s %10s %12s %12s %12s\n", "method", "points", "median ms", "ms/Mpoint", "radius err mm");
  for (std::size_t n : {std::size_t(10000), std::size_t(100000), std::size_t(1000000)}) {
    if (n > max_points) break;
    const auto pts = MakeCloud(n, 1);
    auto row = [&](const std::string& name, const std::function<double()>& fit) {
      double radius = 0;
      const double ms = hedgefit::bench::MedianMs(repeats, [&] { radius = fit(); });
      std::printf("%-34s %10zu %12.2f %12.2f %12.3f\n", name.c_str(), n, ms, ms / (double(n) / 1e6), radius - 300.0);
    };
    for (AlgebraicMethod m :
         {AlgebraicMethod::kKasa, AlgebraicMethod::kPratt, AlgebraicMethod::kTaubin, AlgebraicMethod::kHyper}) {
      row(std::string("hedgefit ") + MethodName(m), [&] {
        AlgebraicFitOptions o;
        o.method = m;
        return FitSphereAlgebraic(pts, o).sphere.radius_mm;
      });
    }
    RansacFitOptions ro;
    ro.distance_threshold_mm = 9;
    ro.min_radius_mm = 100;
    ro.max_radius_mm = 1000;
    row("hedgefit ransac (PCL, centred)", [&] { return FitSphereRansac(pts, ro).sphere.radius_mm; });
    row("PCL SACSegmentation SACMODEL_SPHERE", [&] {
      // As a PCL user writes it: raw float coordinates, optimisation on.
      auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
      cloud->resize(pts.size());
      for (std::size_t i = 0; i < pts.size(); ++i) {
        (*cloud)[i] = pcl::PointXYZ(float(pts[i].x()), float(pts[i].y()), float(pts[i].z()));
      }
      pcl::SACSegmentation<pcl::PointXYZ> seg;
      seg.setModelType(pcl::SACMODEL_SPHERE);
      seg.setMethodType(pcl::SAC_RANSAC);
      seg.setDistanceThreshold(9);
      seg.setRadiusLimits(100, 1000);
      seg.setMaxIterations(10000);
      seg.setOptimizeCoefficients(true);
      seg.setInputCloud(cloud);
      pcl::PointIndices inliers;
      pcl::ModelCoefficients coeffs;
      seg.segment(inliers, coeffs);
      return coeffs.values.size() == 4 ? double(coeffs.values[3]) : -1.0;
    });
    GeometricFitOptions go;
    go.compute_covariance = false;
    row("hedgefit geometric (Ceres, no cov.)", [&] { return FitSphereGeometric(pts, go).sphere.radius_mm; });
    go.compute_covariance = true;
    row("hedgefit geometric (Ceres, with cov.)", [&] { return FitSphereGeometric(pts, go).sphere.radius_mm; });
    // The leafy-shell fit: a geometric start on every point, then its likelihood over at most
    // 10000 of them (two LBFGS starts at most). Here a bare cap: it should read the geometric
    // fit's sphere, all the points on the envelope.
    row("hedgefit envelope (shell ML)", [&] { return FitEnvelope(pts).fit.sphere.radius_mm; });
  }
  std::printf("(radius err: fit minus true 300 mm; outliers bias the non-robust fits by design)\n");
  // The uncertainty's refit (AddUncertainty repeats it 48 times per fit with a matcher
  // perturbation: 16 jackknife patches and 32 draws): 3000 points, one thread, from the sphere
  // of the whole cap, on the cap less one sixteenth, as the jackknife leaves out a patch.
  {
    auto pts = MakeCloud(3000 * 10 / 9, 2);
    pts.resize(3000);  // the cap's points only: least squares, as the refit is run on supporting points
    GeometricFitOptions go;
    go.compute_covariance = false;
    go.num_threads = 1;
    const SphereFitResult whole = FitSphereGeometric(pts, go);
    std::vector<Eigen::Vector3d> rest;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      if (i % 16 != 0) rest.push_back(pts[i]);
    }
    const int refits = 48;
    double ceres_r = 0, gn_r = 0;
    const double ceres_ms = hedgefit::bench::MedianMs(repeats, [&] {
      for (int k = 0; k < refits; ++k) ceres_r = FitSphereGeometric(rest, go, &whole.sphere).sphere.radius_mm;
    });
    const double gn_ms = hedgefit::bench::MedianMs(repeats, [&] {
      for (int k = 0; k < refits; ++k) gn_r = RefitSphereGeometric(rest, whole.sphere).value_or(Sphere{}).radius_mm;
    });
    std::printf("\nrefit from a close start, %zu points, %d refits, 1 thread (median of %d runs):\n", rest.size(),
                refits, repeats);
    std::printf("%-34s %12.2f ms  radius %.6f mm\n", "Ceres LM (FitSphereGeometric)", ceres_ms, ceres_r);
    std::printf("%-34s %12.2f ms  radius %.6f mm  (%.1fx faster)\n", "Gauss-Newton (RefitSphereGeometric)", gn_ms, gn_r,
                ceres_ms / std::max(1e-9, gn_ms));
  }
  return 0;
}
