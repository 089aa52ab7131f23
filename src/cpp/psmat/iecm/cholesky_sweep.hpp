// The blocked Cholesky sweeps behind cholesky_in_place (cholesky.hpp), in a header of their own
// so that several translation units compile them: cholesky.cpp for the baseline instruction set
// of the build, the vector units of simd.hpp (AVX2 + FMA, AVX-512) under renamed Eigen namespaces
// (chosen at run time). Internal linkage: each unit keeps its own copy.
//
// The free blocks of the active-set method have ~100-300 rows at 16x16 and 32x32, where Eigen's
// LLT (blocks of 16, right-looking) is slow; a left-looking (Crout) sweep of 16 columns at a
// time (one GEMM with the factored columns, the unblocked kernel, one triangular solve) is
// faster there, the right-looking sweep of 32 columns at ~1 300 rows (64x64). Measured (float,
// one core, microseconds; Eigen LLT / left-looking 16 / right-looking 32): m = 100 21.5 / 14.0 /
// 20.5; 130 33.6 / 22.5 / 32.1; 160 42.3 / 26.7 / 35.5; 300 209 / 157 / 174; 1 300 7 827 /
// 9 275 / 6 850. Since then: the triangular solve of each block's panel folded into the unblocked
// kernel's column pass (diagonal_block on the tall panel), and blocks of 8 in the left-looking
// sweep; the noisy bench streams (one core, per frame) 16x16 268 -> 262 us (blocks of 8 instead
// of 16), 32x32 2.62 -> 2.50 ms (the panel pass in the right-looking sweep), 64x64 unchanged.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace psmat::iecm {
namespace {

// Unblocked (column by column) Cholesky of a diagonal block of the sweeps below: the kernel that
// Eigen's LLT runs on its diagonal blocks, written with the public API. A may be a tall panel
// (rows >= cols): its top square is the diagonal block, and the rows below come out as the
// panel's part of L (the triangular solve against the diagonal block's factor, done column by
// column with the same matrix-vector products).
inline bool diagonal_block(Eigen::Ref<Eigen::MatrixXf> A) {
  const Eigen::Index b = A.cols(), rows = A.rows();
  for (Eigen::Index k = 0; k < b; ++k) {
    const Eigen::Index rest = rows - k - 1;
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
    constexpr Eigen::Index bs = 8;
    for (Eigen::Index k = 0; k < m; k += bs) {
      const Eigen::Index b = std::min(bs, m - k), rest = m - k - b;
      if (k > 0)  // A[k:, k:k+b] -= L[k:, :k] L[k:k+b, :k]^T
        A.block(k, k, m - k, b).noalias() -=
            A.block(k, 0, m - k, k) * A.block(k, 0, b, k).transpose();
      // the diagonal block and the panel below it in one column-by-column pass: Eigen's
      // triangular solve on the right costs more than the arithmetic on panels this narrow
      if (!diagonal_block(A.block(k, k, b + rest, b))) return false;
    }
    return true;
  }
  constexpr Eigen::Index bs = 32;
  for (Eigen::Index k = 0; k < m; k += bs) {
    const Eigen::Index b = std::min(bs, m - k), rest = m - k - b;
    if (!diagonal_block(A.block(k, k, b + rest, b))) return false;  // block and panel, as above
    if (rest > 0)
      A.block(k + b, k + b, rest, rest).selfadjointView<Eigen::Lower>().rankUpdate(
          A.block(k + b, k, rest, b), -1.0f);
  }
  return true;
}

// The first `cols` columns of the right-looking sweep: L's first `cols` columns out (the leading
// block's factor and the panel below it), and in the trailing block A[cols:, cols:] (lower
// triangle) the Schur complement A22 - L21 L21^T of the leading block (FreeBlockSolver's split
// factor, free_block_solver.hpp). False where the leading block is not numerically SPD.
inline bool cholesky_sweep_partial(Eigen::Ref<Eigen::MatrixXf> A, Eigen::Index cols) {
  const Eigen::Index m = A.rows();
  constexpr Eigen::Index bs = 32;
  for (Eigen::Index k = 0; k < cols; k += bs) {
    const Eigen::Index b = std::min(bs, cols - k), rest = m - k - b;
    if (!diagonal_block(A.block(k, k, b + rest, b))) return false;
    if (rest > 0)
      A.block(k + b, k + b, rest, rest).selfadjointView<Eigen::Lower>().rankUpdate(
          A.block(k + b, k, rest, b), -1.0f);
  }
  return true;
}

// B <- L^-1 B (mode 0), (L L^T)^-1 B (mode 1) or L^-T B (mode 2) with the lower factor L (m x m,
// leading dimension ld), B m x k (leading dimension ldb): FreeBlockSolver's split factor.
inline void lower_solve_matrix_sweep(const float* l, Eigen::Index m, Eigen::Index ld, float* b,
                                     Eigen::Index k, Eigen::Index ldb, int mode) {
  const Eigen::Map<const Eigen::MatrixXf, 0, Eigen::OuterStride<>> L(l, m, m, Eigen::OuterStride<>(ld));
  if (k == 1) {
    Eigen::Map<Eigen::VectorXf> v(b, m);
    if (mode != 2) L.triangularView<Eigen::Lower>().solveInPlace(v);
    if (mode != 0) L.triangularView<Eigen::Lower>().transpose().solveInPlace(v);
    return;
  }
  Eigen::Map<Eigen::MatrixXf, 0, Eigen::OuterStride<>> B(b, m, k, Eigen::OuterStride<>(ldb));
  if (mode != 2) L.triangularView<Eigen::Lower>().solveInPlace(B);
  if (mode != 0) L.triangularView<Eigen::Lower>().transpose().solveInPlace(B);
}

// C -= A B (C rows x cols, A rows x inner, B inner x cols; column-major, leading dimensions).
inline void gemm_subtract_sweep(float* c, Eigen::Index rows, Eigen::Index cols, Eigen::Index ldc,
                                const float* a, Eigen::Index inner, Eigen::Index lda,
                                const float* b, Eigen::Index ldb) {
  Eigen::Map<Eigen::MatrixXf, 0, Eigen::OuterStride<>> C(c, rows, cols, Eigen::OuterStride<>(ldc));
  const Eigen::Map<const Eigen::MatrixXf, 0, Eigen::OuterStride<>> A(a, rows, inner, Eigen::OuterStride<>(lda));
  const Eigen::Map<const Eigen::MatrixXf, 0, Eigen::OuterStride<>> B(b, inner, cols, Eigen::OuterStride<>(ldb));
  C.noalias() -= A * B;
}

// y -= A x (transpose false: A rows x cols, x of length cols, y of length rows) or y -= A^T x
// (true: x of length rows, y of length cols); A column-major, leading dimension lda.
inline void gemv_subtract_sweep(float* y, const float* a, Eigen::Index rows, Eigen::Index cols,
                                Eigen::Index lda, const float* x, bool transpose) {
  const Eigen::Map<const Eigen::MatrixXf, 0, Eigen::OuterStride<>> A(a, rows, cols, Eigen::OuterStride<>(lda));
  if (transpose)
    Eigen::Map<Eigen::VectorXf>(y, cols).noalias() -= A.transpose() * Eigen::Map<const Eigen::VectorXf>(x, rows);
  else
    Eigen::Map<Eigen::VectorXf>(y, rows).noalias() -= A * Eigen::Map<const Eigen::VectorXf>(x, cols);
}

// x <- (L L^T)^-1 x with the lower factor L (m x m, column-major, leading dimension ld): the
// two triangular solves of a preconditioner application.
inline void cholesky_solve_sweep(const float* l, Eigen::Index m, Eigen::Index ld, float* x) {
  const Eigen::Map<const Eigen::MatrixXf, 0, Eigen::OuterStride<>> L(l, m, m, Eigen::OuterStride<>(ld));
  Eigen::Map<Eigen::VectorXf> v(x, m);
  L.triangularView<Eigen::Lower>().solveInPlace(v);
  L.triangularView<Eigen::Lower>().transpose().solveInPlace(v);
}

}  // namespace
}  // namespace psmat::iecm
