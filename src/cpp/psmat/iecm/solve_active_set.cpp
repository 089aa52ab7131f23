// Bounded IECM for noisy frames: the complementarity problem of docs/spec.md §3 (the problem
// solve_bounded_newton.cpp states; unique solution)
//   g >= g_floor,   F(g) - G_exp >= 0,   (g - g_floor)(F(g) - G_exp) = 0   cell by cell,
// by sequential bound-constrained QPs (Josephy-Newton), each QP solved exactly by a primal-dual
// active-set method (Hintermüller, Ito & Kunisch 2002).
//
// Outer iteration at g: with J = D_G S D_G^-1 (jacobian.hpp; G = F(g)) and dg = G∘y, the
// linearised complementarity problem is the strictly convex QP (S is SPD where the problem is
// well posed, docs/spec.md §3)
//   min 0.5 y'S y + c'y   over   y >= lo,   c = (F(g) - G_exp)/G,   lo = (g_floor - g)/G.
// Its KKT conditions, y - lo >= 0, lambda = S y + c >= 0, (y - lo) lambda = 0, are min(a, b) = 0
// of the scaled variables a = (g - g_floor)/G_exp, b = (F - G_exp)/G_exp linearised, so the QP
// solution is the semismooth Newton step with the right bound set for this linearisation.
// Inner iteration (PDAS on the QP, S fixed): with the free set I, y_A = lo_A and
//   S_II y_I = -c_I - S_IA y_A
// solved by PCG with the matrix-free product of S and a float32 factor of S_II as
// preconditioner (FreeBlockSolver, free_block_solver.hpp); then I = {y - lo > lambda}
// (lambda_I = 0; at most a tenth of |I| freed per step, kFreeCap below), until I repeats. When
// I changes the factor is rebuilt, or updated cell by cell when few cells changed within one QP
// (kUpdateShare below); it is kept while the point moves by little (the last outer
// iterations: PCG on a factor of the previous point, kRefactorAbove). Free blocks of kSplitFrom
// cells or more are factorised split instead (core and fringe, kSplitFrom below): a new free set
// then costs a Cholesky of the fringe's part of the Schur complement, or an update of it when few
// fringe cells changed, not a refactorisation. The first free set of a frame is the PDAS rule at
// the starting point (for free blocks of kKeepFrom cells or more: the previous frame's final
// set); each QP starts from the previous QP's set.
//
// Why exact QPs: the plain PDAS step on the nonlinear problem (one linear solve per outer
// iteration, bound set read off the iterate) let the noise that re-draws the quiet cells each
// frame alternate the free set, and the line search cut its steps. Measured (noisy bench frames,
// CPU time on one core; iterations / forward evaluations / factorisations per frame):
//   16x16 (1000 frames)  plain PDAS 12.2 / 20.7 / 10.3, 864 frames/s;  QPs 4.3 / 5.4 / 6.8, 1416
//   32x32 (100 frames)   plain PDAS 17.9 / 39.4 / 15.6, 84 frames/s;   QPs 4.0 / 5.0 / 7.9, 162
// (The rates with everything below: 16x16 ~2100, 32x32 ~270, 64x64 ~17 frames/s; with the
// kernels of hadamard_kernel.hpp, laplacian.hpp's block inverse and the AVX2 sweeps of
// cholesky_sweep.hpp, one core of the shared machine: 16x16 ~3900, 32x32 ~400, 64x64 ~20.)
// Tried and not kept: a Levenberg term mu = |phi|^2 on the QP's diagonal (the plain PDAS step
// needed one; the QP is strictly convex without it): 16x16 946 instead of 1416 frames/s, 32x32
// 106 / 162 (more PCG steps on factors of another mu). Capping the inner iterations at 2-4
// (inexact QPs) brings the cycling back (16x16 at 3: 12.2 iterations, 42.6 evaluations, 447
// frames/s). Starting each frame's
// first QP from the previous frame's free set instead of the rule: before the cap on freed
// cells, at 64x64 the first inner step freed ~1 850 cells (a block of 2 700 to factorise);
// with everything below, 16x16 2083 instead of 2159 frames/s (6.0 factorisations instead of
// 4.9), 32x32 267 / 273, 64x64 16.7 / 16.9. Keeping the factor across small set changes and
// letting PCG absorb the changed cells (no update): slower at every threshold tried (2-32
// cells), PCG then needs more steps than a refactorisation costs. The inexact-Newton forcing
// 0.1 |phi| against 0.3, 1, 0.03, 0.01, 0.001 |phi| and 0.1 or 1 |phi|^0.5: within +-3 %.
//
// Globalisation: Armijo backtracking (halving) on the Fischer-Burmeister merit 0.5|phi|^2
// (complementarity.hpp; its max |phi| is the residual both solvers report); the full step is
// taken on nearly every bench frame. A warm start far from the frame gives way to the cold point
// g = G (kFarStart). When no step length is accepted the frame is finished by
// solve_bounded_newton from the current iterate, whose Fischer-Burmeister step always is a
// descent direction (the solution is the same, unique one).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "psmat/iecm/complementarity.hpp"
#include "psmat/iecm/free_block_solver.hpp"
#include "psmat/iecm/solve.hpp"

