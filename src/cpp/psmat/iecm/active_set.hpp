// Workspace of the active-set Newton (solve_active_set.cpp) kept by a Solver across the
// iterations and frames of a stream: the Cholesky factor of the free block of S, used as the
// preconditioner of the Krylov (PCG) solves while the free set and the point move under it.
#pragma once
#include <vector>

#include "psmat/iecm/laplacian.hpp"
#include "psmat/iecm/newton_operator.hpp"

namespace psmat::iecm {

// The free-block system of one active-set Newton step, (S_II + mu I) y_I = b_I, solved by PCG
// with matrix-free products of S (newton_operator.hpp) and a stored factor
//   L L^T = S_PP + mu_P I
// of the free set P of an earlier iterate (or frame). While P differs from the current free
// set I, PCG runs on I ∪ P with identity rows for the cells of P \ I (their step is fixed by
// the bound) and a unit diagonal for the cells of I \ P: each such cell is a low-rank
// difference between the operator and the preconditioner that PCG absorbs in an iteration or
// two, so the factor (O(|P|^3)) is rebuilt only when PCG slows down.
class FreeBlockSolver {
 public:
  // Forget the stored factor.
  void reset() { valid_ = false; }
  bool has_factor() const { return valid_; }
  // Cells of I (ascending) and P that differ.
  Index changes(const std::vector<Index>& free_cells) const;
  // Builds and factorises S_II + mu I at (net, G) for I = free_cells (float32, with a small
  // diagonal shift if round-off needs one). False if not SPD even then.
  bool factor(const NodalInverse& net, const Eigen::VectorXd& G,
              const std::vector<Index>& free_cells, double mu);
  // Solves (S_II + mu I) y_I = b_I to ||residual|| <= tol ||b_I||; b and y have length R*C
  // (entries outside I: b ignored, y set to 0). Sy receives S y on every cell, summed from the
  // products PCG makes anyway (the active-set method reads its multipliers off it). Returns the
  // PCG iterations used, or -1 when max_iter was reached or the recurrence broke down (y then
  // holds the last iterate).
  int solve(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
            const std::vector<Index>& free_cells, double mu, const Eigen::VectorXd& b,
            Eigen::VectorXd& y, Eigen::VectorXd& Sy, double tol, int max_iter);

 private:
  void apply(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G, double mu,
             const Eigen::VectorXd& v, Eigen::VectorXd& out);
  void precondition(const Eigen::VectorXd& r, double mu, Eigen::VectorXd& z);

  std::vector<Index> cells_;  // P, in factor order (ascending)
  std::vector<char> in_p_, in_i_;  // per cell: in P, in the current I
  Eigen::MatrixXf L_;         // lower triangle: Cholesky factor of S_PP + mu_P I, float32: it
                              // is only a preconditioner (as in newton_operator.hpp)
  bool valid_ = false;
  Eigen::VectorXd x_, Sx_, r_, z_, p_, q_;
  Eigen::VectorXf tmp_;
};

}  // namespace psmat::iecm
