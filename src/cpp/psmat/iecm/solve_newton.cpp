// Damped Newton-Krylov on log g for F(g) = G_exp (docs/spec.md §3; eq. 2.8 with positivity by
// log-parameterisation, as the thesis' C/GSL implementation).
//
// Newton step: J dg = -(F(g) - G_exp) with J = D_G S D_G^-1, S = D_G (T∘T) D_G SPD
//   => S y = -(F(g) - G_exp)/G,  dg = G∘y,  applied as g <- g exp(t dx), dx = log((g+dg)/g)
//      projected into [-cap, cap] per cell (see projected_log_step),
// solved by PCG with the exact matrix-free S and a reusable float32 Cholesky preconditioner
// (newton_operator.hpp), to a relative tolerance min(forcing, 0.1*residual) (inexact Newton).
// The preconditioner is rebuilt at the current point only when PCG needs more than
// krylov_max_iter iterations or the step fails the line search; otherwise it is kept across
// iterations and across the frames of a stream.
// Globalisation: the per-cell multiplicative trust region and a backtracking line search on the
// cost 0.5*sum(((F(g)-G_exp)/G_exp)^2), for which the Newton step is a descent direction with
// slope -2*cost.
// Fallback (options.fallback): a frame Newton cannot finish (noisy G_exp that no g > 0
// reproduces: the cost stalls) is restarted from its starting point by the active-set method
// (solve_active_set.cpp), whose complementarity solution is the answer there; a start with
// cells at g_floor (the previous frame of a stream was such a frame) goes to it directly.
#include <algorithm>
#include <cmath>
#include <limits>

#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

namespace {
// The Newton step dg taken in g, projected cell by cell into the multiplicative trust region
// g e^-cap <= g + dg <= g e^cap (positivity included). Taking it in g rather than as
// d(log g) = dg/g lets a cell that starts far above its value (g0 = G >> g on quiet cells)
// drop to it in one step instead of by a factor e per iteration; clipping per cell rather
// than scaling the whole step keeps a few ghost-dominated cells (whose G barely depends on
// them) from stalling all the others. Returned as the log step dx = log(g_new / g).
void projected_log_step(const ConstVecRef& g, const Eigen::VectorXd& dg, double cap,
                        Eigen::VectorXd& dx) {
  const double lo = std::exp(-cap), hi = std::exp(cap);
  dx = ((g.array() + dg.array()).max(lo * g.array()).min(hi * g.array()) / g.array()).log().matrix();
}
}  // namespace

SolveReport solve_newton(Solver& s, const ConstVecRef& G_exp, VecRef g) {
  const SolveOptions& o = s.options();
  const Index n = s.shape().cells();
  const int kmax = o.krylov_max_iter > 0 ? o.krylov_max_iter : 10 + static_cast<int>(n / 64);
  SolveReport rep;
  Eigen::VectorXd dx(n), gt(n), b(n), y(n);
  g = g.cwiseMax(o.g_floor);
  const Eigen::VectorXd g_start = g;  // the active-set fallback restarts from here
  // A warm start from a bounded solution (cells at the floor) stays on the bounded problem:
  // log g cannot move off the floor in a useful number of steps.
  if (o.fallback && (g.array() <= o.g_floor * (1.0 + 1e-9)).any()) {
    SolveReport bd = solve_active_set(s, G_exp, g);
    bd.used_fallback = true;
    return bd;
  }
  if (!o.reuse_factorization) s.op.reset();

  double cost = 0, resid = 0;
  if (!s.evaluate(g, G_exp, cost, resid)) {
    rep.status = Status::Singular;
    return rep;
  }
  rep.evaluations = 1;
  bool at_g = true;  // does the Solver's evaluation state belong to g?
  int slow = 0;      // consecutive iterations that did not halve the cost

  for (; rep.iterations < o.max_iter; ++rep.iterations) {
    if (resid <= o.rtol) {
      rep.status = Status::Converged;
      break;
    }
    if (!at_g) {
      ++rep.evaluations;
      s.evaluate(g, G_exp, cost, resid);
      at_g = true;
    }
    b = -(s.ra.array() / s.Gm.array()).matrix();
    const double tol = std::max(1e-8, std::min(o.forcing, 0.1 * resid));
    bool fresh = false;  // preconditioner built at this very point?
    if (!s.op.has_factor()) {
      if (!s.op.factor(s.net, s.Gm)) {
        rep.status = Status::Singular;
        break;
      }
      ++rep.factorizations;
      fresh = true;
    }
    int k = s.op.pcg(s.net, s.Gm, b, y, tol, kmax);
    rep.krylov_iterations += k > 0 ? k : kmax;
    if (k < 0 && !fresh) {  // a stale preconditioner: rebuild here and solve again
      if (!s.op.factor(s.net, s.Gm)) {
        rep.status = Status::Singular;
        break;
      }
      ++rep.factorizations;
      fresh = true;
      k = s.op.pcg(s.net, s.Gm, b, y, tol, 4 * kmax);
      rep.krylov_iterations += k > 0 ? k : 4 * kmax;
    }
    // Two candidate directions: the projected g-space step (fast far from the solution) and,
    // if its line search fails, the plain log-Newton step scaled into the trust region
    // (always a descent direction for the cost: slope -2*cost).
    double t = 1.0, ct = std::numeric_limits<double>::infinity(), rt = 0;
    bool accepted = false;
    for (int attempt = 0; attempt < 2 && !accepted; ++attempt) {
      if (attempt == 0) {
        projected_log_step(g, (s.Gm.array() * y.array()).matrix(), o.max_log_step, dx);
      } else {
        dx = (s.Gm.array() * y.array() / g.array()).matrix();
        const double m = dx.cwiseAbs().maxCoeff();
        if (m > o.max_log_step) dx *= o.max_log_step / m;
      }
      t = 1.0;
      for (int ls = 0; ls < (attempt == 0 ? 4 : 40); ++ls, t *= 0.5) {
        gt = (g.array() * (t * dx.array()).exp()).max(o.g_floor).matrix();
        ++rep.evaluations;
        at_g = false;
        if (s.evaluate(gt, G_exp, ct, rt) && ct <= (1.0 - 2e-4 * t) * cost) {  // Armijo
          accepted = true;
          break;
        }
      }
    }
    if (!accepted) {
      if (!fresh) {  // maybe only the preconditioner was too stale for an accurate step
        s.op.reset();
        continue;
      }
      rep.status = Status::Stalled;
      break;
    }
    slow = (ct > 0.5 * cost) ? slow + 1 : 0;
    g = gt;
    cost = ct;
    resid = rt;
    at_g = true;
    if (slow >= 8) {  // eight damped iterations without halving the cost: no exact solution
      rep.status = Status::Stalled;
      break;
    }
  }
  if (!at_g) {
    ++rep.evaluations;
    s.evaluate(g, G_exp, cost, resid);
  }
  rep.cost = cost;
  rep.residual = resid;
  if (rep.status != Status::Converged && rep.status != Status::Singular && resid <= o.rtol)
    rep.status = Status::Converged;

  if (!rep.converged() && o.fallback) {
    // G_exp not reproducible by positive g (noise): the complementarity solution, from the
    // starting point (a stalled log-Newton path may have wandered into a poor region).
    g = g_start;
    SolveReport bd = solve_active_set(s, G_exp, g);
    bd.iterations += rep.iterations;
    bd.factorizations += rep.factorizations;
    bd.krylov_iterations += rep.krylov_iterations;
    bd.evaluations += rep.evaluations;
    bd.used_fallback = true;
    return bd;
  }
  return rep;
}

}  // namespace psmat::iecm
