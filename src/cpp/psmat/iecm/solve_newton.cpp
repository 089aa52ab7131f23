// Damped Newton on log g for F(g) = G_exp (SPEC §3, eq. 2.8 with positivity by
// log-parameterisation, as the thesis' C/GSL implementation).
//
// Newton step: J dg = -(F(g) - G_exp) with J = D_G (S) D_G^-1, S = D_G (T∘T) D_G SPD
//   => S y = -(F(g) - G_exp)/G,  dg = G∘y,  d(log g) = dg/g.
// Globalisation: |d log g| capped (trust region in log space) and a backtracking line search
// on the cost 0.5*sum(((F(g)-G_exp)/G_exp)^2), for which the Newton step is a descent
// direction with slope -2*cost. Chord steps reuse the last factorisation (S at G_ref) while
// they shrink the cost by `chord_contraction` and the iterate is close to a solution (far from
// it, a stale linearisation can lead into regions where cells collapse); otherwise S is rebuilt.
#include <algorithm>
#include <cmath>
#include <limits>

#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

namespace {
// Caps the log step so that max |dx| <= cap; returns the scale applied.
double cap_step(Eigen::VectorXd& dx, double cap) {
  const double m = dx.cwiseAbs().maxCoeff();
  if (m > cap) {
    dx *= cap / m;
    return cap / m;
  }
  return 1.0;
}

void take_log_step(const ConstVecRef& g, const Eigen::VectorXd& dx, double t, double floor,
                   Eigen::VectorXd& out) {
  out = (g.array() * (t * dx.array()).exp()).max(floor).matrix();
}
}  // namespace

SolveReport solve_newton(Solver& s, const ConstVecRef& G_exp, VecRef g) {
  const SolveOptions& o = s.options();
  const Index n = s.shape().cells();
  SolveReport rep;
  Eigen::VectorXd dx(n), gt(n), rhs(n);
  g = g.cwiseMax(o.g_floor);
  const Eigen::VectorXd g_start = g;  // the bounded fallback restarts from here
  // A warm start from a bounded solution (cells at the floor) stays on the bounded problem:
  // log g cannot move off the floor in a useful number of steps.
  if (o.fallback && (g.array() <= o.g_floor * (1.0 + 1e-9)).any()) {
    SolveReport b = solve_bounded_newton(s, G_exp, g);
    b.used_fallback = true;
    return b;
  }

  double cost = 0, resid = 0;
  if (!s.evaluate(g, G_exp, cost, resid)) {
    rep.status = Status::Singular;
    return rep;
  }
  rep.evaluations = 1;
  bool at_g = true;  // is the Solver's evaluation state that of g?
  int slow = 0;      // consecutive Newton iterations with little progress

  for (; rep.iterations < o.max_iter; ++rep.iterations) {
    if (resid <= o.rtol) {
      rep.status = Status::Converged;
      break;
    }
    // --- chord step with the stored factorisation -------------------------------------
    if (o.chord && s.have_factor_ && resid <= o.chord_max_residual) {
      rhs = -(s.ra.array() / s.G_ref.array()).matrix();
      s.llt.solveInPlace(rhs);
      dx = (s.G_ref.array() * rhs.array() / g.array()).matrix();
      cap_step(dx, o.max_log_step);
      take_log_step(g, dx, 1.0, o.g_floor, gt);
      double ct = 0, rt = 0;
      ++rep.evaluations;
      if (s.evaluate(gt, G_exp, ct, rt) && ct <= o.chord_contraction * cost) {
        g = gt;
        cost = ct;
        resid = rt;
        at_g = true;
        continue;
      }
      // not contracting: rebuild the Newton matrix at g
      s.have_factor_ = false;
      ++rep.evaluations;
      if (!s.evaluate(g, G_exp, cost, resid)) {
        rep.status = Status::Singular;
        return rep;
      }
      at_g = true;
    }
    // --- full Newton step with line search ----------------------------------------------
    if (!at_g) {
      ++rep.evaluations;
      s.evaluate(g, G_exp, cost, resid);
    }
    if (!s.factorize_newton_matrix()) {
      rep.status = Status::Singular;
      break;
    }
    ++rep.factorizations;
    rhs = -(s.ra.array() / s.Gm.array()).matrix();
    s.llt.solveInPlace(rhs);
    dx = (s.Gm.array() * rhs.array() / g.array()).matrix();
    cap_step(dx, o.max_log_step);

    double t = 1.0, ct = std::numeric_limits<double>::infinity(), rt = 0;
    bool accepted = false;
    for (int k = 0; k < 40; ++k, t *= 0.5) {
      take_log_step(g, dx, t, o.g_floor, gt);
      ++rep.evaluations;
      const bool ok = s.evaluate(gt, G_exp, ct, rt);
      if (ok && ct <= (1.0 - 2e-4 * t) * cost) {  // Armijo, slope -2*cost
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      at_g = false;
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
    SolveReport b = solve_bounded_newton(s, G_exp, g);
    b.iterations += rep.iterations;
    b.factorizations += rep.factorizations;
    b.evaluations += rep.evaluations;
    b.used_fallback = true;
    return b;
  }
  return rep;
}

}  // namespace psmat::iecm
