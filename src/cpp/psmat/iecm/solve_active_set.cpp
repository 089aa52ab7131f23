// Bounded IECM by a primal-dual active-set (semismooth Newton) method on the complementarity
// problem of SPEC §3 (the problem solve_bounded_newton.cpp states; unique solution):
//   g >= g_floor,   F(g) - G_exp >= 0,   (g - g_floor)(F(g) - G_exp) = 0   cell by cell.
//
// In the scaled variables a = (g - g_floor)/G_exp, b = (F(g) - G_exp)/G_exp the problem is
// min(a, b) = 0, and its semismooth Newton step (Hintermüller, Ito & Kunisch 2002) is
//   bound set  A = {a <= b}:  dg_A = g_floor - g_A                       (back to the bound)
//   free set   I = the rest:  J_II dg_I = -(F - G_exp)_I - J_IA dg_A    (F = G_exp, linearised)
// With J = D_G S D_G^-1 (jacobian.hpp) and dg = G∘y the free block is the SPD system
//   (S_II + mu I) y_I = -(F - G_exp)_I / G_I - S_IA y_A      (mu: a Levenberg term, below)
// solved by PCG with the matrix-free product of S and a float32 factor of the free block as
// preconditioner (FreeBlockSolver, active_set.hpp). The factor is rebuilt whenever the free set
// changed and kept while only the point moves (or until PCG slows down): rebuilding it is
// cheaper than the extra matrix-free products a stale factor costs. Measured (CPU time on one
// core, noisy bench frames, frames/s; 16x16 x 2000, 32x32 x 200, 64x64 x 4), keeping the factor
// until the free set differs by more than (10 + RC/64)/2 cells: 660 / 62 / 1.9; rebuilding on
// any change: 865 / 77 / 2.7; on every iteration: 901 / 76 / 2.5 (PCG then takes 1.1 steps). The bound set is read off the current
// iterate, so a warm start from the previous frame starts from its bound set, and a step moves
// any number of cells into or out of it (the noise re-draws the quiet cells every frame).
// Unlike the Fischer-Burmeister Newton, which linearises a smoothed function and damps the
// cells near the kink, the step is exact on every cell whose side of the kink is right:
// superlinear convergence once the bound set is found (quadratic for mu = O(|phi|^2)).
//
// Globalisation: the Levenberg term and Armijo backtracking (halving) on the Fischer-Burmeister
// merit 0.5|phi|^2 (the residual both solvers report), non-monotone over the last 3 merits for
// the first 15 iterations (constants below). The active-set step is not always a descent
// direction of that merit; when no step length is accepted the frame is finished by
// solve_bounded_newton from the current iterate, whose Fischer-Burmeister step always is (the
// solution is the same, unique one).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "psmat/iecm/active_set.hpp"
#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

namespace {
// Fischer-Burmeister phi = sqrt(a^2 + b^2) - a - b for the current evaluation state of s;
// returns 0.5*|phi|^2 and the largest |phi| in worst.
double fb_merit(const Solver& s, const ConstVecRef& g, const ConstVecRef& G_exp, double fl,
                double& worst) {
  double m = 0;
  worst = 0;
  for (Index c = 0; c < g.size(); ++c) {
    const double a = (g[c] - fl) / G_exp[c], b = s.ra[c] / G_exp[c];
    const double phi = std::sqrt(a * a + b * b) - a - b;
    m += 0.5 * phi * phi;
    worst = std::max(worst, std::abs(phi));
  }
  return m;
}
// Levenberg term mu = kLevenberg * max|phi|^2 on the diagonal of S_II (unit diagonal). Quiet
// cells of quiet rows are nearly interchangeable (moving conductance between two of them barely
// changes any G: eigenvalues of S_II down to ~3e-4 on noisy 16x16 twin frames), and the plain
// step moves them far along those directions, so that the line search cut the first steps to
// t ~ 1e-3. mu -> 0 fast enough keeps the local convergence quadratic. Measured on 300 noisy
// 16x16 twin frames (iterations / forward evaluations per frame): no term 16.8 / 86;
// 0.1 |phi| 14.9 / 47; 1 |phi| 17.6 / 48; 0.1 |phi|^2 14.0 / 48; 1 |phi|^2 13.0 / 38.
constexpr double kLevenberg = 1.0;
// Non-monotone Armijo reference: the largest merit of the last kMemory iterates (Grippo,
// Lampariello & Lucidi 1986), plain monotone after kMonotoneAfter iterations (the active-set
// step is not a descent direction of the merit, so a longer memory can cycle: memory 4-8 left
// frames at 100 iterations). Measured (iterations / forward evaluations per frame, max
// iterations): 300 noisy 16x16 bench frames, monotone 13.0 / 37.9 / 33, memory 3 12.5 / 20.8 /
// 33; 1000 frames of a simulated study session (172 of 256 cells at the bound) 18.9 / 81.8 / 53
// and 15.7 / 29.3 / 45; 64x64 (4 frames) 29.5 / 100 and 38.5 / 104.
// Where whole quiet rows carry the same (open-floor) reading, two free sets can alternate, each
// full step accepted against the memory; going monotone ends that. Measured by when (mean / p99 /
// max iterations): 100 000 noisy 16x16 twin frames (10 streams) after 30: 12.56 / 33 / 50, after
// 15: 12.24 / 25 / 43 (30 000 frames: after 10 12.07 / 24 / 37, after 5 12.84 / 25 / 37); one
// 6 000-frame study session after 30: 15.4 / - / 61 at 815 frames/s, after 15: 14.9 / 33 / 51 at
// 870, after 10: 16.0 / 37 / 54 at 746 (46 evaluations a frame instead of 30).
constexpr int kMemory = 3;
constexpr int kMonotoneAfter = 15;
}  // namespace

