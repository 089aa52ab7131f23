// Least squares IECM (thesis eq. 2.9): minimise 0.5*sum(((F(g) - G_exp)/G_exp)^2), g > 0, by the
// core's Levenberg-Marquardt (numerics/levenberg_marquardt.hpp) with the analytic Jacobian
// (eq. 2.13) in one of two parameterisations:
//  * log_param: x = log g (positivity by construction, as the thesis' GSL implementation);
//  * bounded:   x = g with the bound g >= g_floor, projected steps, and the cells at the bound
//               whose gradient pushes them down held there (the thesis' scipy
//               `least_squares(bounds=(0, inf))` formulation).
// Reference methods "lm" and "bounded_lsq" (psmat.iecm.reference); on noisy G_exp, which no
// positive g reproduces exactly, the answer is a least-squares point (Status::LeastSquares).
// Newton's fallback for such frames is the complementarity solution instead (solve_active_set.cpp).
#include <algorithm>
#include <cmath>

#include "psmat/iecm/jacobian.hpp"
#include "psmat/iecm/solve.hpp"
#include "psmat/numerics/levenberg_marquardt.hpp"

namespace psmat::iecm {

namespace {
// The problem at the point g, with steps d in log g (log_param) or in g (bounded).
class LeastSquaresProblem {
 public:
  LeastSquaresProblem(Solver& s, const ConstVecRef& G_exp, bool log_param)
      : s_(s), G_exp_(G_exp), log_(log_param), o_(s.options()) {}

  bool evaluate(const Eigen::VectorXd& g, double& cost, double& resid) {
    return s_.evaluate(g, G_exp_, cost, resid);
  }
  // weighted Jacobian d((F(g)-G_exp)/G_exp)/dx = D_{1/G_exp} D_G S D_G^-1 D_{dg/dx} at the last
  // evaluated point (jacobian.hpp: J = D_G S D_G^-1; dg/dx = g for x = log g), formed in place
  // of S
  const Eigen::VectorXd& jacobian(const Eigen::VectorXd& g, Eigen::MatrixXd& Jw) {
    scaled_hadamard(s_.net, s_.Gm, Jw, /*lower_only=*/false);
    Jw.array().colwise() *= s_.Gm.array() / G_exp_.array();
    if (log_)
      Jw.array().rowwise() *= (g.array() / s_.Gm.array()).transpose();
    else
      Jw.array().rowwise() *= s_.Gm.array().inverse().transpose();
    r_ = (s_.ra.array() / G_exp_.array()).matrix();
    return r_;
  }
  // bounded: a cell at its floor whose gradient pushes it down stays there
  bool fix(const Eigen::VectorXd& g, const Eigen::VectorXd& grad,
           Eigen::Array<bool, Eigen::Dynamic, 1>& fixed) const {
    if (log_) return false;
    fixed = (g.array() <= o_.g_floor * (1 + 1e-9)) && (grad.array() > 0);
    return fixed.any();
  }
  void step(const Eigen::VectorXd& g, Eigen::VectorXd& d, Eigen::VectorXd& gt) const {
    if (log_) {  // the trust region |d log g| <= max_log_step, and g >= g_floor
      const double m = d.cwiseAbs().maxCoeff();
      if (m > o_.max_log_step) d *= o_.max_log_step / m;
      gt = (g.array() * d.array().exp()).max(o_.g_floor).matrix();
    } else {
      gt = (g + d).cwiseMax(o_.g_floor);
      d = gt - g;  // the projected step
    }
  }

 private:
  Solver& s_;
  const ConstVecRef& G_exp_;
  bool log_;
  const SolveOptions& o_;
  Eigen::VectorXd r_;  // weighted residual (F(g) - G_exp)/G_exp at the last Jacobian
};
}  // namespace

SolveReport solve_least_squares(Solver& s, const ConstVecRef& G_exp, VecRef g, bool log_param) {
  const SolveOptions& o = s.options();
  SolveReport rep;
  Eigen::VectorXd x = g.cwiseMax(o.g_floor);
  LeastSquaresProblem problem(s, G_exp, log_param);
  numerics::LmSettings st;  // lambda from 1e-3, divided by 3 down to 1e-12; gradient 1e-12 |r|
  st.max_iter = o.max_iter;
  st.rtol = o.rtol;
  st.ftol = o.ftol;
  numerics::LmWork work;
  numerics::levenberg_marquardt(problem, x, st, rep, work);
  g = x;
  if (rep.status != Status::Singular)
    rep.at_bound = static_cast<int>((g.array() <= o.g_floor * (1.0 + 1e-9)).count());
  return rep;
}

}  // namespace psmat::iecm
