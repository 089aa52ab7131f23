// Grounded nodal matrix of the basic circuit (thesis eq. 2.6-2.7, docs/spec.md §3) and its inverse M.
//
// The R x C array is a bipartite resistor network on n = R + C nodes: rows are nodes
// 0..R-1, columns are nodes R..R+C-1, cell (i, p) joins node i to node R+p with conductance
// g[i,p]. Node 0 (row 0) is ground, as in the thesis ("we consider row 1 as ground").
// `Cmat` is the Laplacian with the ground row/column removed; it is SPD when every row and
// column touches a conducting cell. `M` is Cmat^-1 padded with a zero row and column for the
// ground node, so that node voltages for any injected current vector I are V = M I.
#pragma once
#include <vector>

#include "psmat/types.hpp"

namespace psmat::iecm {

// Laplacian of the cell network, nothing grounded (eq. 2.7 before node 0 is dropped):
// n x n, node order as above, L(i,i) = sum_p g[i,p], L(R+p,R+p) = sum_i g[i,p],
// L(i,R+p) = L(R+p,i) = -g[i,p]. `L` is resized to n x n. Returns false (L unusable) for a
// negative or non-finite g. One assembly for the IECM (grounded at node 0, NodalInverse) and
// the QZPM readout (every line grounded through its switch, thesis eq. C.4-C.6).
bool cell_laplacian(const Shape& s, const ConstVecRef& g, Eigen::MatrixXd& L);

class NodalInverse {
 public:
  explicit NodalInverse(Shape shape);

  // Forms M = Cmat^-1 from g (length R*C, row-major), by blocks: with the ground row dropped,
  // Cmat = [Dr -B; -B^T Dc] (Dr, Dc diagonal: the line degrees; B the cells of rows 1..R-1), so
  // with E = Dr^-1 B and the Schur complement Sc = Dc - B^T E (C x C, Cholesky):
  //   Mcc = Sc^-1,   Mrc = E Mcc,   Mrr = Dr^-1 + Mrc E^T
  // (the elimination Cholesky would do on Cmat, rows first, without forming the (n-1)^2 factor
  // and its inverse: at 16x16 about a quarter of the arithmetic; measured with callgrind on the
  // 16x16 noisy bench stream, 5.4 evaluations a frame: 2.3 times fewer instructions here, the
  // frame ~20 % faster).
  // Returns false when the network is not one connected piece (a row or column with no
  // conducting cell, or two blocks with no cell between them), when g has negative or
  // non-finite entries, or when Cmat is numerically not positive definite; M is then unusable.
  // portable: the block inverse with the build's baseline instruction set only, not the widest
  // vector unit of simd.hpp (the independent check of the units in the C++ tests).
  bool compute(const ConstVecRef& g, bool portable = false);

  const Shape& shape() const { return shape_; }
  // n x n, node order as above, zero row/column for the ground node.
  const Eigen::MatrixXd& M() const { return m_; }

  // Blocks of M used by eq. 2.5 and eq. 2.13 (valid after compute()):
  //   A(i, p)   = M[i, R+p]       rows x cols
  //   Mrr(i, j) = M[i, j]         rows x rows
  //   Mcc(p, q) = M[R+p, R+q]     cols x cols
  auto A() const { return m_.topRightCorner(shape_.rows, shape_.cols); }
  auto Mrr() const { return m_.topLeftCorner(shape_.rows, shape_.rows); }
  auto Mcc() const { return m_.bottomRightCorner(shape_.cols, shape_.cols); }

 private:
  Shape shape_;
  Eigen::MatrixXd m_;     // n x n
  Eigen::VectorXd work_;  // Dr, E = Dr^-1 B, Sc and the inverse of its Cholesky factor
                          // (nodal_inverse_kernel.hpp)
  std::vector<Index> parent_;  // union-find workspace of the connectivity check
};

}  // namespace psmat::iecm
