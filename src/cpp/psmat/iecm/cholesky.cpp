#include "psmat/iecm/cholesky.hpp"

#include <Eigen/Jacobi>
#include <algorithm>
#include <cmath>

#include "psmat/iecm/cholesky_avx2.hpp"
#include "psmat/iecm/cholesky_sweep.hpp"

namespace psmat::iecm {

#if defined(PSMAT_AVX2_KERNELS) && (defined(__GNUC__) || defined(__clang__))
bool cholesky_avx2_built() { return true; }
bool cpu_has_avx2_fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#else
bool cholesky_avx2_built() { return false; }
bool cpu_has_avx2_fma() { return false; }
bool cholesky_in_place_avx2(float*, std::ptrdiff_t, std::ptrdiff_t) { return false; }
bool cholesky_partial_in_place_avx2(float*, std::ptrdiff_t, std::ptrdiff_t, std::ptrdiff_t) {
  return false;
}
void lower_solve_matrix_avx2(const float*, std::ptrdiff_t, std::ptrdiff_t, float*, std::ptrdiff_t,
                             std::ptrdiff_t, int) {}
void gemm_subtract_avx2(float*, std::ptrdiff_t, std::ptrdiff_t, std::ptrdiff_t, const float*,
                        std::ptrdiff_t, std::ptrdiff_t, const float*, std::ptrdiff_t) {}
void cholesky_solve_in_place_avx2(const float*, std::ptrdiff_t, std::ptrdiff_t, float*) {}
#endif

bool cholesky_in_place_portable(Eigen::Ref<Eigen::MatrixXf> A) { return cholesky_sweep(A); }

// The sweep of cholesky_sweep.hpp, with AVX2 + FMA where the CPU has them. Measured (one core of
// the 2-core machine): a free block of 1 250 cells 22.5 ms with SSE2 (the portable baseline);
// the 64x64 noisy bench stream (4.7 factorisations a frame) 9.7-10.1 frames/s before, 19.3 after,
// the same iterations, factorisations and residuals.
bool cholesky_in_place(Eigen::Ref<Eigen::MatrixXf> A) {
  if (cholesky_avx2_built() && cpu_has_avx2_fma())
    return cholesky_in_place_avx2(A.data(), A.rows(), A.outerStride());
  return cholesky_sweep(A);
}

bool cholesky_partial_in_place_portable(Eigen::Ref<Eigen::MatrixXf> A, Eigen::Index cols) {
  return cholesky_sweep_partial(A, cols);
}

bool cholesky_partial_in_place(Eigen::Ref<Eigen::MatrixXf> A, Eigen::Index cols) {
  if (cholesky_avx2_built() && cpu_has_avx2_fma())
    return cholesky_partial_in_place_avx2(A.data(), A.rows(), A.outerStride(), cols);
  return cholesky_sweep_partial(A, cols);
}

void lower_solve_matrix(const Eigen::Ref<const Eigen::MatrixXf>& L, Eigen::Ref<Eigen::MatrixXf> B,
                        int mode) {
  if (cholesky_avx2_built() && cpu_has_avx2_fma())
    lower_solve_matrix_avx2(L.data(), L.rows(), L.outerStride(), B.data(), B.cols(),
                            B.outerStride(), mode);
  else
    lower_solve_matrix_sweep(L.data(), L.rows(), L.outerStride(), B.data(), B.cols(),
                             B.outerStride(), mode);
}

void gemm_subtract(Eigen::Ref<Eigen::MatrixXf> C, const Eigen::Ref<const Eigen::MatrixXf>& A,
                   const Eigen::Ref<const Eigen::MatrixXf>& B) {
  if (cholesky_avx2_built() && cpu_has_avx2_fma())
    gemm_subtract_avx2(C.data(), C.rows(), C.cols(), C.outerStride(), A.data(), A.cols(),
                       A.outerStride(), B.data(), B.outerStride());
  else
    gemm_subtract_sweep(C.data(), C.rows(), C.cols(), C.outerStride(), A.data(), A.cols(),
                        A.outerStride(), B.data(), B.outerStride());
}

void cholesky_solve_in_place_portable(const Eigen::Ref<const Eigen::MatrixXf>& L,
                                      Eigen::Ref<Eigen::VectorXf> x) {
  cholesky_solve_sweep(L.data(), L.rows(), L.outerStride(), x.data());
}

void cholesky_solve_in_place(const Eigen::Ref<const Eigen::MatrixXf>& L, Eigen::Ref<Eigen::VectorXf> x) {
  if (cholesky_avx2_built() && cpu_has_avx2_fma())
    cholesky_solve_in_place_avx2(L.data(), L.rows(), L.outerStride(), x.data());
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
