// IECM inverse g = F^-1(G_exp), g > 0 (thesis eq. 2.8-2.10, docs/spec.md §3).
//
// A Solver owns the workspace of one thread: the nodal inverse, the Newton operator and its
// preconditioner. Between calls it keeps the preconditioner, so consecutive frames of a
// stream reuse one factorisation for as long as PCG converges quickly with it.
#pragma once
#include <vector>

#include "psmat/iecm/free_block_solver.hpp"
#include "psmat/iecm/laplacian.hpp"
#include "psmat/iecm/newton_operator.hpp"
#include "psmat/iecm/solve_options.hpp"

namespace psmat::iecm {

class Solver {
 public:
  Solver(Shape shape, const SolveOptions& options);

  // Solves F(g) = G_exp. With warm, g holds the starting point (the previous frame); without,
  // the solve starts cold from g0 = G_exp and the stored factorisation is discarded.
  SolveReport solve(const ConstVecRef& G_exp, VecRef g, bool warm);

  // Forget the stored preconditioner.
  void reset() {
    op.reset();
    free_block.reset();
    last_free.clear();
  }

  const SolveOptions& options() const { return opts_; }
  const Shape& shape() const { return shape_; }

  // ---- workspace used by the method implementations (solve_*.cpp) ----
  // Evaluates F(g) into Gm, the raw residual ra = F(g) - G_exp, the cost
  // 0.5*sum((ra/G_exp)^2) and the max relative residual. False if the network is singular.
  bool evaluate(const ConstVecRef& g, const ConstVecRef& G_exp, double& cost, double& resid);

  NodalInverse net;
  Eigen::VectorXd Gm;     // F(g) at the last evaluated point
  Eigen::VectorXd ra;     // F(g) - G_exp at the last evaluated point
  NewtonOperator op;      // Newton: matrix-free S and its reusable preconditioner
  Eigen::MatrixXd S;      // dense double S (bounded Newton), sized on first use
  FreeBlockSolver free_block;  // active-set method: factor of the free block of S, kept
  std::vector<char> last_free;  // active-set method: the last frame's final free set, per cell

 private:
  Shape shape_;
  SolveOptions opts_;
};

// Method implementations, all on the Solver's workspace; g is the starting point in and the
// result out. Recommended: solve_newton (noisy frames handed to solve_active_set) and
// solve_active_set; the others are the reference methods (psmat.iecm.reference).
SolveReport solve_newton(Solver& s, const ConstVecRef& G_exp, VecRef g);
SolveReport solve_bounded_newton(Solver& s, const ConstVecRef& G_exp, VecRef g);
SolveReport solve_active_set(Solver& s, const ConstVecRef& G_exp, VecRef g);
SolveReport solve_least_squares(Solver& s, const ConstVecRef& G_exp, VecRef g, bool log_param);
SolveReport solve_fixed_point(Solver& s, const ConstVecRef& G_exp, VecRef g);

}  // namespace psmat::iecm
