// The blocked Cholesky sweeps behind cholesky_in_place (cholesky.hpp), in a header of their own
// so that two translation units compile them: cholesky.cpp for the baseline instruction set of
// the build, cholesky_avx2.cpp with AVX2 + FMA under a renamed Eigen namespace (chosen at run
// time, cholesky_avx2.hpp). Internal linkage: each unit keeps its own copy.
//
// The free blocks of the active-set method have ~100-300 rows at 16x16 and 32x32, where Eigen's
// LLT (blocks of 16, right-looking) is slow; a left-looking (Crout) sweep of 16 columns at a
// time (one GEMM with the factored columns, the unblocked kernel, one triangular solve) is
// faster there, the right-looking sweep of 32 columns at ~1 300 rows (64x64). Measured (float,
// one core, microseconds; Eigen LLT / left-looking 16 / right-looking 32): m = 100 21.5 / 14.0 /
// 20.5; 130 33.6 / 22.5 / 32.1; 160 42.3 / 26.7 / 35.5; 300 209 / 157 / 174; 1 300 7 827 /
// 9 275 / 6 850.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace psmat::iecm {
namespace {

// Unblocked (column by column) Cholesky of a diagonal block of the sweeps below: the kernel that
// Eigen's LLT runs on its diagonal blocks, written with the public API.
inline bool diagonal_block(Eigen::Ref<Eigen::MatrixXf> A) {
  const Eigen::Index b = A.rows();
  for (Eigen::Index k = 0; k < b; ++k) {
    const Eigen::Index rest = b - k - 1;
    float x = A(k, k);
    if (k > 0) x -= A.row(k).head(k).squaredNorm();
    if (!(x > 0.0f)) return false;  // not positive (or NaN): not SPD
    x = std::sqrt(x);
    A(k, k) = x;
    if (rest > 0) {
      if (k > 0)
        A.col(k).tail(rest).noalias() -= A.bottomLeftCorner(rest, k) * A.row(k).head(k).transpose();
      A.col(k).tail(rest) /= x;
    }
  }
  return true;
}

// In place: the lower triangle of A in, L out (cholesky.hpp's contract).
inline bool cholesky_sweep(Eigen::Ref<Eigen::MatrixXf> A) {
  const Eigen::Index m = A.rows();
  if (m <= 400) {
    constexpr Eigen::Index bs = 16;
    for (Eigen::Index k = 0; k < m; k += bs) {
      const Eigen::Index b = std::min(bs, m - k), rest = m - k - b;
      if (k > 0)  // A[k:, k:k+b] -= L[k:, :k] L[k:k+b, :k]^T
        A.block(k, k, m - k, b).noalias() -=
            A.block(k, 0, m - k, k) * A.block(k, 0, b, k).transpose();
      if (!diagonal_block(A.block(k, k, b, b))) return false;
      if (rest > 0)
        A.block(k, k, b, b).triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(
            A.block(k + b, k, rest, b));
    }
    return true;
  }
  constexpr Eigen::Index bs = 32;
  for (Eigen::Index k = 0; k < m; k += bs) {
    const Eigen::Index b = std::min(bs, m - k), rest = m - k - b;
    if (!diagonal_block(A.block(k, k, b, b))) return false;
    if (rest > 0) {
      auto A21 = A.block(k + b, k, rest, b);
      A.block(k, k, b, b).triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(A21);
      A.block(k + b, k + b, rest, rest).selfadjointView<Eigen::Lower>().rankUpdate(A21, -1.0f);
    }
  }
  return true;
}

}  // namespace
}  // namespace psmat::iecm
