// The matrix-free product (T∘T) v of jacobian.hpp (docs/spec.md §3; thesis eq. 2.13) as plain
// loops on raw arrays, in a header of its own so that several translation units compile it:
// jacobian.cpp for the baseline instruction set of the build, the vector units of simd.hpp (AVX2
// + FMA, AVX-512; chosen at run time). Internal linkage: each unit keeps its own copy. No Eigen:
// nothing of it crosses the boundary between the units.
//
//   ((T∘T) v)[i,p] = K[i,i] + K[p',p'] - 2 K[i,p'],   K = M L_v M,   p' = R + p,
// with L_v the Laplacian of the cell graph weighted by v and M the padded inverse of the grounded
// Laplacian (laplacian.hpp; symmetric, its ground row and column zero). With P = L_v M and
// Pt = P^T (M symmetric, so the rows of P are combinations of the columns of M):
//   Pt[:, i]  = (sum_p v[i,p]) M[:, i]  - sum_p v[i,p] M[:, p']         (a row node i)
//   Pt[:, p'] = (sum_i v[i,p]) M[:, p'] - sum_i v[i,p] M[:, i]          (a column node p')
//   K[k, k]   = sum_m M[k, m] Pt[k, m]
//   K[i, p']  = sum_m Pt[p', m] M[i, m]
// Every step sums columns of M (contiguous, column-major) with scalar weights, a strip of rows at
// a time in registers; cells with v = 0 are skipped (the PCG products of the active-set method
// are zero on the bound cells: about 45 % of them on the noisy 16x16 frames).
//
// Why not Eigen's GEMMs (the earlier form, P = L_v M then K's blocks): at 16x16 (n = 32) the
// products are 16 x 16 x 32, where packing and blocking cost more than the arithmetic. Measured
// (one core of the shared 2-core machine, back to back, the 16x16 noisy bench stream with its
// ~23 products a frame): 550 / 521 us a frame with the GEMMs, 458 / 467 us with this kernel
// (AVX2 unit); the same iterations, factorisations and PCG steps.
#pragma once
#include <cstddef>

namespace psmat::iecm {
namespace {

using KIndex = std::ptrdiff_t;

// dst[0:len) = sum_k coef[k * cstride] * A[k * ld + (0:len)], terms with coef 0 skipped.
inline void sum_columns(const double* A, KIndex ld, KIndex len, const double* coef, KIndex cstride,
                        KIndex count, double* __restrict dst) {
  constexpr KIndex kStrip = 16;  // 4 AVX2 / 8 SSE2 registers of accumulators
  KIndex r = 0;
  for (; r + kStrip <= len; r += kStrip) {
    double acc[kStrip] = {};
    for (KIndex k = 0; k < count; ++k) {
      const double c = coef[k * cstride];
      if (c == 0.0) continue;
      const double* a = A + k * ld + r;
      for (KIndex j = 0; j < kStrip; ++j) acc[j] += c * a[j];
    }
    for (KIndex j = 0; j < kStrip; ++j) dst[r + j] = acc[j];
  }
  if (r == len) return;
  for (KIndex j = r; j < len; ++j) dst[j] = 0.0;
  for (KIndex k = 0; k < count; ++k) {
    const double c = coef[k * cstride];
    if (c == 0.0) continue;
    const double* a = A + k * ld;
    for (KIndex j = r; j < len; ++j) dst[j] += c * a[j];
  }
}

// out[i*C + p] = ((T∘T) v)[i,p] (row-major cells). M: n x n column-major (ld n), n = R + C;
// v: R*C, row-major; Pt: n*n and kdiag: n + R, workspace.
inline void hadamard_kernel(const double* M, KIndex R, KIndex C, const double* v, double* out,
                            double* Pt, double* kdiag) {
  const KIndex n = R + C;
  for (KIndex i = 0; i < R; ++i) {  // row node i
    double* d = Pt + i * n;
    sum_columns(M + R * n, n, n, v + i * C, 1, C, d);
    double deg = 0.0;
    for (KIndex p = 0; p < C; ++p) deg += v[i * C + p];
    const double* mi = M + i * n;
    for (KIndex k = 0; k < n; ++k) d[k] = deg * mi[k] - d[k];
  }
  for (KIndex p = 0; p < C; ++p) {  // column node p' = R + p
    double* d = Pt + (R + p) * n;
    sum_columns(M, n, n, v + p, C, R, d);
    double deg = 0.0;
    for (KIndex i = 0; i < R; ++i) deg += v[i * C + p];
    const double* mp = M + (R + p) * n;
    for (KIndex k = 0; k < n; ++k) d[k] = deg * mp[k] - d[k];
  }
  for (KIndex k = 0; k < n; ++k) kdiag[k] = 0.0;
  for (KIndex m = 0; m < n; ++m) {
    const double* a = M + m * n;
    const double* b = Pt + m * n;
    for (KIndex k = 0; k < n; ++k) kdiag[k] += a[k] * b[k];
  }
  // K[0:R, p'] (a column of R entries) into out's column p, then the diagonal terms
  double* krc = kdiag + n;  // R more entries of workspace after kdiag
  for (KIndex p = 0; p < C; ++p) {
    sum_columns(M, n, R, Pt + (R + p), n, n, krc);
    for (KIndex i = 0; i < R; ++i) out[i * C + p] = kdiag[i] + kdiag[R + p] - 2.0 * krc[i];
  }
}

}  // namespace
}  // namespace psmat::iecm
