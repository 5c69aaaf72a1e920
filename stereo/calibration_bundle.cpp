// The stereo calibration's joint least-squares problem in Ceres: both cameras' intrinsics and
// distortion, the rotation and translation between them, and every board's pose, fitted to the
// corners of both views. cv::stereoCalibrate solves the same problem but reports no parameter
// covariance; here the covariance comes from the same Jacobian (Ceres' Covariance), scaled by
// the residual variance, the way COLMAP and Ceres' own examples report it.

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <opencv2/calib3d.hpp>

#include <array>
#include <cmath>

#include "pipeline/error.hpp"
#include "stereo/calibration.hpp"

namespace hedgefit::stereo {

namespace {

// OpenCV's camera model (calib3d's projectPoints without skew or thin-prism terms): a point in
// the camera frame -> pixel. intr = fx fy cx cy; dist = k1 k2 p1 p2 k3 k4 k5 k6. With
// aspect > 0, fy = aspect * fx (CALIB_FIX_ASPECT_RATIO) and intr[1] is unused.
template <typename T>
void Project(const T* intr, const T* dist, double aspect, const T* p, T* uv) {
  const T x = p[0] / p[2], y = p[1] / p[2];
  const T r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const T radial = (T(1) + dist[0] * r2 + dist[1] * r4 + dist[4] * r6) /
                   (T(1) + dist[5] * r2 + dist[6] * r4 + dist[7] * r6);
  const T xd = x * radial + T(2) * dist[2] * x * y + dist[3] * (r2 + T(2) * x * x);
  const T yd = y * radial + dist[2] * (r2 + T(2) * y * y) + T(2) * dist[3] * x * y;
  const T fy = aspect > 0 ? intr[0] * T(aspect) : intr[1];
  uv[0] = intr[0] * xd + intr[2];
  uv[1] = fy * yd + intr[3];
}

// One board corner and where a camera saw it; the residual is the projection's miss, px.
struct Corner {
  Corner(const cv::Point3f& b, const cv::Point2f& o, double a) : board{b.x, b.y, b.z}, obs{o.x, o.y}, aspect(a) {}
  // x_out = AngleAxis(r) x_in + t.
  template <typename T>
  static void Move(const T* r, const T* t, const T* in, T* out) {
    ceres::AngleAxisRotatePoint(r, in, out);
    for (int i = 0; i < 3; ++i) out[i] += t[i];
  }
  // The board corner in the left camera (pose maps board -> left camera).
  template <typename T>
  void InLeft(const T* pose_r, const T* pose_t, T* p) const {
    const T b[3] = {T(board[0]), T(board[1]), T(board[2])};
    Move(pose_r, pose_t, b, p);
  }
  template <typename T>
  void Residual(const T* intr, const T* dist, const T* p, T* res) const {
    T uv[2];
    Project(intr, dist, aspect, p, uv);
    res[0] = uv[0] - T(obs[0]);
    res[1] = uv[1] - T(obs[1]);
  }
  std::array<double, 3> board;
  std::array<double, 2> obs;
  double aspect;
};

// Seen by the left camera.
struct LeftCorner : Corner {
  using Corner::Corner;
  template <typename T>
  bool operator()(const T* intr, const T* dist, const T* pose_r, const T* pose_t, T* res) const {
    T p[3];
    InLeft(pose_r, pose_t, p);
    Residual(intr, dist, p, res);
    return true;
  }
};

// Seen by the right camera: x_right = R (pose x_board) + T.
struct RightCorner : Corner {
  using Corner::Corner;
  template <typename T>
  bool operator()(const T* intr, const T* dist, const T* pose_r, const T* pose_t, const T* rig_r, const T* rig_t,
                  T* res) const {
    T p[3], q[3];
    InLeft(pose_r, pose_t, p);
    Move(rig_r, rig_t, p, q);
    Residual(intr, dist, q, res);
    return true;
  }
};

}  // namespace

namespace {

// The covariance of the parameters a rig keeps, in RigParameters() order (the board poses are
// nuisance parameters, marginalised by taking the blocks of the full inverse), scaled by the
// residual variance `sigma2`; zero where Ceres cannot compute it.
cv::Mat ParameterCovariance(ceres::Problem* problem, double* const intr[2], double* const dist[2], double* rig_r,
                            double* rig_t, const double aspect[2], double sigma2, const CalibrationOptions& options) {
  std::vector<const double*> blocks = {rig_r, rig_t};
  if (options.refine_intrinsics) blocks.insert(blocks.begin(), {intr[0], dist[0], intr[1], dist[1]});
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;  // drop directions the data does not constrain rather than fail
  co.num_threads = 1;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> pairs;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    for (std::size_t j = i; j < blocks.size(); ++j) pairs.emplace_back(blocks[i], blocks[j]);
  }
  cv::Mat cov = cv::Mat::zeros(kRigParameters, kRigParameters, CV_64F);
  if (covariance.Compute(pairs, problem)) {
    const int start[] = {0, 4, 12, 16, 24, 27};
    const int size[] = {4, 8, 4, 8, 3, 3};
    const std::size_t first = options.refine_intrinsics ? 0 : 4;
    for (std::size_t i = 0; i < blocks.size(); ++i) {
      for (std::size_t j = i; j < blocks.size(); ++j) {
        const std::size_t bi = first + i, bj = first + j;
        std::vector<double> b(std::size_t(size[bi] * size[bj]));
        covariance.GetCovarianceBlock(blocks[i], blocks[j], b.data());
        for (int r = 0; r < size[bi]; ++r) {
          for (int c = 0; c < size[bj]; ++c) {
            const double val = b[std::size_t(r * size[bj] + c)] * sigma2;
            cov.at<double>(start[bi] + r, start[bj] + c) = val;
            cov.at<double>(start[bj] + c, start[bi] + r) = val;
          }
        }
      }
    }
    if (options.fix_aspect_ratio) {  // fy = aspect * fx moves with fx
      for (int c = 0; c < 2; ++c) {
        const int fx = 12 * c, fy = fx + 1;
        for (int k = 0; k < kRigParameters; ++k) {
          cov.at<double>(fy, k) = cov.at<double>(k, fy) = aspect[c] * cov.at<double>(fx, k);
        }
        cov.at<double>(fy, fy) = aspect[c] * aspect[c] * cov.at<double>(fx, fx);
      }
    }
  }
  return cov;
}

}  // namespace

