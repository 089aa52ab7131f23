#include "psmat/iecm/cholesky.hpp"

#include <algorithm>

namespace psmat::iecm {

namespace {
// Eigen's unblocked kernel on a diagonal block (returns -1 on success)
bool diagonal_block(Eigen::Ref<Eigen::MatrixXf> A11) {
  return Eigen::internal::llt_inplace<float, Eigen::Lower>::unblocked(A11) < 0;
}
}  // namespace

// The free blocks of the active-set method have ~100-300 rows at 16x16 and 32x32, where Eigen's
// LLT (blocks of 16, right-looking) is slow; a left-looking (Crout) sweep of 16 columns at a
// time (one GEMM with the factored columns, the unblocked kernel, one triangular solve) is
// faster there, the right-looking sweep of 32 columns at ~1 300 rows (64x64). Measured (float,
// one core, microseconds; Eigen LLT / left-looking 16 / right-looking 32): m = 100 21.5 / 14.0 /
// 20.5; 130 33.6 / 22.5 / 32.1; 160 42.3 / 26.7 / 35.5; 300 209 / 157 / 174; 1 300 7 827 /
// 9 275 / 6 850.
bool cholesky_in_place(Eigen::Ref<Eigen::MatrixXf> A) {
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

}  // namespace psmat::iecm
