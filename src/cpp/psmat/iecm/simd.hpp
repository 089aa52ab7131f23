// The dense kernels of the IECM preconditioners (cholesky_sweep.hpp: Cholesky sweeps, triangular
// solves, C -= A B), the matrix-free product of the Newton matrix (hadamard_kernel.hpp) and the
// block inverse of the nodal matrix (nodal_inverse_kernel.hpp),
// compiled once more per vector instruction set wider than the build's baseline, one unit each
// (simd_unit.inc: simd_avx2.cpp with AVX2 + FMA, simd_avx512.cpp with AVX-512 F/VL/DQ/BW + FMA),
// and chosen once at run time: the widest tier the build has and the CPU (and OS) supports. A
// portable build (the default, docs/spec.md §10: wheels run on any x86-64 CPU) thus still runs
// these kernels as wide as the machine allows; a native build (PSMAT_NATIVE) has no such unit,
// its baseline is the CPU's. The environment variable PSMAT_SIMD caps the tier ("avx2",
// "baseline"), read on the first use (benchmarks of the narrower code in one installation).
// No Eigen type crosses this interface: each unit's Eigen lives in a namespace of its own.
#pragma once
#include <cstddef>
#include <vector>

namespace psmat::iecm {

// One tier's kernels, on column-major arrays with leading dimensions ld*:
//   cholesky_in_place / cholesky_partial_in_place / lower_solve_matrix / gemm_subtract /
//   gemv_subtract / cholesky_solve_in_place as in cholesky.hpp, hadamard_kernel as in
//   hadamard_kernel.hpp, nodal_inverse as nodal_inverse_kernel in nodal_inverse_kernel.hpp.
struct SimdKernels {
  const char* name;  // "avx2", "avx512"
  bool (*cholesky_in_place)(float* a, std::ptrdiff_t m, std::ptrdiff_t ld);
  bool (*cholesky_partial_in_place)(float* a, std::ptrdiff_t m, std::ptrdiff_t ld,
                                    std::ptrdiff_t cols);
  void (*lower_solve_matrix)(const float* l, std::ptrdiff_t m, std::ptrdiff_t ld, float* b,
                             std::ptrdiff_t k, std::ptrdiff_t ldb, int mode);
  void (*gemm_subtract)(float* c, std::ptrdiff_t rows, std::ptrdiff_t cols, std::ptrdiff_t ldc,
                        const float* a, std::ptrdiff_t inner, std::ptrdiff_t lda, const float* b,
                        std::ptrdiff_t ldb);
  void (*gemv_subtract)(float* y, const float* a, std::ptrdiff_t rows, std::ptrdiff_t cols,
                        std::ptrdiff_t lda, const float* x, bool transpose);
  void (*cholesky_solve_in_place)(const float* l, std::ptrdiff_t m, std::ptrdiff_t ld, float* x);
  void (*hadamard_kernel)(const double* M, std::ptrdiff_t R, std::ptrdiff_t C, const double* v,
                          double* out, double* Pt, double* kdiag);
  bool (*nodal_inverse)(const double* g, std::ptrdiff_t R, std::ptrdiff_t C, double* m,
                        double* work);
};

// The tier in use, or nullptr: the build's baseline code runs (no wider unit built, the CPU has
// none of them, or PSMAT_SIMD=baseline).
const SimdKernels* simd_kernels();
// The name of the code in use: "avx512", "avx2", "baseline" (the build's own instruction set) or,
// in a native build (PSMAT_NATIVE, no vector units), "native".
const char* simd_kernels_name();
// Every tier this build has and this CPU runs, narrowest first (the C++ tests check each one
// against the baseline code).
std::vector<const SimdKernels*> simd_kernels_available();

// Doubles of workspace that SimdKernels::nodal_inverse takes for an R x C array.
std::ptrdiff_t nodal_inverse_work_size(std::ptrdiff_t R, std::ptrdiff_t C);

// The units' tables (simd_unit.inc); only where the build has the unit (PSMAT_SIMD_AVX2,
// PSMAT_SIMD_AVX512) and only to be called where the CPU supports its instructions.
const SimdKernels& simd_table_avx2();
const SimdKernels& simd_table_avx512();

}  // namespace psmat::iecm
