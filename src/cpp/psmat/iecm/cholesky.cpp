#include "psmat/iecm/cholesky.hpp"

#include <Eigen/Jacobi>
#include <algorithm>
#include <cmath>

#include "psmat/iecm/cholesky_sweep.hpp"
#include "psmat/iecm/simd.hpp"

namespace psmat::iecm {


bool cholesky_in_place_portable(Eigen::Ref<Eigen::MatrixXf> A) { return cholesky_sweep(A); }

// The sweep of cholesky_sweep.hpp, in the widest vector unit the CPU runs (simd.hpp). Measured
// (one core of the 2-core machine): a free block of 1 250 cells 22.5 ms with SSE2 (the portable
// baseline); the 64x64 noisy bench stream (4.7 factorisations a frame) 9.7-10.1 frames/s before,
// 19.3 with AVX2 + FMA, the same iterations, factorisations and residuals. The AVX-512 unit on
// this machine's AMD EPYC (C++ driver, the noisy bench streams, one core, back to back): 64x64
// 30.6-31.8 -> 24.0-24.2 ms a frame, 32x32 2.13 -> 1.83 ms, as fast as a -march=native build
// (24.6 / 1.84), the same iterations and factorisations.
bool cholesky_in_place(Eigen::Ref<Eigen::MatrixXf> A) {
  if (const SimdKernels* k = simd_kernels())
    return k->cholesky_in_place(A.data(), A.rows(), A.outerStride());
  return cholesky_sweep(A);
}

bool cholesky_partial_in_place_portable(Eigen::Ref<Eigen::MatrixXf> A, Eigen::Index cols) {
  return cholesky_sweep_partial(A, cols);
}

bool cholesky_partial_in_place(Eigen::Ref<Eigen::MatrixXf> A, Eigen::Index cols) {
  if (const SimdKernels* k = simd_kernels())
    return k->cholesky_partial_in_place(A.data(), A.rows(), A.outerStride(), cols);
  return cholesky_sweep_partial(A, cols);
}

void lower_solve_matrix(const Eigen::Ref<const Eigen::MatrixXf>& L, Eigen::Ref<Eigen::MatrixXf> B,
                        int mode) {
  if (const SimdKernels* k = simd_kernels())
    k->lower_solve_matrix(L.data(), L.rows(), L.outerStride(), B.data(), B.cols(),
                          B.outerStride(), mode);
  else
    lower_solve_matrix_sweep(L.data(), L.rows(), L.outerStride(), B.data(), B.cols(),
                             B.outerStride(), mode);
}

void gemm_subtract(Eigen::Ref<Eigen::MatrixXf> C, const Eigen::Ref<const Eigen::MatrixXf>& A,
                   const Eigen::Ref<const Eigen::MatrixXf>& B) {
  if (const SimdKernels* k = simd_kernels())
    k->gemm_subtract(C.data(), C.rows(), C.cols(), C.outerStride(), A.data(), A.cols(),
                     A.outerStride(), B.data(), B.outerStride());
  else
    gemm_subtract_sweep(C.data(), C.rows(), C.cols(), C.outerStride(), A.data(), A.cols(),
                        A.outerStride(), B.data(), B.outerStride());
}

void gemv_subtract_portable(Eigen::Ref<Eigen::VectorXf> y, const Eigen::Ref<const Eigen::MatrixXf>& A,
                            const Eigen::Ref<const Eigen::VectorXf>& x, bool transpose) {
  gemv_subtract_sweep(y.data(), A.data(), A.rows(), A.cols(), A.outerStride(), x.data(), transpose);
}

void gemv_subtract(Eigen::Ref<Eigen::VectorXf> y, const Eigen::Ref<const Eigen::MatrixXf>& A,
                   const Eigen::Ref<const Eigen::VectorXf>& x, bool transpose) {
  if (const SimdKernels* k = simd_kernels())
    k->gemv_subtract(y.data(), A.data(), A.rows(), A.cols(), A.outerStride(), x.data(), transpose);
  else
    gemv_subtract_sweep(y.data(), A.data(), A.rows(), A.cols(), A.outerStride(), x.data(), transpose);
}

void cholesky_solve_in_place_portable(const Eigen::Ref<const Eigen::MatrixXf>& L,
                                      Eigen::Ref<Eigen::VectorXf> x) {
  cholesky_solve_sweep(L.data(), L.rows(), L.outerStride(), x.data());
}

void cholesky_solve_in_place(const Eigen::Ref<const Eigen::MatrixXf>& L, Eigen::Ref<Eigen::VectorXf> x) {
  if (const SimdKernels* k = simd_kernels())
    k->cholesky_solve_in_place(L.data(), L.rows(), L.outerStride(), x.data());
  else
    cholesky_solve_sweep(L.data(), L.rows(), L.outerStride(), x.data());
}

// One plane rotation per column j zeroes w[j] against L[j, j] (Eigen's Givens rotation, public
// API; the pivots stay positive):
//   (L[j:, j], w[j:]) <- (c L[j:, j] + s w[j:], -s L[j:, j] + c w[j:]).
// The arithmetic of Eigen's LLT::rankUpdate, so the factors (and the active-set paths measured
// with them) are unchanged: with the rounding of the textbook form c = L_jj / r, s = w_j / r, a
// noisy 32x32 bench frame took another path (107 iterations instead of 18).
void cholesky_rank1_update(Eigen::Ref<Eigen::MatrixXf> L, Eigen::Ref<Eigen::VectorXf> w) {
  const Eigen::Index n = L.rows();
  Eigen::JacobiRotation<float> rot;
  for (Eigen::Index j = 0; j < n; ++j) {
    rot.makeGivens(L(j, j), -w[j], &L(j, j));
    const float c = rot.c(), s = rot.s();
    const Eigen::Index rest = n - j - 1;
    float* x = L.col(j).data() + j + 1;  // a column of a column-major L: contiguous
    float* y = w.data() + j + 1;
    for (Eigen::Index i = 0; i < rest; ++i) {
      const float xi = x[i], yi = y[i];
      x[i] = c * xi + s * yi;
      y[i] = -s * xi + c * yi;
    }
  }
}

}  // namespace psmat::iecm
