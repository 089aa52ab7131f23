// The Cholesky sweep of cholesky_sweep.hpp compiled for AVX2 + FMA (cholesky_avx2.cpp), chosen at
// run time by cholesky_in_place (cholesky.cpp) on CPUs that have them. A portable build (the
// default, docs/spec.md §10: wheels run on any x86-64 CPU) then still factorises the ~1 300-cell
// free blocks of 64x64 noisy frames with 8-wide fused multiply-adds. No Eigen type crosses
// this interface: the other unit's Eigen lives in another namespace.
#pragma once
#include <cstddef>

namespace psmat::iecm {

// Whether this build has the AVX2 unit (x86-64 with GCC or Clang, PSMAT_NATIVE off).
bool cholesky_avx2_built();
// Whether the running CPU (and OS) supports AVX2 and FMA.
bool cpu_has_avx2_fma();
// cholesky_in_place on the m x m column-major matrix at a (leading dimension ld). Only where
// cholesky_avx2_built() and cpu_has_avx2_fma().
bool cholesky_in_place_avx2(float* a, std::ptrdiff_t m, std::ptrdiff_t ld);
// cholesky_partial_in_place (cholesky.hpp) on the m x m matrix at a. Same condition.
bool cholesky_partial_in_place_avx2(float* a, std::ptrdiff_t m, std::ptrdiff_t ld,
                                    std::ptrdiff_t cols);
// lower_solve_matrix, cholesky_solve_matrix and gemm_subtract (cholesky.hpp) on column-major
// arrays (leading dimensions ld*). Same condition.
void lower_solve_matrix_avx2(const float* l, std::ptrdiff_t m, std::ptrdiff_t ld, float* b,
                             std::ptrdiff_t k, std::ptrdiff_t ldb, int mode);
void gemm_subtract_avx2(float* c, std::ptrdiff_t rows, std::ptrdiff_t cols, std::ptrdiff_t ldc,
                        const float* a, std::ptrdiff_t inner, std::ptrdiff_t lda, const float* b,
                        std::ptrdiff_t ldb);
// cholesky_solve_in_place (cholesky.hpp) with the factor at l (m x m, leading dimension ld), x of
// length m. Same condition.
void cholesky_solve_in_place_avx2(const float* l, std::ptrdiff_t m, std::ptrdiff_t ld, float* x);

}  // namespace psmat::iecm
