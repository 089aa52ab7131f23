// IECM inverse g = F^-1(G_exp), g > 0 (thesis eq. 2.8-2.10, SPEC §3).
//
// A Solver owns the workspace of one thread: the nodal inverse, the Newton matrix and its
// Cholesky factor. Between calls it keeps that factor, so consecutive frames of a stream
// are solved with chord steps (the previous frame's factorisation) until they stop
// contracting — one factorisation every few frames instead of one per iteration.
#pragma once
#include "psmat/iecm/laplacian.hpp"
#include "psmat/iecm/solve_options.hpp"

namespace psmat::iecm {

class Solver {
 public:
  Solver(Shape shape, const SolveOptions& options);

  // Solves F(g) = G_exp. With warm, g holds the starting point (the previous frame); without,
  // the solve starts cold from g0 = G_exp and the stored factorisation is discarded.
  SolveReport solve(const ConstVecRef& G_exp, VecRef g, bool warm);

  // Forget the stored factorisation.
  void reset() { have_factor_ = false; }

  const SolveOptions& options() const { return opts_; }
  const Shape& shape() const { return shape_; }

  // ---- workspace used by the method implementations (solve_*.cpp) ----
  // Evaluates F(g) into Gm, the raw residual ra = F(g) - G_exp, the cost
  // 0.5*sum((ra/G_exp)^2) and the max relative residual. False if the network is singular.
  bool evaluate(const ConstVecRef& g, const ConstVecRef& G_exp, double& cost, double& resid);
  // Builds S = D_G (T∘T) D_G at the last evaluated point and Cholesky-factorises it (with a
  // small diagonal shift if round-off makes it indefinite). Stores G_ref = Gm.
  bool factorize_newton_matrix();

  NodalInverse net;
  Eigen::VectorXd Gm;     // F(g) at the last evaluated point
  Eigen::VectorXd ra;     // F(g) - G_exp at the last evaluated point
  Eigen::MatrixXd S;      // Newton matrix (or normal matrix for least squares)
  Eigen::LLT<Eigen::MatrixXd> llt;
  Eigen::VectorXd G_ref;  // Gm where the stored factorisation was built
  bool have_factor_ = false;

 private:
  Shape shape_;
  SolveOptions opts_;
};

// Method implementations, all on the Solver's workspace; g is the starting point in and the
// result out.
SolveReport solve_newton(Solver& s, const ConstVecRef& G_exp, VecRef g);
SolveReport solve_bounded_newton(Solver& s, const ConstVecRef& G_exp, VecRef g);
SolveReport solve_least_squares(Solver& s, const ConstVecRef& G_exp, VecRef g, bool log_param);
SolveReport solve_fixed_point(Solver& s, const ConstVecRef& G_exp, VecRef g);

}  // namespace psmat::iecm
