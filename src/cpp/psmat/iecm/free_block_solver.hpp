// FreeBlockSolver: the linear algebra of the active-set method (the method itself:
// solve_active_set.cpp), kept by a Solver across the iterations and frames of a stream: the
// Cholesky factor of the free block of S, used as the preconditioner of the Krylov (PCG) solves
// while the free set and the point move under it.
#pragma once
#include <vector>

#include "psmat/iecm/laplacian.hpp"
#include "psmat/iecm/newton_operator.hpp"
#include "psmat/numerics/pcg.hpp"

namespace psmat::iecm {

// The free-block system of one active-set step, S_II y_I = b_I, solved by PCG
// (numerics/pcg.hpp) with matrix-free products of S (newton_operator.hpp) and a stored factor
//   L L^T = S_PP
// of a free set P, built at an earlier iterate (or frame) or brought to the current free set by
// updates. While P differs from the current free set I, PCG runs on I ∪ P with identity rows for
// the cells of P \ I (their step is fixed by the bound) and a unit diagonal for the cells of
// I \ P: each such cell is a low-rank difference between the operator and the preconditioner
// that PCG absorbs in an iteration or two.
class FreeBlockSolver {
 public:
  // Forget the stored factor.
  void reset() { valid_ = false; }
  bool has_factor() const { return valid_; }
  // Cells of I and P that differ.
  Index changes(const std::vector<Index>& free_cells) const;
  // Cells in P.
  Index size() const { return used_ - holes_; }
  // Builds and factorises S_II at (net, G) for I = free_cells (float32, with a small diagonal
  // shift if round-off needs one). False if not SPD even then.
  bool factor(const NodalInverse& net, const Eigen::VectorXd& G,
              const std::vector<Index>& free_cells);
  // Brings P to I = free_cells without refactorising: a cell of P \ I leaves by a rank-1 update
  // of the factor below its row (cholesky_rank1_update; its row becomes an identity row), a cell of
  // I \ P joins as a new last row from its column of S at (net, G) (one triangular solve).
  // O(|P|^2) per cell against O(|P|^3) for factor(); exact when the factor is of the same point.
  // False when the room reserved by factor() is used up or a new pivot is not positive: the
  // factor is then invalid and the caller refactorises.
  bool update(const NodalInverse& net, const Eigen::VectorXd& G,
              const std::vector<Index>& free_cells);
  // Solves S_II y_I = b_I to ||residual|| <= tol ||b_I||; b and y have length R*C
  // (entries outside I: b ignored, y set to 0). Sy receives S y on every cell, summed from the
  // products PCG makes anyway (the active-set method reads its multipliers off it). Returns the
  // PCG iterations used, or -1 when max_iter was reached or the recurrence broke down (y then
  // holds the last iterate).
  int solve(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
            const std::vector<Index>& free_cells, const Eigen::VectorXd& b, Eigen::VectorXd& y,
            Eigen::VectorXd& Sy, double tol, int max_iter);

 private:
  void apply(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
             const Eigen::VectorXd& v, Eigen::VectorXd& out);
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z);
  void remove_position(Index k);

  std::vector<Index> cells_;  // factor position -> cell of P; -1: a cell that left (identity row)
  std::vector<Index> pos_;    // cell -> factor position, -1 when not in P
  Index used_ = 0, holes_ = 0;  // positions in use, of which identity rows
  std::vector<char> mark_;    // per cell: in the I of an update
  Eigen::VectorXd i_mask_, p_only_;  // per cell, 1 or 0: in the current I; in P \ I
  Eigen::MatrixXf L_;         // lower triangle of the top-left used_ x used_ corner: the factor,
                              // float32 (only a preconditioner, as in newton_operator.hpp); the
                              // rest is room for cells that join
  bool valid_ = false;
  Eigen::VectorXd x_, Sx_, b_;
  numerics::PcgWork pcg_;
  Eigen::VectorXf tmp_, col_;
};

}  // namespace psmat::iecm
