// The choice of the kernels' tier (simd.hpp), once, on first use.
#include "psmat/iecm/simd.hpp"

#include <cstdlib>
#include <cstring>

namespace psmat::iecm {

namespace {

bool cpu_runs_avx2() {
#if defined(PSMAT_SIMD_AVX2)
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

bool cpu_runs_avx512() {
#if defined(PSMAT_SIMD_AVX512)
  // libgcc's and compiler-rt's checks include the OS's support of the AVX-512 register state
  return cpu_runs_avx2() && __builtin_cpu_supports("avx512f") &&
         __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq") &&
         __builtin_cpu_supports("avx512bw");
#else
  return false;
#endif
}

// PSMAT_SIMD: "baseline" -> 0, "avx2" -> 1, anything else (or unset) -> no cap.
int cap_from_environment() {
  const char* v = std::getenv("PSMAT_SIMD");
  if (v == nullptr) return 2;
  if (std::strcmp(v, "baseline") == 0) return 0;
  if (std::strcmp(v, "avx2") == 0) return 1;
  return 2;
}

const SimdKernels* choose() {
  const int cap = cap_from_environment();
#if defined(PSMAT_SIMD_AVX512)
  if (cap >= 2 && cpu_runs_avx512()) return &simd_table_avx512();
#endif
#if defined(PSMAT_SIMD_AVX2)
  if (cap >= 1 && cpu_runs_avx2()) return &simd_table_avx2();
#endif
  (void)cap;
  return nullptr;
}

}  // namespace

const SimdKernels* simd_kernels() {
  static const SimdKernels* const chosen = choose();
  return chosen;
}

const char* simd_kernels_name() {
  const SimdKernels* k = simd_kernels();
#if defined(PSMAT_NATIVE_BUILD)
  return k != nullptr ? k->name : "native";
#else
  return k != nullptr ? k->name : "baseline";
#endif
}

std::vector<const SimdKernels*> simd_kernels_available() {
  std::vector<const SimdKernels*> out;
#if defined(PSMAT_SIMD_AVX2)
  if (cpu_runs_avx2()) out.push_back(&simd_table_avx2());
#endif
#if defined(PSMAT_SIMD_AVX512)
  if (cpu_runs_avx512()) out.push_back(&simd_table_avx512());
#endif
  return out;
}

}  // namespace psmat::iecm
