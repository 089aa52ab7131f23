// FreeBlockSolver: the linear algebra of the active-set method (the method itself:
// solve_active_set.cpp), kept by a Solver across the iterations and frames of a stream: the
// Cholesky factor of the free block of S, used as the preconditioner of the Krylov (PCG) solves
// while the free set and the point move under it; for large blocks a split factor (core block
// factorised, Schur complement of the fringe kept) that follows a changing free set cheaply.
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
  // Cells of I and P that differ (for a split factor, P without the core cells that were
  // outside I at the last select: an unchanged I is no change).
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
  // The split factor: U = core then fringe (disjoint cells), S_UU at (net, G) factorised over the
  // core only (cholesky_partial_in_place): L_CC, the panel W = L_FC and the Schur complement
  //   Z = S_FF - W W^T
  // are kept. The Schur complement of the core in S_(C+J) for any part J of the fringe is the
  // principal submatrix Z_JJ, so a free set I = C + J costs the Cholesky of Z_JJ (select), not
  // of all of S_II. False if the core block is not SPD (float32, after a small shift).
  bool factor_split(const NodalInverse& net, const Eigen::VectorXd& G,
                    const std::vector<Index>& core, const std::vector<Index>& fringe);
  // Whether the stored factor is a split one (factor_split; factor() and update() end it).
  bool is_split() const { return valid_ && split_; }
  // Brings the split factor to I = free_cells: P = core + (fringe cells in I), the fringe first
  // grown by the cells of I outside U (a new row of W by one triangular solve against L_CC, a new
  // row of Z). Core cells outside I stay in P as identity rows of PCG's operator (solve()); the
  // preconditioner is still S_II's on I, by a capacitance correction (out_pos_ below). In split
  // mode only L_CC lives in L_; the preconditioner solves by blocks with W_J and L_JJ. L_JJ is
  // updated from the last select's when at most kFringeUpdateMax fringe cells changed
  // (update_fringe), else factorised anew; a fringe out of room first drops its cells outside I
  // (compact_fringe). False when the room is still too small or a pivot is not positive: the
  // factor is then invalid and the caller refactorises.
  bool select(const NodalInverse& net, const Eigen::VectorXd& G,
              const std::vector<Index>& free_cells);
  // Core cells outside free_cells (they stay in P as identity rows of PCG's operator).
  Index core_outside(const std::vector<Index>& free_cells) const;
  // Solves S_II y_I = b_I to ||residual|| <= tol ||b_I||; b and y have length R*C
  // (entries outside I: b ignored, y set to 0). Sy receives S y on every cell, summed from the
  // products PCG makes anyway (the active-set method reads its multipliers off it). With
  // from_guess, PCG starts from y on I (the previous solve's) instead of 0. Returns the PCG
  // iterations used, or -1 when max_iter was reached or the recurrence broke down (y then holds
  // the last iterate).
  int solve(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
            const std::vector<Index>& free_cells, const Eigen::VectorXd& b, Eigen::VectorXd& y,
            Eigen::VectorXd& Sy, double tol, int max_iter, bool from_guess = false);

 private:
  void apply(NewtonOperator& op, const NodalInverse& net, const Eigen::VectorXd& G,
             const Eigen::VectorXd& v, Eigen::VectorXd& out);
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z);
  void remove_position(Index k);
  // Drops from the fringe (W_, Z_) the cells outside I (mark_), when a select has no room left
  // for the cells that join it.
  void compact_fringe();
  // Room in Zs_ and Wa_ for an active fringe of na cells and the cells that join it later.
  void reserve_fringe_factor(Index na);
  // Brings L_JJ (Zs_, rows active_) from the last select's J to the marked one without a new
  // factorisation: a rank-1 update per fringe cell that leaves (its row becomes an identity row,
  // a hole, active_ = -1) and a new last row per cell that joins. False when more than
  // kFringeUpdateMax cells changed, the holes would pass a quarter of the rows, or a new pivot is
  // not positive (select then factorises Z_JJ anew).
  bool update_fringe();
  // Changed fringe cells that update_fringe() takes: each costs O(|J|^2), a new factor
  // O(|J|^3 / 3). Noisy 64x64 bench stream (|J| ~ 500, a new factor ~1.7 ms, an update ~15 us a
  // cell), ms a frame: 32 changed cells at most 41.2, 64 41.0, 128 40.9 (the same within the
  // run's noise), 300 49.3; without updates 45-46. At 32x32 (|J| ~ 200) the same either way.
  static constexpr Index kFringeUpdateMax = 64;

  std::vector<Index> cells_;  // factor position -> cell of P; -1: a cell that left (identity row)
  std::vector<Index> pos_;    // cell -> factor position, -1 when not in P
  Index used_ = 0, holes_ = 0;  // positions in use, of which identity rows
  std::vector<char> mark_;    // per cell: in the I of an update
  Eigen::VectorXd i_mask_, p_only_;  // per cell, 1 or 0: in the current I; in P \ I
  Eigen::MatrixXf L_;         // lower triangle of the top-left used_ x used_ corner: the factor,
                              // float32 (only a preconditioner, as in newton_operator.hpp); the
                              // rest is room for cells that join
  bool valid_ = false;
  bool split_ = false;        // a split factor (factor_split): positions [0, nc_) the core, then
                              // the fringe (fringe_[j] at position nc_ + j, active or a hole)
  Index nc_ = 0;
  std::vector<Index> fringe_, core_cells_;  // fringe index -> cell; the core's cells in order
  std::vector<Index> fidx_;   // cell -> fringe index, -1 when not in the fringe
  Eigen::MatrixXf W_, Z_;     // fringe x core panel L_FC; fringe x fringe Schur complement (lower)
  Eigen::MatrixXf Zs_;        // Z on the active fringe J, then its factor L_JJ
  Eigen::MatrixXf Wa_;        // W on J (na x nc)
  std::vector<Index> active_;  // position in L_JJ -> fringe index, -1: a hole (update_fringe)
  std::vector<Index> actpos_;  // fringe index -> position in active_, -1 when not in J
  Index act_holes_ = 0;
  bool fringe_factored_ = false;  // Zs_ holds L_JJ of this split factor's last select
  std::vector<Index> leaving_, joining_;
  std::vector<char> core_out_;
  std::vector<char> keep_;  // compact_fringe: per fringe index, in I  // per core position: outside I at the last select
  // core cells outside I (their positions O): the preconditioner is the factor's solve
  // restricted to y_O = 0 (capacitance): with Y = L^-1 E_O and K = Y^T Y,
  //   z = L^-T (u - Y K^-1 Y^T u),   u = L^-1 r.
  // Y's core rows L_CC^-1 e_o do not depend on the fringe: kept per core position (yc_col_).
  std::vector<Index> out_pos_, yc_col_;
  Eigen::MatrixXf Y_, Yc_;
  Index n_yc_ = 0;
  Eigen::LLT<Eigen::MatrixXd> K_;
  Eigen::VectorXd mu_;
  Eigen::VectorXd x_, Sx_, b_;
  numerics::PcgWork pcg_;
  Eigen::VectorXf tmp_, col_, ytu_;
};

}  // namespace psmat::iecm
