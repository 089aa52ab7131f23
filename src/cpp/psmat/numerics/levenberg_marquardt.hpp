// Levenberg-Marquardt for a weighted least-squares problem min 0.5 |r(x)|^2: the one LM loop of
// the core, used by IECM's least squares (iecm/solve_lsq.cpp, thesis eq. 2.9: log g or
// g >= g_floor) and by every least-squares step of the QZPM inverse (qzpm/solve.cpp, eq.
// C.8-C.9: log cells and switches; the cells alone for given switches; and the variable
// projection on the switches, whose reduced problem supplies Kaufman's Jacobian and the
// geodesic acceleration hook below).
//
// Each iteration solves the Marquardt-damped normal equations
//   (A + lambda diag(A)) d = -grad,   A = Jw^T Jw,  grad = Jw^T r
// by Cholesky, with the variables the problem holds at a bound this iteration (fixed) taken out.
// A problem that provides acceleration() gets geodesic acceleration (Transtrum & Sethna): with
// r'' its second directional derivative of r along d, d2 solves the same damped system for
// -0.5 Jw^T r''; the step d + d2 is taken when |d2| <= accel_ratio |d| in the norm of diag(A),
// else lambda is raised as for a rejected step. The step is accepted when the cost decreases
// by more than accept_ratio of the decrease the linear model predicts (by anything when
// accept_ratio = 0, the model unused: an accelerated step's); lambda is then divided by
// lambda_down (down to lambda_min), else multiplied by lambda_up. Ends Converged
// (max |r_a| <= rtol), LeastSquares (a stationary point: projected gradient <= grad_tol |r|, a
// relative cost decrease below ftol, or no decrease for any lambda up to lambda_max), Stalled
// (the damped matrix not positive definite for any lambda up to lambda_max), MaxIterations or
// Singular (the start not evaluable). Every pass counts as an iteration, rejected ones included.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>

#include "psmat/solve_report.hpp"

