// Bounded IECM as a nonlinear complementarity problem (docs/spec.md §3 "g >= 0"):
//   g >= g_floor,   F(g) - G_exp >= 0,   (g - g_floor)(F(g) - G_exp) = 0   cell by cell.
// A cell at the bound is one that even when empty makes the model over-predict its measured G
// (typical of quiet background cells under noise). Because dG/dg = D_G S D_G^-1 with S SPD,
// every principal submatrix of J has a positive determinant (J is a P-matrix), so the problem
// has a unique solution.
//
// Semismooth Newton on the Fischer-Burmeister reformulation (De Luca, Facchinei & Kanzow 1996;
// complementarity.hpp):
//   a = (g - g_floor)/G_exp,  b = (F(g) - G_exp)/G_exp,  phi = sqrt(a^2 + b^2) - a - b = 0,
// whose merit 0.5*|phi|^2 is continuously differentiable, so the Newton direction is a
// descent direction (slope -|phi|^2) and a plain Armijo line search globalises it. With
// alpha = da-part, beta = db-part of the generalised Jacobian (both in [-2, 0]) the Newton
// system  diag(alpha) dg + diag(beta) J dg = -phi∘G_exp  becomes, with dg = G∘y,
//   (S + diag(alpha/beta)) y = -phi∘G_exp / (beta∘G)           (SPD: alpha/beta >= 0)
// on the cells with beta < 0; a cell with beta = 0 (g at the bound, F > G) keeps dg = 0.
#include <cmath>
#include <limits>
#include <vector>

#include "psmat/iecm/complementarity.hpp"
#include "psmat/iecm/jacobian.hpp"
#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

SolveReport solve_bounded_newton(Solver& s, const ConstVecRef& G_exp, VecRef g) {
  const SolveOptions& o = s.options();
  const Index n = s.shape().cells();
  const double fl = o.g_floor;
  SolveReport rep;
  g = g.cwiseMax(fl);

  double cost = 0, resid = 0;
  if (!s.evaluate(g, G_exp, cost, resid)) {
    rep.status = Status::Singular;
    return rep;
  }
  rep.evaluations = 1;
  std::vector<Index> F;  // cells in the linear system (beta < 0)
  F.reserve(static_cast<size_t>(n));
  Eigen::VectorXd gt(n), dg(n), g_prev(n), y, rhs;
  Eigen::MatrixXd K;
  Eigen::LLT<Eigen::MatrixXd> llt;
  std::vector<FischerBurmeister> fb(static_cast<size_t>(n));
  auto S_at = [&](Index a, Index c) { return a >= c ? s.S(a, c) : s.S(c, a); };  // lower-stored

  double merit = fb_merit(g, s.ra, G_exp, fl, resid);
  // non-monotone line search (Grippo, Lampariello & Lucidi 1986): compare with the largest
  // merit of the last few iterations, so that full Newton steps that clamp a few cells at
  // the bound are not cut down to a linear rate
  double history[5];
  int hist_n = 0;
  for (;; ++rep.iterations) {
    history[hist_n++ % 5] = merit;
    double ref = 0;
    for (int k = 0; k < std::min(hist_n, 5); ++k) ref = std::max(ref, history[k]);
    if (resid <= o.rtol) {
      rep.status = Status::Converged;
      break;
    }
    if (rep.iterations >= o.max_iter) {
      rep.status = Status::MaxIterations;
      break;
    }
    F.clear();
    dg.setZero();
    for (Index c = 0; c < n; ++c) {
      fb[static_cast<size_t>(c)] = fischer_burmeister((g[c] - fl) / G_exp[c], s.ra[c] / G_exp[c]);
      if (fb[static_cast<size_t>(c)].beta < -1e-14) {
        F.push_back(c);
      } else {  // alpha dg = -phi G_exp (here phi ~ 0: the cell stays at the bound)
        dg[c] = -fb[static_cast<size_t>(c)].phi * G_exp[c] / fb[static_cast<size_t>(c)].alpha;
      }
    }
    const Index nf = static_cast<Index>(F.size());
    scaled_hadamard(s.net, s.Gm, s.S, /*lower_only=*/true);
    K.resize(nf, nf);
    rhs.resize(nf);
    for (Index r = 0; r < nf; ++r) {
      const Index c = F[static_cast<size_t>(r)];
      const FischerBurmeister& f = fb[static_cast<size_t>(c)];
      double fixed = 0;  // coupling to the cells held fixed: (S D_G^-1 dg_fixed)_c
      if (nf < n)
        for (Index d = 0; d < n; ++d)
          if (dg[d] != 0.0) fixed += S_at(c, d) * dg[d] / s.Gm[d];
      rhs[r] = -f.phi * G_exp[c] / (f.beta * s.Gm[c]) - fixed;
      for (Index q = 0; q <= r; ++q) K(r, q) = S_at(c, F[static_cast<size_t>(q)]);
      K(r, r) += f.alpha / f.beta;
    }
    if (nf > 0) {
      llt.compute(K);
      ++rep.factorizations;
      if (llt.info() != Eigen::Success) {
        rep.status = Status::Singular;
        break;
      }
      y = llt.solve(rhs);
      for (Index r = 0; r < nf; ++r) {
        const Index c = F[static_cast<size_t>(r)];
        dg[c] = s.Gm[c] * y[r];
      }
    }

    bool accepted = false;
    g_prev = g;  // workspace: no allocation per iteration
    double t = 1.0;
    for (int k = 0; k < 40; ++k, t *= 0.5) {
      gt = (g_prev + t * dg).cwiseMax(fl);  // the network needs g >= g_floor > 0
      ++rep.evaluations;
      if (!s.evaluate(gt, G_exp, cost, resid)) continue;
      double worst = 0;
      const double m = fb_merit(gt, s.ra, G_exp, fl, worst);
      if (m <= ref - 4e-4 * t * merit) {  // Armijo against ref, slope -2*merit
        g = gt;
        merit = m;
        resid = worst;
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      ++rep.evaluations;
      s.evaluate(g, G_exp, cost, resid);
      fb_merit(g, s.ra, G_exp, fl, resid);
      rep.status = Status::Stalled;
      break;
    }
  }
  rep.at_bound = static_cast<int>((g.array() <= fl * (1.0 + 1e-9)).count());
  if (rep.status == Status::Converged && rep.at_bound > 0) rep.status = Status::Bounded;
  // state is that of g: report the cost of F(g) - G_exp over all cells and the
  // complementarity residual max |phi| (relative to G_exp)
  rep.cost = 0.5 * (s.ra.array() / G_exp.array()).square().sum();
  rep.residual = resid;
  return rep;
}

}  // namespace psmat::iecm
