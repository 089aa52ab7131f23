// Least squares IECM (thesis eq. 2.9): minimise 0.5*sum(((F(g) - G_exp)/G_exp)^2), g > 0.
//
// Levenberg-Marquardt with the analytic Jacobian (eq. 2.13) in one of two parameterisations:
//  * log_param: x = log g (positivity by construction, as the thesis' GSL implementation);
//  * bounded:   x = g with the bound g >= g_floor, projected steps and an active set
//               (the thesis' scipy `least_squares(bounds=(0, inf))` formulation).
// Used directly (methods "lm", "bounded_lsq") and as the fallback of Newton when noise makes
// G_exp unreachable by any positive g, where the answer is a least-squares point.
#include <algorithm>
#include <cmath>

#include "psmat/iecm/jacobian.hpp"
#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

SolveReport solve_least_squares(Solver& s, const ConstVecRef& G_exp, VecRef g, bool log_param) {
  const SolveOptions& o = s.options();
  const Index n = s.shape().cells();
  SolveReport rep;
  g = g.cwiseMax(o.g_floor);

  double cost = 0, resid = 0;
  if (!s.evaluate(g, G_exp, cost, resid)) {
    rep.status = Status::Singular;
    return rep;
  }
  rep.evaluations = 1;
  Eigen::MatrixXd Jw(n, n), A(n, n);
  Eigen::VectorXd grad(n), d(n), gt(n), dparam(n);
  Eigen::Array<bool, Eigen::Dynamic, 1> fixed(n);
  double lambda = 1e-3;
  bool need_jacobian = true, at_g = true;

  for (; rep.iterations < o.max_iter; ++rep.iterations) {
    if (resid <= o.rtol) {
      rep.status = Status::Converged;
      break;
    }
    if (need_jacobian) {
      // weighted Jacobian d((F(g)-G_exp)/G_exp)/dx = D_{1/G_exp} D_G S D_G^-1 D_{dg/dx}
      scaled_hadamard(s.net, s.Gm, s.S, /*lower_only=*/false);
      dparam = log_param ? Eigen::VectorXd(g) : Eigen::VectorXd::Ones(n);
      Jw.noalias() = (s.Gm.array() / G_exp.array()).matrix().asDiagonal() * s.S *
                     (dparam.array() / s.Gm.array()).matrix().asDiagonal();
      A.setZero();
      A.selfadjointView<Eigen::Lower>().rankUpdate(Jw.transpose());
      A.triangularView<Eigen::StrictlyUpper>() = A.transpose();
      grad.noalias() = Jw.transpose() * (s.ra.array() / G_exp.array()).matrix();
      // bound constraints: a variable at its floor whose gradient pushes it down stays there
      fixed = Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(n, false);
      if (!log_param) fixed = (g.array() <= o.g_floor * (1 + 1e-9)) && (grad.array() > 0);
      need_jacobian = false;
      const double gfree = fixed.select(0.0, grad.array()).abs().maxCoeff();
      if (gfree <= 1e-12 * std::sqrt(2.0 * cost)) {  // stationary point of the cost
        rep.status = Status::LeastSquares;
        break;
      }
    }
    s.S = A;
    s.S.diagonal().array() += lambda * A.diagonal().array().max(1e-300);
    d = -grad;
    for (Index b = 0; b < n; ++b) {
      if (fixed[b]) {
        s.S.row(b).setZero();
        s.S.col(b).setZero();
        s.S(b, b) = 1.0;
        d[b] = 0.0;
      }
    }
    s.llt.compute(s.S);
    ++rep.factorizations;
    if (s.llt.info() != Eigen::Success) {
      lambda *= 10.0;
      continue;
    }
    s.llt.solveInPlace(d);
    if (log_param) {
      const double m = d.cwiseAbs().maxCoeff();
      if (m > o.max_log_step) d *= o.max_log_step / m;
      gt = (g.array() * d.array().exp()).max(o.g_floor).matrix();
    } else {
      gt = (g + d).cwiseMax(o.g_floor);
      d = gt - g;  // the projected step
    }
    const double predicted = -(grad.dot(d) + 0.5 * d.dot(A * d));
    double ct = 0, rt = 0;
    ++rep.evaluations;
    const bool ok = s.evaluate(gt, G_exp, ct, rt);
    at_g = false;
    if (ok && predicted > 0 && (cost - ct) > 1e-4 * predicted) {
      const double rel_decrease = (cost - ct) / cost;
      g = gt;
      cost = ct;
      resid = rt;
      at_g = true;
      need_jacobian = true;
      lambda = std::max(lambda / 3.0, 1e-12);
      if (rel_decrease < o.ftol && resid > o.rtol) {
        rep.status = Status::LeastSquares;
        ++rep.iterations;
        break;
      }
    } else {
      lambda *= 4.0;
      if (lambda > 1e16) {  // no decrease in any direction: a least-squares point
        rep.status = Status::LeastSquares;
        break;
      }
    }
  }
  if (!at_g) {
    ++rep.evaluations;
    s.evaluate(g, G_exp, cost, resid);
  }
  if (resid <= o.rtol) rep.status = Status::Converged;
  rep.at_bound = static_cast<int>((g.array() <= o.g_floor * (1.0 + 1e-9)).count());
  rep.cost = cost;
  rep.residual = resid;
  return rep;
}

}  // namespace psmat::iecm
