// The arithmetic of NodalInverse::compute (laplacian.hpp: M = Cmat^-1 by blocks, thesis eq.
// 2.6-2.7, docs/spec.md §3) on raw arrays, in a header of its own so that several translation
// units compile it: laplacian.cpp for the baseline instruction set of the build, the vector units
// of simd.hpp (AVX2 + FMA, AVX-512; chosen at run time) under their renamed Eigen namespaces.
// Internal linkage: each unit keeps its own copy. The checks (every cell finite and >= 0, one
// connected network, M finite) stay in NodalInverse::compute.
//
// Why in the units: its products (E Mcc, Mrc E^T, W^T W, the rank update of Sc) are double GEMMs
// of the line counts (63 x 64 x 64 at 64x64), once per forward evaluation (~5 a noisy frame).
// Measured in isolation (one core, random g, us per call, baseline SSE2 / AVX-512): 16x16 3.9 / 3.0,
// 32x32 18.3 / 9.5, 64x64 110 / 41.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace psmat::iecm {
namespace {

// Doubles of workspace for nodal_inverse_kernel: a copy of g (R*C), Dr, E (R-1 x C), Sc
// and W (C x C each), M (n x n), each block rounded up to 8 doubles, and 8 to align the first to
// 64 bytes.
inline std::ptrdiff_t nodal_inverse_block(std::ptrdiff_t size) { return (size + 7) / 8 * 8; }
inline std::ptrdiff_t nodal_inverse_work_doubles(std::ptrdiff_t R, std::ptrdiff_t C) {
  return 8 + nodal_inverse_block(R * C) + nodal_inverse_block(R - 1) +
         nodal_inverse_block((R - 1) * C) + 2 * nodal_inverse_block(C * C) +
         nodal_inverse_block((R + C) * (R + C));
}

// g: R*C cells, row-major, finite and > 0 on enough cells to connect the network (the caller
// checks). m: n x n column-major (ld n, n = R + C), its ground row and column 0 set to zero.
// work: nodal_inverse_work_doubles(R, C) doubles, any alignment. With the ground row dropped,
// Cmat = [Dr -B; -B^T Dc], E = Dr^-1 B, Sc = Dc - B^T E:
//   Mcc = Sc^-1 = W^T W (W = L^-1, L L^T = Sc),   Mrc = E Mcc,   Mrr = Dr^-1 + Mrc E^T.
// False where Sc is numerically not positive definite.
// The result does not depend on where g, m and work lie: g is copied into the workspace, whose
// blocks start on 64-byte boundaries, M is formed there and copied out, so that Eigen's
// vectorised sums and small products (which split their work by the alignment of their data: at
// 5x5 and 6x6 the products' first and last coefficients came out of another instruction than
// the rest) run the same way on every call (a C++ test shifts the arrays).
inline bool nodal_inverse_kernel(const double* g, std::ptrdiff_t R, std::ptrdiff_t C, double* m,
                                 double* work) {
  using Index = Eigen::Index;
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Index r = R - 1, n = R + C;
  double* w0 = reinterpret_cast<double*>((reinterpret_cast<std::uintptr_t>(work) + 63) &
                                         ~static_cast<std::uintptr_t>(63));
  double* const gc = w0;
  double* const rd = gc + nodal_inverse_block(R * C);
  double* const e = rd + nodal_inverse_block(r);
  double* const scp = e + nodal_inverse_block(r * C);
  double* const wp = scp + nodal_inverse_block(C * C);
  double* const mw = wp + nodal_inverse_block(C * C);
  std::copy(g, g + R * C, gc);
  const Eigen::Map<const RowMatrix> V(gc, R, C);
  Eigen::Map<Eigen::VectorXd> rdeg(rd, r);
  Eigen::Map<Eigen::MatrixXd> E(e, r, C);
  Eigen::Map<Eigen::MatrixXd> sc(scp, C, C);
  Eigen::Map<RowMatrix> w(wp, C, C);
  Eigen::Map<Eigen::MatrixXd> M(mw, n, n);
  rdeg = V.bottomRows(r).rowwise().sum();
  E = rdeg.cwiseInverse().asDiagonal() * V.bottomRows(r);  // Dr^-1 B
  sc.setZero();
  sc.diagonal() = V.colwise().sum().transpose();  // Dc
  sc.selfadjointView<Eigen::Lower>().rankUpdate((rdeg.cwiseSqrt().asDiagonal() * E).transpose(),
                                                -1.0);  // - B^T Dr^-1 B
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(sc);     // in place (lower triangle)
  if (llt.info() != Eigen::Success) return false;
  // Sc^-1 = W^T W with W = L^-1 (measured on the whole Cmat, n - 1 = 31...127: ~30 % faster than
  // two triangular solves against the identity). W row by row:
  // W[i, :i] = -L[i, :i] W[:i, :i] / L[i,i], one vector-matrix product per row.
  const auto L = llt.matrixLLT();
  w.setZero();
  for (Index i = 0; i < C; ++i) {
    const double inv = 1.0 / L(i, i);
    if (i > 0) w.row(i).head(i).noalias() = -(L.row(i).head(i) * w.topLeftCorner(i, i)) * inv;
    w(i, i) = inv;
  }
  auto Mcc = M.bottomRightCorner(C, C);
  Mcc.noalias() = w.transpose() * w;
  auto Mrc = M.block(1, R, r, C);
  Mrc.noalias() = E * Mcc;
  auto Mrr = M.block(1, 1, r, r);
  Mrr.noalias() = Mrc * E.transpose();
  Mrr.diagonal() += rdeg.cwiseInverse();
  M.block(R, 1, C, r) = Mrc.transpose();
  M.row(0).setZero();  // the ground node
  M.col(0).setZero();
  std::copy(mw, mw + n * n, m);
  return true;
}

}  // namespace
}  // namespace psmat::iecm
