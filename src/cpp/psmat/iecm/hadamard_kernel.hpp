// The matrix-free product (T∘T) v of jacobian.hpp (docs/spec.md §3; thesis eq. 2.13) as plain
// loops on raw arrays, in a header of its own so that several translation units compile it:
// jacobian.cpp for the baseline instruction set of the build, the vector units of simd.hpp (AVX2
// + FMA, AVX-512; chosen at run time). Internal linkage: each unit keeps its own copy, and its
// fixed-size Eigen arrays are those of its unit's renamed Eigen; nothing crosses the boundary
// between the units.
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
#include <Eigen/Core>
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

#if defined(__AVX__)
// In the vector units: four sums over the same columns of A at once (four row nodes, or four
// column nodes), dst + q * dstride = sum_k coef[q * qstride + k * cstride] * A[k * ld + (0:len)],
// a column skipped where all four coefficients are 0. Each strip of A is loaded once for four
// destinations, and the four independent accumulator chains hide the latency of the FMAs (one
// destination of 16 doubles is only two AVX-512 registers, a chain each). A strip is two vector
// registers; Eigen's fixed-size arrays of the unit's instruction set (GCC's own vectoriser
// left the same loops scalar under -mavx2). The same sums, term by term in the same order, as
// sum_columns: the results are identical. Measured in isolation (one core, random M, v 70 %
// zeros, us per product, sum_columns alone / grouped): AVX-512 32x32 9.2 / 5.7, 64x64 98.7 / 47.4;
// AVX2 32x32 9.9 / 9.5, 64x64 103 / 77 (SSE2 was slower grouped: kept per destination there).
#if defined(__AVX512F__)
constexpr KIndex kGroupStrip = 16;
#else
constexpr KIndex kGroupStrip = 8;
#endif
inline void sum_columns4(const double* A, KIndex ld, KIndex len, const double* coef, KIndex qstride,
                         KIndex cstride, KIndex count, double* __restrict dst, KIndex dstride) {
  using Strip = Eigen::Array<double, kGroupStrip, 1>;
  using StripMap = Eigen::Map<const Strip>;
  KIndex r = 0;
  for (; r + kGroupStrip <= len; r += kGroupStrip) {
    Strip a0 = Strip::Zero(), a1 = Strip::Zero(), a2 = Strip::Zero(), a3 = Strip::Zero();
    for (KIndex k = 0; k < count; ++k) {
      const double* cf = coef + k * cstride;
      const double c0 = cf[0], c1 = cf[qstride], c2 = cf[2 * qstride], c3 = cf[3 * qstride];
      if (c0 == 0.0 && c1 == 0.0 && c2 == 0.0 && c3 == 0.0) continue;
      const StripMap x(A + k * ld + r);
      a0 += c0 * x;
      a1 += c1 * x;
      a2 += c2 * x;
      a3 += c3 * x;
    }
    Eigen::Map<Strip>(dst + r) = a0;
    Eigen::Map<Strip>(dst + dstride + r) = a1;
    Eigen::Map<Strip>(dst + 2 * dstride + r) = a2;
    Eigen::Map<Strip>(dst + 3 * dstride + r) = a3;
  }
  if (r == len) return;
  for (KIndex q = 0; q < 4; ++q) {
    double* d = dst + q * dstride;
    for (KIndex j = r; j < len; ++j) d[j] = 0.0;
    for (KIndex k = 0; k < count; ++k) {
      const double c = coef[q * qstride + k * cstride];
      if (c == 0.0) continue;
      const double* a = A + k * ld;
      for (KIndex j = r; j < len; ++j) d[j] += c * a[j];
    }
  }
}
constexpr KIndex kGroup = 4;
#else
constexpr KIndex kGroup = 1;  // the baseline: one destination at a time
#endif

// m sums dst + q * dstride (q < m) as above: in groups of four where the unit groups them, the
// rest one at a time.
inline void sum_columns_many(const double* A, KIndex ld, KIndex len, const double* coef,
                             KIndex qstride, KIndex cstride, KIndex count, KIndex m, double* dst,
                             KIndex dstride) {
  KIndex q = 0;
#if defined(__AVX__)
  for (; q + 4 <= m; q += 4)
    sum_columns4(A, ld, len, coef + q * qstride, qstride, cstride, count, dst + q * dstride,
                 dstride);
#endif
  for (; q < m; ++q) sum_columns(A, ld, len, coef + q * qstride, cstride, count, dst + q * dstride);
}

// out[i*C + p] = ((T∘T) v)[i,p] (row-major cells). M: n x n column-major (ld n), n = R + C;
// v: R*C, row-major; Pt: n*n and kdiag: n + 4 R, workspace.
inline void hadamard_kernel(const double* M, KIndex R, KIndex C, const double* v, double* out,
                            double* Pt, double* kdiag) {
  const KIndex n = R + C;
  // Pt[:, i] = deg_i M[:, i] - sum_p v[i,p] M[:, p'] (row node i)
  sum_columns_many(M + R * n, n, n, v, C, 1, C, R, Pt, n);
  for (KIndex i = 0; i < R; ++i) {
    double* d = Pt + i * n;
    double deg = 0.0;
    for (KIndex p = 0; p < C; ++p) deg += v[i * C + p];
    const double* mi = M + i * n;
    for (KIndex k = 0; k < n; ++k) d[k] = deg * mi[k] - d[k];
  }
  // Pt[:, p'] = deg_p M[:, p'] - sum_i v[i,p] M[:, i] (column node p' = R + p)
  sum_columns_many(M, n, n, v, 1, C, R, C, Pt + R * n, n);
  for (KIndex p = 0; p < C; ++p) {
    double* d = Pt + (R + p) * n;
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
  // K[0:R, p'] (a column of R entries, kGroup columns at a time into krc), then the diagonal terms
  double* krc = kdiag + n;  // kGroup * R more entries of workspace after kdiag
  for (KIndex p = 0; p < C;) {
    const KIndex g = p + kGroup <= C ? kGroup : 1;
    sum_columns_many(M, n, R, Pt + (R + p), 1, n, n, g, krc, R);
    for (KIndex q = 0; q < g; ++q)
      for (KIndex i = 0; i < R; ++i)
        out[i * C + p + q] = kdiag[i] + kdiag[R + p + q] - 2.0 * krc[q * R + i];
    p += g;
  }
}

}  // namespace
}  // namespace psmat::iecm