namespace psmat::iecm {

namespace {
// Inner PDAS iterations per QP before the step is taken as it stands (bench frames need up to
// 7 at 16x16 and 64x64).
constexpr int kInnerMax = 20;
// Cells freed per inner step, at most kFreeCap * |I|: the first PDAS step of a frame's QP frees
// every bound cell whose multiplier the noise made negative, most of which the next steps bind
// again, and the factorisation of that swollen block costs the most (at 64x64: 1 445 -> 1 959
// -> 1 484 -> ... -> 1 206 free cells; capped at 0.1: 1 418 -> 1 359 -> 1 357 -> ... -> 1 240).
// Measured (noisy bench frames, CPU time on one core, frames/s for cap none / 0.05 / 0.1 / 0.25):
// 16x16 1340 / 1380 / 1368 / 1291; 32x32 161 / 185 / 183 / 174; 64x64 9.7 / 12.8 / 12.7 / -;
// 0.01-0.02 leave too many for later steps (32x32: 157, 9.9 factorisations instead of 7.6).
constexpr double kFreeCap = 0.1;
// Within one QP (S fixed) a free set that changed in at most kUpdateShare * |I| cells updates
// the factor (FreeBlockSolver::update: a rank-1 update per cell that leaves, a new row per cell
// that joins) instead of refactorising. Only the factor of the same point: updating a factor of
// an earlier point costs more PCG steps than it saves. Measured (noisy bench frames, CPU time on
// one core, frames/s, factorisations per frame): no updates 16x16 1685 / 6.6, 64x64 13.8 / 7.8;
// share 0.1 1792 / 4.4 and 16.8 / 5.0; 0.15 1765 / 3.9 and 15.1 / 4.3 (each update costs
// O(|I|^2) with poorly vectorised Givens rotations); 0.1 on the factor of any point 1686 / 4.0
// (PCG 24 steps a frame instead of 21) and 17.9 / 4.0; 32x32: 213 frames/s without, 239-253.
constexpr double kUpdateShare = 0.1;
// ... and at most kUpdateMax cells: each changed cell costs a pass over the factor, memory-bound
// once the factor leaves the cache (a cold 64x64 frame, free blocks of ~4 000 cells, 64 MB:
// updates of ~300 cells made it 2.6 s instead of 2.0 s with at most 64 or 128 changed cells).
constexpr Index kUpdateMax = 128;
// A QP that starts at a residual (max |phi|) above kRefactorAbove refactorises even when its
// free set is the previous QP's: the step that led here was long (the first QP of a frame
// leaves ~0.1), and PCG on the factor of the previous point took 4.35 steps a solve where a
// new factor takes 1. Later QPs (residual ~2e-3, then ~2e-6) keep the factor. Measured (noisy
// bench frames, CPU time on one core, frames/s, 16x16 / 32x32 / 64x64): never 1798 / 238 /
// 17.6; above 1e-1 1900 / 252 / -; 1e-2 1954 / 268 / 17.7; 1e-3 1949 / 256 / 17.0; 1e-5 1935.
constexpr double kRefactorAbove = 1e-2;
// The four re-measured with the faster product and forward model (hadamard_kernel.hpp,
// laplacian.hpp; 16x16 noisy bench stream, one core, 254 us a frame as set): kRefactorAbove 1e-1
// 255 us (4.6 factorisations, 16.1 PCG steps), 1 268; kUpdateShare 0.2 269 (3.7
// factorisations: the updates cost more than they save), 0.3 306; kFreeCap 0.05 251, 0.2 268.
// Free blocks of at least kSplitFrom cells are factorised split (FreeBlockSolver::factor_split):
// the core, the free cells with g - g_floor > kCoreShare * max(g - g_floor), by a partial
// Cholesky, the rest of I (the fringe: quiet cells that the noise frees and binds) kept as the
// Schur complement of the core; a new free set of the same QP then costs the Cholesky of the
// fringe's part (select) instead of a refactorisation or Givens updates, with the core cells
// that left I (at most kCoreOutMax, else a new factor) as a capacitance correction. Noisy bench
// streams, one core (C++ driver), same iterations and residuals, ms a frame (factorisations a
// frame): 64x64 49.6-51.0 (4.9) -> 43.5-45.5 (2.0), 32x32 2.49 (4.8) -> 2.21 (2.0); kCoreShare
// 1e-2 45.4 / 2.23, 5e-2 48.5 / 2.36 (a larger fringe: dearer selects), 3e-3 worse (64x64 54
// against 46 in an earlier version: more core cells leave). 16x16 (free blocks ~100-150) is
// slower split (272 against 255 us a frame), kept whole. PCG: 15.6 steps a frame at 64x64
// against 14.1.
constexpr Index kSplitFrom = 200;
constexpr double kCoreShare = 2e-2;
constexpr Index kCoreOutMax = 128;
// Free blocks of at least kKeepFrom cells (64x64 noisy frames: ~1 200; 32x32: ~400) keep their
// split factor across QPs and frames: no refactorisation for a far point (kRefactorAbove does not
// apply; PCG takes more steps on the older factor, a new one is built when select() or PCG
// fails), each frame's first QP starts from the previous frame's final free set (Solver::
// last_free) instead of the PDAS rule, and a QP whose free set repeats an earlier one ends there
// (PCG on an older factor lets a cell near the threshold flip in and out). There a factorisation
// costs ~50 PCG steps and the fringe follows the noise by update_fringe(). Noisy bench streams,
// one core (C++ driver, back to back with the code before), ms a frame (factorisations, PCG steps
// a frame): 64x64 45.0-45.7 (2.0, 15.7) -> 31.7-32.4 (0.98, 29.7), iterations 4.0 -> 4.2 (at
// most 7). At 32x32 the same policy saved nothing (2.3-2.5 ms either way: a factor costs ~15
// PCG steps there), so the threshold leaves it and 16x16 as they were.
// Tried there and not kept: a diagonal shift to factorise the fringe when its rows come from
// several points (shifts of 1e-2 needed, PCG 107 steps a frame); the fringe preconditioned by
// its diagonal (PCG ~1 700 steps), or by a diagonal plus one rank-1 term per mat row and column
// (the structure of Z_JJ: cells of one quiet row or column couple at 0.25-1, others at ~4e-4),
// 15 PCG steps on Z_JJ alone against 1; the core and fringe blocks without their coupling, 78.
// Why a kept factor is still rebuilt about once a frame there: the fringe's Cholesky in select()
// fails (Z_JJ not positive definite: the rows of cells that joined later come from S at later
// points than W and L_CC). It failed at the frame's first new free set (the first PDAS step of its
// first QP, ~120 cells joining) in 39 of 40 frames, after computing their rows; so a factor from
// an earlier frame now serves that frame's first solve (the previous frame's final set) and is
// rebuilt at the first new set without trying select(): 64x64 20.6 -> 18.8 ms a frame (C++ driver,
// one core, back to back; the same iterations and PCG steps, 1.000 factorisations a frame against
// 0.975). Rebuilding it already for the first solve instead (the previous frame's set) was slower,
// 23.9 ms: that set's fringe lacks the ~120 cells of the first step, and every select joins them. Computing those rows at the factor's own point instead (select never
// failed) let the factor age over frames; PCG then stops just at its tolerance, the PDAS sets of
// a QP cycle and the steps are cut: 8.4 iterations a frame (at most 52), 219 ms a frame against
// 31. The same with a new factor at each frame's first QP: 37 ms (2.0 factorisations a frame).
// A fringe with room for every cell that joins (no compaction): 30-31 ms, the same.
constexpr Index kKeepFrom = 800;
// kFarStart: a frame far from its warm start (the previous frame's solution), such as the first
// frame of another stance or mat in one stream, used to stop the line search after a few steps; the
// Fischer-Burmeister Newton then finished it, slowly. So a warm start whose max |phi| exceeds 1,
// the bound at the cold point g = G (there a = 1 and b >= 0 since F(G) >= G, so -1 < phi <= 0), is
// compared with the cold point, and the frame starts from whichever has the smaller merit (one
// evaluation more, two when the warm start stays); consecutive frames stay under it (noisy 16x16
// study stream: max |phi| at the warm start 0.39 at the median, 0.88 at the 99.9th percentile).
// Measured (iecm.solve, rtol 1e-6, one thread): the 90 ordered pairs (last frame of one session,
// first frame of another) of a simulated study of 2 volunteers x 3 trials (seed 0-2): iterations at
// most 210 (4 pairs over 50) -> 7, factorisations at most 279 (mean 81) -> 20 (16), the pair's time
// at most 49.5 -> 5.0 ms; three sessions back to back (17 998 frames): the two first frames 84 and
// 10 iterations -> 5 and 5, every other frame the same iterations, at 32x32 (801 frames) and 64x64
// (60) every frame the same iterations and factorisations. Also tried: starting again from g = G
// where a warm-started frame's line search accepts no step (alone: at most 17 iterations on those
// pairs, 240 factorisations); beside the rule above it never acted there, so it was not kept.
// kWarmPcg: within one QP, a solve on a factor of an earlier point (the later QPs of a frame on
// the factor kept from its first, kKeepFrom) starts PCG from the previous solve's y on the new
// free set instead of 0 (a factor of this point needs one step from 0 anyway). Noisy 64x64 bench
// stream, C++ driver, one core, alternating: 18.3 / 18.2 / 18.2 -> 17.6 / 17.8 / 17.8 ms a frame,
// PCG steps 29.6 -> 24.4 a frame, and the QPs' more accurate multipliers cut the iterations to
// 4.00 a frame (at most 4) from 4.23 (at most 7); 16x16 and 32x32 unchanged (their factors are of
// the point where this applies).
// Also tried and not kept (C++ driver, one core, ms a frame, each against the code it was tried
// on): at 64x64, stopping a QP's PDAS steps once at most 0.5-2 % of the free set
// changes (inexact QPs: line searches fail, 42-67 against 21.6; only in the first QP, 29.6);
// freeing a cell in the first steps only below a multiplier margin (the same, 240-290); kFreeCap
// 0.15 / 0.2 (23.5 / 24.9 against 20.1); compacting the fringe whenever it holds over 1.15-1.5
// times its active cells (19.9-20.5 against 19.4: the dropped rows rejoin); the PDAS rule instead
// of the last frame's set for a kept factor's first QP (25.1 against 18.8: a larger first block);
// rescaling a factor of an earlier point by G_factor / G (S = D_G (T∘T) D_G; 19.8 against 18.7:
// the change of T∘T dominates). At 32x32: the previous frame's factor for the first QP instead of
// the refactorisation for a far point (2.16 against 1.84: its select fails on rows of another
// point; with rows at the factor's point the PDAS steps cycle, 2.21 with cycle detection), and
// no refactorisation after the first step (kRefactorAbove 0.3-100: 2.54-2.61 against 1.91, PCG
// 38 steps a frame against 14.8).
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
  double merit = fb_merit(g, s.ra, G_exp, fl, resid);
  // kFarStart: a start other than the cold point g = G, beyond that point's bound on max |phi|,
  // gives way to it when its merit is larger
  bool switched = false;
  if (resid > 1.0 && g != G_exp.cwiseMax(fl)) {
    Eigen::VectorXd g_cold = G_exp.cwiseMax(fl);
    double cost_cold = 0, resid_cold = 0;
    ++rep.evaluations;
    if (s.evaluate(g_cold, G_exp, cost_cold, resid_cold)) {
      const double merit_cold = fb_merit(g_cold, s.ra, G_exp, fl, resid_cold);
      if (merit_cold < merit) {
        g = g_cold;
        merit = merit_cold;
        resid = resid_cold;
        switched = true;
      }
    }
    if (!switched) {  // the warm start kept: its state again
      ++rep.evaluations;
      if (!s.evaluate(g, G_exp, cost, resid)) {
        rep.status = Status::Singular;
        return rep;
      }
      merit = fb_merit(g, s.ra, G_exp, fl, resid);
    }
  }

