// The AVX-512 unit of simd.hpp; this file alone is compiled with -mavx512f -mavx512vl -mavx512dq
// -mavx512bw -mavx2 -mfma (src/cpp/CMakeLists.txt).
#define Eigen psmat_eigen_avx512
#define PSMAT_SIMD_TIER avx512
#include "psmat/iecm/simd_unit.inc"
