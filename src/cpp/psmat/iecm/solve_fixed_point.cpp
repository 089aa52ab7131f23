// Thesis fixed point (eq. 2.10): g_{n+1} = g_n + beta (G_exp - F(g_n)), clipped at g_floor to
// keep the network physical. Converges when beta < 2/lambda_max(J); the slow modes contract
// by 1 - beta*lambda_min per iteration (lambda spread ~0.005..15 on two-feet images, docs/spec.md §3).
#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

SolveReport solve_fixed_point(Solver& s, const ConstVecRef& G_exp, VecRef g) {
  const SolveOptions& o = s.options();
  SolveReport rep;
  double cost = 0, resid = 0;
  g = g.cwiseMax(o.g_floor);
  for (;; ++rep.iterations) {
    ++rep.evaluations;
    if (!s.evaluate(g, G_exp, cost, resid)) {
      rep.status = Status::Singular;
      break;
    }
    if (resid <= o.rtol) {
      rep.status = Status::Converged;
      break;
    }
    if (rep.iterations >= o.max_iter) {
      rep.status = Status::MaxIterations;
      break;
    }
    g = (g - o.beta * s.ra).cwiseMax(o.g_floor);  // eq. 2.10
  }
  rep.cost = cost;
  rep.residual = resid;
  return rep;
}

}  // namespace psmat::iecm
