// The AVX2 + FMA unit of simd.hpp; this file alone is compiled with -mavx2 -mfma
// (src/cpp/CMakeLists.txt).
#define Eigen psmat_eigen_avx2
#define PSMAT_SIMD_TIER avx2
#include "psmat/iecm/simd_unit.inc"
