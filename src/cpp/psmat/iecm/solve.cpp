#include "psmat/iecm/solve.hpp"

#include <cmath>

#include "psmat/iecm/forward.hpp"
#include "psmat/iecm/jacobian.hpp"

namespace psmat::iecm {

const char* to_string(Method m) {
  switch (m) {
    case Method::Newton: return "newton";
    case Method::BoundedNewton: return "bounded_newton";
    case Method::LM: return "lm";
    case Method::BoundedLSQ: return "bounded_lsq";
    case Method::FixedPoint: return "fixed_point";
    case Method::ActiveSet: return "active_set";
  }
  return "unknown";
}

Solver::Solver(Shape shape, const SolveOptions& options)
    : net(shape),
      Gm(shape.cells()),
      ra(shape.cells()),
      op(shape),
      shape_(shape),
      opts_(options) {}

bool Solver::evaluate(const ConstVecRef& g, const ConstVecRef& G_exp, double& cost,
                      double& resid) {
  if (!forward(g, net, Gm)) return false;
  ra = Gm - G_exp;
  cost = 0.5 * (ra.array() / G_exp.array()).square().sum();  // no temporaries: hot path
  resid = (ra.array() / G_exp.array()).abs().maxCoeff();
  return std::isfinite(cost);
}

SolveReport Solver::solve(const ConstVecRef& G_exp, VecRef g, bool warm) {
  if (!warm) {
    g = G_exp;  // g0 = G: the equivalent conductance bounds the cell conductance from above
    reset();
  }
  switch (opts_.method) {
    case Method::Newton: return solve_newton(*this, G_exp, g);
    case Method::BoundedNewton: return solve_bounded_newton(*this, G_exp, g);
    case Method::LM: return solve_least_squares(*this, G_exp, g, /*log_param=*/true);
    case Method::BoundedLSQ: return solve_least_squares(*this, G_exp, g, /*log_param=*/false);
    case Method::FixedPoint: return solve_fixed_point(*this, G_exp, g);
    case Method::ActiveSet: return solve_active_set(*this, G_exp, g);
  }
  return {};
}

}  // namespace psmat::iecm