  std::vector<Index> free_cells, core, fringe;
  free_cells.reserve(static_cast<size_t>(n));
  // the free set of the QP, carried from one QP to the next; first guess: the PDAS rule at g
  std::vector<char> is_free(static_cast<size_t>(n));
  std::vector<double> lam_bound;  // negative multipliers of bound cells (the PDAS cap)
  // s.last_free: kept by the last frame only when its free set had kKeepFrom cells or more
  const bool keep = s.last_free.size() == static_cast<size_t>(n);
  if (keep && !switched)
    is_free = s.last_free;
  else
    for (Index c = 0; c < n; ++c) is_free[static_cast<size_t>(c)] = g[c] - fl > s.ra[c];
  std::vector<std::vector<char>> seen;  // free sets of the current QP (keep)
  // (dg zeroed: it is PCG's guess below, read only after a solve of the same QP wrote it)
  Eigen::VectorXd y(n), lo(n), qc(n), yA(n), yA_prev(n), SyA(n), Sy(n), b(n),
      dg = Eigen::VectorXd::Zero(n), gt(n), g_prev(n);
  bool handed_over = false;
  bool factored_this_frame = false;  // a factorisation at a point of this frame (keep)
  for (;; ++rep.iterations) {
    if (resid <= o.rtol) {
      rep.status = Status::Converged;
      break;
    }
    if (rep.iterations >= o.max_iter) {
      rep.status = Status::MaxIterations;
      break;
    }
    // the QP at g (header): lo = (g_floor - g)/G, c = (F - G_exp)/G = ra/Gm
    lo = (fl - g.array()) / s.Gm.array();
    qc = s.ra.array() / s.Gm.array();
    // inexact Newton: PCG to 0.1 |phi| relative, but no tighter than the last step needs: the
    // residual after a step is about eta |phi| + C |phi|^2, so eta = 0.1 rtol / |phi| ends the
    // frame as well (16x16: 14.2 PCG steps a frame instead of 16.2, the same 4.33 iterations)
    const double tol =
        std::max(1e-10, std::min(1e-2, std::max(0.1 * resid, 0.1 * o.rtol / resid)));
    FreeBlockSolver& fs = s.free_block;
    bool factor_here = false;  // the stored factor is of S at this point
    if (keep) seen.assign(1, is_free);
    bool solved = false;  // a solve of this QP left its y in dg (kWarmPcg's guess)
    for (int inner = 0;; ++inner) {
      // I and y_A = lo on the bound set, without branches on the (noise-drawn) pattern of I
      free_cells.resize(static_cast<size_t>(n));
      size_t n_free = 0;
      bool moved = false;  // bound-set cells not at the bound yet
      for (Index c = 0; c < n; ++c) {
        const bool f = is_free[static_cast<size_t>(c)];
        free_cells[n_free] = c;
        n_free += f;
        yA[c] = f ? 0.0 : lo[c];
        moved |= yA[c] != 0.0;
      }
      free_cells.resize(n_free);
      y = yA;
      // S y_A: unchanged within a QP while the same cells of lo != 0 are bound
      if (moved && !(inner > 0 && yA == yA_prev)) s.op.apply(s.net, s.Gm, yA, SyA);
      yA_prev = yA;
      if (!free_cells.empty()) {
        // b_I = -c_I - (S_IA y_A)_I
        for (Index c : free_cells) b[c] = -qc[c] - (moved ? SyA[c] : 0.0);
        bool fresh = false;
        // a new free set: the factor of this point updated cell by cell when few cells
        // changed, otherwise a new factorisation
        const Index changes = fs.changes(free_cells);
        const bool few = factor_here && changes <= kUpdateMax &&
                         static_cast<double>(changes) <=
                             kUpdateShare * static_cast<double>(free_cells.size());
        // the factor is of a far point
        const bool far = !keep && inner == 0 && resid > kRefactorAbove;
        // a split factor kept from an earlier frame (kKeepFrom) meets the frame's first new free
        // set: rebuilt without trying select() (kKeepFrom's comment)
        const bool earlier_frame = keep && !factored_this_frame && changes > 0;
        bool kept = false;
        if ((changes > 0 || far) && !far && !earlier_frame) {
          if (fs.is_split())
            kept = fs.core_outside(free_cells) <= kCoreOutMax && fs.select(s.net, s.Gm, free_cells);
          else
            kept = few && fs.update(s.net, s.Gm, free_cells);
        }
        if ((changes > 0 || far) && !kept) {
          bool ok;
          if (static_cast<Index>(free_cells.size()) >= kSplitFrom) {
            // core: the free cells well above the floor; fringe: the rest of I
            core.clear();
            fringe.clear();
            const double th = kCoreShare * (g.maxCoeff() - fl);
            for (Index c : free_cells) (g[c] - fl > th ? core : fringe).push_back(c);
            ok = fs.factor_split(s.net, s.Gm, core, fringe) && fs.select(s.net, s.Gm, free_cells);
            // (float round-off: the fringe's block not SPD) the whole block, with its shifts
            if (!ok) ok = fs.factor(s.net, s.Gm, free_cells);
          } else {
            ok = fs.factor(s.net, s.Gm, free_cells);
          }
          if (!ok) {
            rep.status = Status::Singular;  // ends the QP, then the frame (below)
            break;
          }
          ++rep.factorizations;
          fresh = true;
          factor_here = true;
          factored_this_frame = true;
        }
        // PCG on a factor of an earlier point starts from the last solve of this QP (kWarmPcg),
        // where there was one: an inner step whose free set was empty solved nothing (a cold
        // point whose PDAS rule frees no cell, kFarStart), and dg then holds no y of this QP
        const bool from_guess = solved && !fresh && !factor_here;
        int k = fs.solve(s.op, s.net, s.Gm, free_cells, b, dg, Sy, tol, kmax, from_guess);
        rep.krylov_iterations += k >= 0 ? k : kmax;
        if (k < 0 && !fresh) {  // a stale factor: rebuild it here and solve again
          if (!fs.factor(s.net, s.Gm, free_cells)) {
            rep.status = Status::Singular;  // ends the QP, then the frame (below)
            break;
          }
          ++rep.factorizations;
          factor_here = true;
          k = fs.solve(s.op, s.net, s.Gm, free_cells, b, dg, Sy, tol, 4 * kmax);
          rep.krylov_iterations += k > 0 ? k : 4 * kmax;
        }
        solved = true;
        for (Index c : free_cells) y[c] = dg[c];
        if (moved) Sy += SyA;  // S y = S y_I (from PCG) + S y_A
      } else if (moved) {
        Sy = SyA;
      } else {
        Sy.setZero();
      }
      if (inner + 1 >= kInnerMax) break;
      // PDAS rule of the QP: free where y - lo > lambda, lambda = S y + c (0 on I), with at most
      // kFreeCap * |I| (>= 8) cells freed per step: those of the most negative lambda (the
      // rest wait for the next step)
      Sy += qc;  // lambda
      lam_bound.resize(static_cast<size_t>(n));
      size_t n_neg = 0;
      for (Index c = 0; c < n; ++c) {
        lam_bound[n_neg] = Sy[c];
        n_neg += !is_free[static_cast<size_t>(c)] & (Sy[c] < 0.0);
      }
      lam_bound.resize(n_neg);
      double cut = 0.0;
      const size_t cap = std::max<size_t>(8, static_cast<size_t>(kFreeCap * free_cells.size()));
      if (lam_bound.size() > cap) {
        std::nth_element(lam_bound.begin(), lam_bound.begin() + static_cast<std::ptrdiff_t>(cap),
                         lam_bound.end());
        cut = lam_bound[cap];
      }
      int changed = 0;
      for (Index c = 0; c < n; ++c) {
        const size_t k = static_cast<size_t>(c);
        const bool stays = y[c] > lo[c], joins = Sy[c] < cut, was = is_free[k];
        const bool f = (was & stays) | (!was & joins);
        changed += f != was;
        is_free[k] = f;
      }
      if (changed == 0) break;
      if (keep) {  // a free set seen before in this QP: a cycle (kKeepFrom)
        if (std::find(seen.begin(), seen.end(), is_free) != seen.end()) break;
        seen.push_back(is_free);
      }
    }
    if (rep.status == Status::Singular) break;
    dg = s.Gm.cwiseProduct(y);

    // backtracking by halving on the Fischer-Burmeister merit (monotone Armijo)
    bool accepted = false;
    g_prev = g;
    double t = 1.0;
    for (int k = 0; k < 40; ++k) {
      gt = (g_prev + t * dg).cwiseMax(fl);
      ++rep.evaluations;
      double m = std::numeric_limits<double>::infinity(), worst = 0;
      if (s.evaluate(gt, G_exp, cost, resid)) m = fb_merit(gt, s.ra, G_exp, fl, worst);
      if (m <= merit - 1e-4 * t * merit) {
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
  if (static_cast<Index>(free_cells.size()) >= kKeepFrom)
    s.last_free = is_free;
  else
    s.last_free.clear();
  rep.at_bound = static_cast<int>((g.array() <= fl * (1.0 + 1e-9)).count());
  if (rep.status == Status::Converged && rep.at_bound > 0) rep.status = Status::Bounded;
  rep.cost = 0.5 * (s.ra.array() / G_exp.array()).square().sum();
  rep.residual = resid;
  return rep;
}

}  // namespace psmat::iecm
