// The matrix-free product (T∘T) v of hadamard_kernel.hpp compiled for AVX2 + FMA
// (hadamard_avx2.cpp), chosen at run time by hadamard_product (jacobian.cpp) on CPUs that have
// them (cpu_has_avx2_fma, cholesky_avx2.hpp), as the Cholesky sweep of the preconditioners is.
// Raw arrays only: no Eigen type crosses this interface.
#pragma once
#include <cstddef>

namespace psmat::iecm {

// hadamard_kernel (hadamard_kernel.hpp) of the AVX2 unit. Only where cholesky_avx2_built() and
// cpu_has_avx2_fma() (the two units are built together).
void hadamard_kernel_avx2(const double* M, std::ptrdiff_t R, std::ptrdiff_t C, const double* v,
                          double* out, double* Pt, double* kdiag);

}  // namespace psmat::iecm
