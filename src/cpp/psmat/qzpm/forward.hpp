// QZPM readout (thesis App. C, docs/spec.md §3 "Adaptation to QZPM"): forward model and Jacobian.
//
// Circuit (eq. C.4-C.6): R row lines (nodes 0..R-1), C column lines (nodes R..R+C-1), the
// connecting node "in" and ground. Cell (i,p) joins row i and column p with g[i,p]. Every
// line k has its own switch of conductance g_k (g_row for rows, g_col for columns) that ties
// it to "in" when the line is selected and to ground otherwise. With
//     A = L_cells + diag(g_row, g_col)        (n x n, n = R + C; SPD for g_k > 0, g >= 0)
// (L_cells is the IECM's, iecm::cell_laplacian, but no node is dropped: every line reaches
// ground or "in" through its own switch, so A's diagonal holds g_k in both switch states),
// selecting a set S of lines with coupling vector s = sum_{k in S} g_k e_k gives node
// potentials V = v V_in, v = A^-1 s, and the admittance between "in" and ground
//     G_S = I_ref / V_in = sum_{k in S} g_k - s^T A^-1 s                       (eq. C.7)
// One Cholesky of A (M = A^-1) gives every reading:
//     pair (i,p):  g_i + g^p - (g_i^2 M_ii + 2 g_i g^p M_{i,R+p} + g^p^2 M_{R+p,R+p})
//     row i:       g_i - g_i^2 M_ii             column p: g^p - g^p^2 M_{R+p,R+p}
// Jacobian (Tellegen: dG/dg_e = (voltage across edge e)^2 for V_in = 1):
//     dG_S/dg[j,q] = (v_j - v_{R+q})^2
//     dG_S/dg_k    = (1 - v_k)^2  if k in S (switch to "in"),   v_k^2 otherwise (to ground)
//
// Reading order (length R*C + R + C): pairs row-major (a = i*C + p), then the R single rows,
// then the C single columns. Parameter order of the Jacobian's columns: cells row-major,
// then g_row (R), then g_col (C).
#pragma once
#include <Eigen/Cholesky>

#include "psmat/types.hpp"

namespace psmat::qzpm {

// Equivalent conductances (S) of the three kinds of switch configuration.
struct Readings {
  Eigen::VectorXd pairs;  // R*C, row-major: row i and column p connected to "in"
  Eigen::VectorXd rows;   // R: only row i connected
  Eigen::VectorXd cols;   // C: only column p connected
  Readings() = default;
  explicit Readings(Shape s) : pairs(s.cells()), rows(s.rows), cols(s.cols) {}
  Index size() const { return pairs.size() + rows.size() + cols.size(); }
  // All readings in the order pairs, rows, cols.
  Eigen::VectorXd flat() const;
  static Readings from_flat(Shape s, const ConstVecRef& v);
};

inline Index n_readings(Shape s) { return s.cells() + s.rows + s.cols; }
inline Index n_parameters(Shape s) { return s.cells() + s.rows + s.cols; }

// A = L_cells + diag(switches), its Cholesky and M = A^-1.
class Network {
 public:
  explicit Network(Shape shape);
  // g: R*C cells (>= 0), sw: R + C switch conductances (> 0), rows first. Returns false for
  // negative / non-finite cells, non-positive / non-finite switches or a failed Cholesky.
  bool compute(const ConstVecRef& g, const ConstVecRef& sw);
  const Shape& shape() const { return shape_; }
  const Eigen::MatrixXd& M() const { return m_; }
  const Eigen::VectorXd& switches() const { return sw_; }

 private:
  Shape shape_;
  Eigen::MatrixXd a_, m_;
  Eigen::VectorXd sw_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

// Readings of an already computed network (eq. C.7), flat order (pairs, rows, cols).
void readings(const Network& net, VecRef G);

// G = F(g, g_row, g_col). Returns false when the network is invalid (see Network::compute).
bool forward(const ConstVecRef& g, const ConstVecRef& g_row, const ConstVecRef& g_col,
             Network& net, Readings& out);

// Dense dG/dtheta, (R*C+R+C) x (R*C+R+C); rows: readings (pairs, rows, cols), columns:
// parameters (cells, g_row, g_col).
void jacobian(const Network& net, RowMatRef J);

}  // namespace psmat::qzpm
