// Bounded IECM as a nonlinear complementarity problem (SPEC §3 "g >= 0"):
//   g >= g_floor,   F(g) - G_exp >= 0 where g = g_floor,   F(g) = G_exp elsewhere.
// A cell held at the bound is one that even when empty makes the model over-predict its
// measured G (typical of quiet background cells under noise). Because dG/dg = D_G S D_G^-1
// with S SPD, every principal submatrix of J has positive determinant (J is a P-matrix), so
// the problem has a unique solution; the Newton step on the free cells F is
//   S_FF y = -(F(g) - G_exp)_F / G_F,   dg_F = G_F ∘ y                (a Cholesky of S_FF)
// with projected steps and a backtracking line search on 0.5*sum_F ((F(g)-G_exp)/G_exp)^2.
#include <cmath>
#include <limits>
#include <vector>

#include "psmat/iecm/jacobian.hpp"
#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

SolveReport solve_bounded_newton(Solver& s, const ConstVecRef& G_exp, VecRef g) {
  const SolveOptions& o = s.options();
  const Index n = s.shape().cells();
  SolveReport rep;
  g = g.cwiseMax(o.g_floor);
  const double at_floor = o.g_floor * (1.0 + 1e-9);

  double cost = 0, resid = 0;
  if (!s.evaluate(g, G_exp, cost, resid)) {
    rep.status = Status::Singular;
    return rep;
  }
  rep.evaluations = 1;
  std::vector<Index> free_idx;
  free_idx.reserve(static_cast<size_t>(n));
  Eigen::VectorXd gt(n), y, dg;
  Eigen::MatrixXd Sf;
  Eigen::LLT<Eigen::MatrixXd> llt;
  // merit over the cells that are not held at the bound
  auto merit = [&](const Eigen::VectorXd& ra, double& worst) {
    double m = 0;
    worst = 0;
    for (Index a : free_idx) {
      const double r = ra[a] / G_exp[a];
      m += 0.5 * r * r;
      worst = std::max(worst, std::abs(r));
    }
    return m;
  };

  for (;; ++rep.iterations) {
    // active set: cells at the floor where the model already reaches the measurement
    free_idx.clear();
    for (Index a = 0; a < n; ++a)
      if (!(g[a] <= at_floor && s.ra[a] >= 0)) free_idx.push_back(a);
    const Index nf = static_cast<Index>(free_idx.size());
    double phi = merit(s.ra, resid);
    if (resid <= o.rtol) {
      rep.status = nf == n ? Status::Converged : Status::Bounded;
      break;
    }
    if (rep.iterations >= o.max_iter) {
      rep.status = Status::MaxIterations;
      break;
    }
    scaled_hadamard(s.net, s.Gm, s.S, /*lower_only=*/true);
    Sf.resize(nf, nf);
    for (Index c = 0; c < nf; ++c)
      for (Index r = c; r < nf; ++r) {
        const Index a = free_idx[r], b = free_idx[c];
        Sf(r, c) = a >= b ? s.S(a, b) : s.S(b, a);  // lower triangle of S holds (max, min)
      }
    llt.compute(Sf);
    ++rep.factorizations;
    if (llt.info() != Eigen::Success) {
      rep.status = Status::Singular;
      break;
    }
    y.resize(nf);
    for (Index k = 0; k < nf; ++k) y[k] = -s.ra[free_idx[k]] / s.Gm[free_idx[k]];
    llt.solveInPlace(y);
    dg.resize(nf);
    for (Index k = 0; k < nf; ++k) dg[k] = s.Gm[free_idx[k]] * y[k];

    bool accepted = false;
    double t = 1.0;
    Eigen::VectorXd g_prev = g;
    for (int k = 0; k < 40; ++k, t *= 0.5) {
      gt = g_prev;
      for (Index j = 0; j < nf; ++j) {
        const Index a = free_idx[j];
        gt[a] = std::max(g_prev[a] + t * dg[j], o.g_floor);  // projected step
      }
      double ct = 0, rt = 0, worst = 0;
      ++rep.evaluations;
      if (!s.evaluate(gt, G_exp, ct, rt)) continue;
      const double phi_t = merit(s.ra, worst);
      if (phi_t <= (1.0 - 2e-4 * t) * phi) {
        g = gt;
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      s.evaluate(g, G_exp, cost, resid);
      ++rep.evaluations;
      rep.status = Status::Stalled;
      break;
    }
  }
  rep.at_bound = 0;
  for (Index a = 0; a < n; ++a) rep.at_bound += (g[a] <= at_floor) ? 1 : 0;
  s.evaluate(g, G_exp, cost, resid);  // state and diagnostics at the final g
  ++rep.evaluations;
  rep.cost = cost;
  // report the residual over the free cells (the bound cells over-predict by construction)
  double worst = 0;
  for (Index a = 0; a < n; ++a)
    if (!(g[a] <= at_floor && s.ra[a] >= 0)) worst = std::max(worst, std::abs(s.ra[a] / G_exp[a]));
  rep.residual = worst;
  return rep;
}

}  // namespace psmat::iecm