double RefineStereoBundle(const std::vector<std::vector<cv::Point2f>>& left_px,
                          const std::vector<std::vector<cv::Point2f>>& right_px,
                          const std::vector<std::vector<cv::Point3f>>& object, const CalibrationOptions& options,
                          StereoRig* rig) {
  cv::Vec<double, kRigParameters> theta = RigParameters(*rig);
  double* intr[2] = {&theta[0], &theta[12]};
  double* dist[2] = {&theta[4], &theta[16]};
  double* rig_r = &theta[24];
  double* rig_t = &theta[27];
  const double aspect[2] = {options.fix_aspect_ratio ? theta[1] / theta[0] : 0.0,
                            options.fix_aspect_ratio ? theta[13] / theta[12] : 0.0};

  // Board poses in the left camera, from the left intrinsics: the starting point.
  const std::size_t views = left_px.size();
  std::vector<std::array<double, 6>> poses(views);
  for (std::size_t v = 0; v < views; ++v) {
    cv::Mat rvec, tvec;
    cv::solvePnP(object[v], left_px[v], rig->K1, rig->D1, rvec, tvec, false, cv::SOLVEPNP_ITERATIVE);
    for (int i = 0; i < 3; ++i) {
      poses[v][std::size_t(i)] = rvec.at<double>(i);
      poses[v][std::size_t(3 + i)] = tvec.at<double>(i);
    }
  }

  ceres::Problem problem;
  for (std::size_t v = 0; v < views; ++v) {
    for (std::size_t k = 0; k < object[v].size(); ++k) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<LeftCorner, 2, 4, 8, 3, 3>(new LeftCorner(object[v][k], left_px[v][k], aspect[0])),
          nullptr, intr[0], dist[0], poses[v].data(), poses[v].data() + 3);
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RightCorner, 2, 4, 8, 3, 3, 3, 3>(
                                   new RightCorner(object[v][k], right_px[v][k], aspect[1])),
                               nullptr, intr[1], dist[1], poses[v].data(), poses[v].data() + 3, rig_r, rig_t);
    }
  }
  // What the options hold fixed, as OpenCV's flags would.
  std::vector<int> fixed_dist;
  switch (options.model) {
    case DistortionModel::kK1K2P1P2: fixed_dist = {4, 5, 6, 7}; break;
    case DistortionModel::kK1K2P1P2K3: fixed_dist = {5, 6, 7}; break;
    case DistortionModel::kRational: break;
  }
  std::vector<int> fixed_intr;
  if (options.fix_aspect_ratio) fixed_intr.push_back(1);
  if (options.fix_principal_point) fixed_intr.insert(fixed_intr.end(), {2, 3});
  for (int c = 0; c < 2; ++c) {
    if (!options.refine_intrinsics) {
      problem.SetParameterBlockConstant(intr[c]);
      problem.SetParameterBlockConstant(dist[c]);
      continue;
    }
    if (!fixed_dist.empty()) problem.SetManifold(dist[c], new ceres::SubsetManifold(8, fixed_dist));
    if (!fixed_intr.empty()) problem.SetManifold(intr[c], new ceres::SubsetManifold(4, fixed_intr));
  }

  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = 100;
  so.function_tolerance = 1e-15;
  so.parameter_tolerance = 1e-15;
  so.gradient_tolerance = 1e-15;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("calibration: the joint refinement failed (" + summary.message + ")");
  if (options.fix_aspect_ratio) {
    theta[1] = aspect[0] * theta[0];
    theta[13] = aspect[1] * theta[12];
  }

  // Residual variance per coordinate: the corners' noise, as the data shows it.
  const double dof = std::max(1, summary.num_residuals_reduced - summary.num_effective_parameters_reduced);
  const double sigma2 = 2.0 * summary.final_cost / dof;

  const cv::Mat cov = ParameterCovariance(&problem, intr, dist, rig_r, rig_t, aspect, sigma2, options);
  const StereoRig refined = RigWithParameters(*rig, theta);
  rig->K1 = refined.K1;
  rig->D1 = refined.D1;
  rig->K2 = refined.K2;
  rig->D2 = refined.D2;
  rig->R = refined.R;
  rig->T = refined.T;
  rig->covariance = cov;
  return std::sqrt(sigma2);
}

}  // namespace hedgefit::stereo