SolveReport solve_active_set(Solver& s, const ConstVecRef& G_exp, VecRef g) {
  const SolveOptions& o = s.options();
  const Index n = s.shape().cells();
  const double fl = o.g_floor;
  const int kmax = o.krylov_max_iter > 0 ? o.krylov_max_iter : 10 + static_cast<int>(n / 64);
  SolveReport rep;
  g = g.cwiseMax(fl);
  double cost = 0, resid = 0;
  if (!s.evaluate(g, G_exp, cost, resid)) {
    rep.status = Status::Singular;
    return rep;
  }
  rep.evaluations = 1;

  std::vector<Index> free_cells;
  free_cells.reserve(static_cast<size_t>(n));
  Eigen::VectorXd y(n), yA(n), SyA(n), b(n), dg(n), gt(n), g_prev(n);
  double merit = fb_merit(s, g, G_exp, fl, resid);
  bool handed_over = false;
  double history[kMemory];  // the last merits, for the non-monotone Armijo reference
  for (;; ++rep.iterations) {
    history[rep.iterations % kMemory] = merit;
    double ref = merit;
    if (rep.iterations < kMonotoneAfter)
      for (int k = 0; k < std::min(rep.iterations + 1, kMemory); ++k) ref = std::max(ref, history[k]);
    if (resid <= o.rtol) {
      rep.status = Status::Converged;
      break;
    }
    if (rep.iterations >= o.max_iter) {
      rep.status = Status::MaxIterations;
      break;
    }
    // the bound set of the current iterate: a <= b (a, b scaled by the same G_exp > 0)
    free_cells.clear();
    yA.setZero();
    bool moved = false;  // bound-set cells not yet at the bound
    for (Index c = 0; c < n; ++c) {
      if (g[c] - fl <= s.ra[c]) {
        if (g[c] > fl) {
          yA[c] = (fl - g[c]) / s.Gm[c];
          moved = true;
        }
      } else {
        free_cells.push_back(c);
      }
    }
    y = yA;
    if (!free_cells.empty()) {
      // b_I = -(F - G_exp)_I / G_I - (S_IA y_A)_I
      if (moved) s.op.apply(s.net, s.Gm, yA, SyA);
      for (Index c : free_cells) b[c] = -s.ra[c] / s.Gm[c] - (moved ? SyA[c] : 0.0);
      const double mu = kLevenberg * resid * resid;
      const double tol = std::max(1e-10, std::min(1e-2, 0.1 * resid));  // inexact Newton
      FreeBlockSolver& fs = s.free_block;
      bool fresh = false;
      if (!fs.has_factor() || fs.changes(free_cells) > 0) {  // a new free set: refactor
        if (!fs.factor(s.net, s.Gm, free_cells, mu)) {
          rep.status = Status::Singular;
          break;
        }
        ++rep.factorizations;
        fresh = true;
      }
      int k = fs.solve(s.op, s.net, s.Gm, free_cells, mu, b, dg, tol, kmax);
      rep.krylov_iterations += k > 0 ? k : kmax;
      if (k < 0 && !fresh) {  // a stale factor: rebuild it here and solve again
        if (!fs.factor(s.net, s.Gm, free_cells, mu)) {
          rep.status = Status::Singular;
          break;
        }
        ++rep.factorizations;
        k = fs.solve(s.op, s.net, s.Gm, free_cells, mu, b, dg, tol, 4 * kmax);
        rep.krylov_iterations += k > 0 ? k : 4 * kmax;
      }
      for (Index c : free_cells) y[c] = dg[c];
    }
    dg = s.Gm.cwiseProduct(y);

    // backtracking by halving (a quadratic model of the merit with the Newton slope -2*merit
    // cut the steps too far: 24 iterations per frame instead of 13, the step is not a Newton
    // step of that merit)
    bool accepted = false;
    g_prev = g;
    double t = 1.0;
    for (int k = 0; k < 40; ++k) {
      gt = (g_prev + t * dg).cwiseMax(fl);
      ++rep.evaluations;
      double m = std::numeric_limits<double>::infinity(), worst = 0;
      if (s.evaluate(gt, G_exp, cost, resid)) m = fb_merit(s, gt, G_exp, fl, worst);
      if (m <= ref - 1e-4 * t * merit) {  // Armijo against the (non-monotone) reference
        g = gt;
        merit = m;
        resid = worst;
        accepted = true;
        break;
      }
      t *= 0.5;
    }
    if (!accepted) {
      handed_over = true;
      break;
    }
  }
  if (handed_over) {  // the Fischer-Burmeister Newton finishes from the current iterate
    SolveReport fb = solve_bounded_newton(s, G_exp, g);
    fb.iterations += rep.iterations;
    fb.factorizations += rep.factorizations;
    fb.krylov_iterations += rep.krylov_iterations;
    fb.evaluations += rep.evaluations;
    fb.used_fallback = true;
    return fb;
  }
  rep.at_bound = static_cast<int>((g.array() <= fl * (1.0 + 1e-9)).count());
  if (rep.status == Status::Converged && rep.at_bound > 0) rep.status = Status::Bounded;
  rep.cost = 0.5 * (s.ra.array() / G_exp.array()).square().sum();
  rep.residual = resid;
  return rep;
}

}  // namespace psmat::iecm
