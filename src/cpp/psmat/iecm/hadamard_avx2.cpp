// AVX2 + FMA build of the matrix-free product (hadamard_avx2.hpp). This unit alone, with
// cholesky_avx2.cpp, is compiled with -mavx2 -mfma (src/cpp/CMakeLists.txt); it uses no Eigen.
#include "psmat/iecm/hadamard_avx2.hpp"

#include "psmat/iecm/hadamard_kernel.hpp"

namespace psmat::iecm {

void hadamard_kernel_avx2(const double* M, std::ptrdiff_t R, std::ptrdiff_t C, const double* v,
                          double* out, double* Pt, double* kdiag) {
  hadamard_kernel(M, R, C, v, out, Pt, kdiag);
}

}  // namespace psmat::iecm
