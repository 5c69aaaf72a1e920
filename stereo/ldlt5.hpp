#pragma once
/// The refinement's 5 x 5 normal equations, H x = b, solved as L D L^T without pivoting.
///
/// H is a sum of outer products J J^T, so symmetric and positive semi-definite, and the
/// factorisation of such a matrix is backward stable without pivoting (Higham, "Accuracy and
/// Stability of Numerical Algorithms", 2nd ed., 10.1). It is written out for the one size the
/// refinement solves at every pixel and step: Eigen's LDLT, with its pivot search and blocks of
/// run-time size, cost as much per pixel as the window's SIMD sums (a profile of the paper's pair:
/// 3.6 % of the frame's samples against 5.9 % for the sums).

#include <cmath>

namespace hedgefit::stereo {

class Ldlt5 {
 public:
  /// Factors H from its upper triangle, row by row: (0,0) (0,1) ... (0,4) (1,1) ... (4,4). False
  /// unless every pivot is positive and finite (H positive definite), where Eigen's
  /// LDLT::isPositive also accepts a pivot of exactly 0 and solves as if that row were absent.
  bool Factor(const double upper[15]) {
    double h[5][5];
    for (int a = 0, m = 0; a < 5; ++a) {
      for (int c = a; c < 5; ++c, ++m) h[a][c] = h[c][a] = upper[m];
    }
    for (int j = 0; j < 5; ++j) {
      double dj = h[j][j];
      for (int k = 0; k < j; ++k) dj -= l_[j][k] * l_[j][k] * d_[k];
      if (!(dj > 0) || !std::isfinite(dj)) return false;
      d_[j] = dj;
      for (int i = j + 1; i < 5; ++i) {
        double v = h[i][j];
        for (int k = 0; k < j; ++k) v -= l_[i][k] * l_[j][k] * d_[k];
        l_[i][j] = v / dj;
      }
    }
    return true;
  }

  /// x = H^-1 b (after a Factor that returned true).
  void Solve(const double b[5], double x[5]) const {
    double y[5];
    for (int i = 0; i < 5; ++i) {
      double v = b[i];
      for (int k = 0; k < i; ++k) v -= l_[i][k] * y[k];
      y[i] = v;
    }
    for (int i = 4; i >= 0; --i) {
      double v = y[i] / d_[i];
      for (int k = i + 1; k < 5; ++k) v -= l_[k][i] * x[k];
      x[i] = v;
    }
  }

  /// (H^-1)_00: the first parameter's variance per unit residual variance.
  double InverseFirst() const {
    const double e0[5] = {1, 0, 0, 0, 0};
    double x[5];
    Solve(e0, x);
    return x[0];
  }

 private:
  double l_[5][5] = {};  // the unit lower triangle, below the diagonal
  double d_[5] = {};
};

}  // namespace hedgefit::stereo
