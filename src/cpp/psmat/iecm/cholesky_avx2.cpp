// AVX2 + FMA build of the Cholesky sweep (cholesky_avx2.hpp). This unit alone is compiled with
// -mavx2 -mfma (src/cpp/CMakeLists.txt); its Eigen is renamed so that none of its template
// instances share a symbol with those of the baseline units (the linker would otherwise keep
// one copy of each, of either instruction set).
#define Eigen psmat_eigen_avx2
#include "psmat/iecm/cholesky_sweep.hpp"
#include "psmat/iecm/cholesky_avx2.hpp"

namespace psmat::iecm {

bool cholesky_in_place_avx2(float* a, std::ptrdiff_t m, std::ptrdiff_t ld) {
  Eigen::Map<Eigen::MatrixXf, 0, Eigen::OuterStride<>> A(a, m, m, Eigen::OuterStride<>(ld));
  return cholesky_sweep(A);
}

bool cholesky_partial_in_place_avx2(float* a, std::ptrdiff_t m, std::ptrdiff_t ld,
                                    std::ptrdiff_t cols) {
  Eigen::Map<Eigen::MatrixXf, 0, Eigen::OuterStride<>> A(a, m, m, Eigen::OuterStride<>(ld));
  return cholesky_sweep_partial(A, cols);
}

void lower_solve_matrix_avx2(const float* l, std::ptrdiff_t m, std::ptrdiff_t ld, float* b,
                             std::ptrdiff_t k, std::ptrdiff_t ldb, int mode) {
  lower_solve_matrix_sweep(l, m, ld, b, k, ldb, mode);
}

void gemm_subtract_avx2(float* c, std::ptrdiff_t rows, std::ptrdiff_t cols, std::ptrdiff_t ldc,
                        const float* a, std::ptrdiff_t inner, std::ptrdiff_t lda, const float* b,
                        std::ptrdiff_t ldb) {
  gemm_subtract_sweep(c, rows, cols, ldc, a, inner, lda, b, ldb);
}

void cholesky_solve_in_place_avx2(const float* l, std::ptrdiff_t m, std::ptrdiff_t ld, float* x) {
  cholesky_solve_sweep(l, m, ld, x);
}

}  // namespace psmat::iecm
