#pragma once
/// The rig's calibration uncertainty carried into 3-D points by sampling: rigs drawn from the
/// calibrated parameters' covariance re-triangulate the pixel pairs the nominal rig matched.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "cloud/point_perturbation.hpp"
#include "stereo/rig.hpp"
#include "stereo/row_check.hpp"

namespace hedgefit::stereo {

/// `n` rigs with K, D, R, T drawn from N(RigParameters(rig), rig.covariance), seeded, so a run
/// can be repeated. Throws hedgefit::Error if the rig has no covariance.
std::vector<StereoRig> SampleRigs(const StereoRig& rig, int n, std::uint64_t seed);

/// Points measured with `nominal` (left camera frame, mm) as `other` would have measured them:
/// each point is projected into both raw images with `nominal` (the pixel pair the matcher
/// found), and the two viewing rays are intersected with `other`'s parameters (midpoint of the
/// closest approach). With other = nominal the points come back unchanged.
void Retriangulate(const StereoRig& nominal, const StereoRig& other, const std::vector<Eigen::Vector3d>& in,
                   std::vector<Eigen::Vector3d>* out);

/// The standard deviation of a disparity offset common to a whole hedge, px: the mean signed
/// error (bias) of hedgefit's matcher on the real Middlebury pairs with ground truth (bench_middlebury:
/// +0.053 px on Motorcycle, -0.046 px on Cones, as the capture path matches; Aloe's stored truth
/// carries its own +0.2 px offset).
/// Such an offset moves every point of a hedge along its ray together, so averaging over the
/// points does not shrink it.
constexpr double kDisparityOffsetSigmaPx = 0.05;

/// The "disparity_perturbation" artifact: draws of a common disparity offset (N(0, sigma_px^2),
/// seeded), each moving the points along their rays from the left camera as the rectified
/// disparity d = f B / Z becomes d + offset. Empty when the rig has no rectification.
cloud::PointPerturbation DisparityOffsetPerturbation(const StereoRig& rig, double sigma_px = kDisparityOffsetSigmaPx,
                                                     int samples = 32, std::uint64_t seed = 2);

/// The "disparity_perturbation" artifact of a rig that leaves the capture's rows apart
/// (stereo.rig_check): each draw adds to the common offset (as DisparityOffsetPerturbation, the
/// same draws) the horizontal error `field` implies, its pattern scaled by a draw of N(0, 1) (the
/// sign of a rig's error is not known from the rows), and its off-plane part as a second offset.
cloud::PointPerturbation DisparityErrorPerturbation(const StereoRig& rig, const DisparityErrorField& field,
                                                    double sigma_px = kDisparityOffsetSigmaPx, int samples = 32,
                                                    std::uint64_t seed = 2);

/// The "point_perturbation" artifact of a calibrated rig: `samples` rigs from SampleRigs.
/// Empty (samples = 0) when the rig carries no covariance.
cloud::PointPerturbation RigPerturbation(const StereoRig& rig, int samples = 32, std::uint64_t seed = 1);

}  // namespace hedgefit::stereo