namespace psmat::numerics {

struct LmSettings {
  int max_iter = 100;
  double rtol = 1e-10;        // Converged when max_a |r_a| <= rtol
  double ftol = 1e-14;        // LeastSquares when an accepted step lowers the cost by less, relatively
  double lambda0 = 1e-3;      // first damping, relative to diag(A)
  double lambda_down = 3.0;   // after an accepted step lambda /= lambda_down ...
  double lambda_min = 1e-12;  // ... down to lambda_min
  double grad_tol = 1e-12;    // LeastSquares when max |grad| over the free variables <= grad_tol |r|
  double lambda_up = 4.0;     // after a rejected step lambda *= lambda_up (failed Cholesky: 10)
  double lambda_max = 1e16;   // ... up to lambda_max
  double accept_ratio = 1e-4;  // accepted: cost decrease > accept_ratio x the predicted one
                               // (0: any decrease, whatever the linear model predicts)
  double accel_ratio = 0.75;   // geodesic acceleration taken when |d2| <= accel_ratio |d|
};

// Matrices and vectors of one solve, kept by the caller so that repeated solves do not allocate.
struct LmWork {
  Eigen::MatrixXd Jw, A, S;
  Eigen::VectorXd grad, d, xt, Jd, diag, d2, rpp;
  Eigen::Array<bool, Eigen::Dynamic, 1> fixed;
  Eigen::LLT<Eigen::MatrixXd> llt;
};

namespace detail {
template <class P, class = void>
struct has_acceleration : std::false_type {};
template <class P>
struct has_acceleration<P, std::void_t<decltype(std::declval<P&>().acceleration(
                               std::declval<const Eigen::VectorXd&>(),
                               std::declval<const Eigen::VectorXd&>(),
                               std::declval<const Eigen::VectorXd&>(),
                               std::declval<Eigen::VectorXd&>()))>> : std::true_type {};
}  // namespace detail

// Minimises 0.5 |r(x)|^2 from x (the result out). The problem provides
//   bool evaluate(const Eigen::VectorXd& x, double& cost, double& resid)
//       cost = 0.5 |r(x)|^2, resid = max_a |r_a|; false where r(x) is undefined;
//   const Eigen::VectorXd& jacobian(const Eigen::VectorXd& x, Eigen::MatrixXd& Jw)
//       Jw = dr/dx at x, the point of the last evaluate(); returns r there;
//   bool fix(const Eigen::VectorXd& x, const Eigen::VectorXd& grad,
//            Eigen::Array<bool, Eigen::Dynamic, 1>& fixed)
//       the variables held at their bound for this Jacobian: false when there are none (fixed
//       then unused), else true with fixed (size of x) marking them;
//   void step(const Eigen::VectorXd& x, Eigen::VectorXd& d, Eigen::VectorXd& xt)
//       the trial point of the step d (trust region, parameterisation, bounds); d may be
//       replaced by the step actually taken (a projected one), which the model then predicts;
// and optionally, for geodesic acceleration,
//   bool acceleration(const Eigen::VectorXd& x, const Eigen::VectorXd& d,
//                     const Eigen::VectorXd& Jd, Eigen::VectorXd& rpp)
//       rpp = the second directional derivative of r at x along d (Jd = Jw d given, for a
//       finite difference); false when there is none this time (the plain step is then taken).
//       It must leave the problem's evaluation state at x.
// Iterations, evaluations and factorisations are added to rep; its status, cost and residual
// are set (the residual and cost those of the final x).
template <class Problem>
void levenberg_marquardt(Problem& pb, Eigen::VectorXd& x, const LmSettings& st, SolveReport& rep,
                         LmWork& w) {
  double cost = 0, resid = 0;
  if (!pb.evaluate(x, cost, resid)) {
    rep.status = Status::Singular;
    return;
  }
  ++rep.evaluations;
  const Eigen::Index n = x.size();
  w.A.resize(n, n);
  double lambda = st.lambda0;
  bool need_jacobian = true, at_x = true;  // does the problem's evaluation state belong to x?
  bool any_fixed = false;
  rep.status = Status::MaxIterations;
  int it = 0;
  for (; it < st.max_iter; ++it) {
    if (resid <= st.rtol) {
      rep.status = Status::Converged;
      break;
    }
    if (need_jacobian) {
      const Eigen::VectorXd& r = pb.jacobian(x, w.Jw);
      w.A.setZero();
      w.A.template selfadjointView<Eigen::Lower>().rankUpdate(w.Jw.transpose());
      w.A.template triangularView<Eigen::StrictlyUpper>() = w.A.transpose();
      w.grad.noalias() = w.Jw.transpose() * r;
      any_fixed = pb.fix(x, w.grad, w.fixed);
      need_jacobian = false;
      const double gfree = any_fixed ? w.fixed.select(0.0, w.grad.array()).abs().maxCoeff()
                                     : w.grad.cwiseAbs().maxCoeff();
      if (gfree <= st.grad_tol * std::sqrt(2.0 * cost)) {  // stationary point of the cost
        rep.status = Status::LeastSquares;
        break;
      }
    }
    w.d = -w.grad;
    if (!any_fixed) {  // the damped matrix formed in A itself, whose diagonal is then restored
      w.diag = w.A.diagonal();
      w.A.diagonal().array() += lambda * w.diag.array().max(1e-300);
      w.llt.compute(w.A);
      w.A.diagonal() = w.diag;
    } else {  // a copy without the rows and columns of the fixed variables (identity there)
      w.S = w.A;
      w.S.diagonal().array() += lambda * w.A.diagonal().array().max(1e-300);
      for (Eigen::Index b = 0; b < n; ++b) {
        if (w.fixed[b]) {
          w.S.row(b).setZero();
          w.S.col(b).setZero();
          w.S(b, b) = 1.0;
          w.d[b] = 0.0;
        }
      }
      w.llt.compute(w.S);
    }
    ++rep.factorizations;
    if (w.llt.info() != Eigen::Success) {
      lambda *= 10.0;
      if (lambda > st.lambda_max) {
        rep.status = Status::Stalled;
        break;
      }
      continue;
    }
    w.llt.solveInPlace(w.d);
    if constexpr (detail::has_acceleration<Problem>::value) {
      w.Jd.noalias() = w.Jw * w.d;
      if (pb.acceleration(x, w.d, w.Jd, w.rpp)) {
        w.d2.noalias() = w.Jw.transpose() * w.rpp;
        w.d2 *= -0.5;
        if (any_fixed) w.d2 = w.fixed.select(0.0, w.d2.array()).matrix();
        w.llt.solveInPlace(w.d2);
        if (!w.d2.allFinite()) w.d2.setZero();
        const auto scale = w.A.diagonal().array().max(1e-300).sqrt();
        const double n1 = (scale * w.d.array()).matrix().norm();
        const double n2 = (scale * w.d2.array()).matrix().norm();
        if (n2 > st.accel_ratio * n1) {  // the second-order term too large: a shorter step
          lambda *= st.lambda_up;
          if (lambda > st.lambda_max) {
            rep.status = Status::LeastSquares;
            break;
          }
          continue;
        }
        w.d += w.d2;
      }
    }
    pb.step(x, w.d, w.xt);
    w.Jd.noalias() = w.Jw * w.d;
    const double predicted = -(w.grad.dot(w.d) + 0.5 * w.Jd.squaredNorm());
    double ct = 0, rt = 0;
    ++rep.evaluations;
    const bool ok = pb.evaluate(w.xt, ct, rt);
    at_x = false;
    const bool decrease = st.accept_ratio > 0
                              ? predicted > 0 && (cost - ct) > st.accept_ratio * predicted
                              : ct < cost;
    if (ok && decrease) {
      const double rel_decrease = (cost - ct) / cost;
      x = w.xt;
      cost = ct;
      resid = rt;
      at_x = true;
      need_jacobian = true;
      lambda = std::max(lambda / st.lambda_down, st.lambda_min);
      if (rel_decrease < st.ftol && resid > st.rtol) {
        rep.status = Status::LeastSquares;
        ++it;
        break;
      }
    } else {
      lambda *= st.lambda_up;
      if (lambda > st.lambda_max) {  // no decrease in any direction: a least-squares point
        rep.status = Status::LeastSquares;
        break;
      }
    }
  }
  rep.iterations += it;
  if (!at_x) {
    ++rep.evaluations;
    pb.evaluate(x, cost, resid);
  }
  if (resid <= st.rtol) rep.status = Status::Converged;
  rep.cost = cost;
  rep.residual = resid;
}

}  // namespace psmat::numerics
