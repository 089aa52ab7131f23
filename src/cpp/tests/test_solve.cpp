// The IECM inverse g = F^-1(G_exp) (docs/spec.md §3, thesis eq. 2.8-2.10): every method recovers known
// cell conductances from G = F(g) (round trips), including non-square arrays, the reference
// two-feet image from a cold start, and a strong-ghost configuration; warm starts pay off;
// the per-frame report tells the truth about the returned g.
#include <algorithm>
#include <cmath>
#include <string>

#include "psmat/iecm/solve.hpp"
#include "support.hpp"

using namespace psmat_test;
using psmat::iecm::Method;
using psmat::iecm::SolveOptions;
using psmat::iecm::SolveReport;
using psmat::iecm::Solver;
using psmat::iecm::Status;

namespace {

std::string name_of(Method m) { return psmat::iecm::to_string(m); }
std::string name_of(Status st) { return psmat::iecm::to_string(st); }

const Method kAllMethods[] = {Method::Newton, Method::ActiveSet, Method::BoundedNewton,
                              Method::LM, Method::BoundedLSQ, Method::FixedPoint};

// Bounds on the spectrum of J at g from physics alone: J >= 0 entrywise and J g = G (Euler,
// F is homogeneous of degree 1), so D_g^-1 J D_g is a nonnegative matrix with row sums
// G_a/g_a and, by Perron-Frobenius, min_a G_a/g_a <= lambda_max(J) <= max_a G_a/g_a.
double lambda_max_bound(Shape s, const VectorXd& g) { return (F(s, g).array() / g.array()).maxCoeff(); }

// Fixed point (eq. 2.10) g <- g - beta (F(g) - G) is a contraction near the solution iff
// 0 < beta < 2/lambda_max(J); beta = 1/(upper bound of lambda_max) is always safe. Its rate is
// 1 - beta*lambda_min per iteration, so it needs many more iterations than Newton (measured:
// ~700-2200 here vs 4-8) but reaches the same 1e-6 accuracy: no looser tolerance is needed.
SolveOptions options_for(Method m, Shape s, const VectorXd& g_true) {
  SolveOptions o;
  o.method = m;
  o.rtol = 1e-12;
  if (m == Method::FixedPoint) {
    o.beta = 1.0 / lambda_max_bound(s, g_true);
    o.max_iter = 200000;
  } else {
    o.max_iter = 200;
  }
  return o;
}

// The report must describe the g that was returned.
void check_report(Shape s, const VectorXd& G_exp, const VectorXd& g, const SolveReport& rep,
                  const SolveOptions& o) {
  CAPTURE(name_of(rep.status));
  CAPTURE(rep.residual);
  CAPTURE(rep.iterations);
  CAPTURE(rep.evaluations);
  CHECK(rep.evaluations >= rep.iterations);
  CHECK(rep.evaluations >= 1);
  CHECK(rep.factorizations >= 0);
  CHECK(rep.iterations <= o.max_iter + 1);
  if (rep.status == Status::Converged) CHECK(rep.residual <= o.rtol);
  if (rep.residual <= o.rtol) CHECK(rep.converged());
  if (rep.status == Status::Singular) CHECK_FALSE(rep.converged());
  if (rep.status == Status::MaxIterations || rep.status == Status::Stalled) CHECK_FALSE(rep.converged());
  if (o.method == Method::FixedPoint) CHECK(rep.factorizations == 0);
  if (rep.status != Status::Singular) {
    REQUIRE(g.allFinite());
    CHECK(g.minCoeff() >= o.g_floor * (1 - 1e-12));
    const VectorXd rel = ((F(s, g) - G_exp).array() / G_exp.array()).matrix();
    const double cost = 0.5 * rel.squaredNorm();
    CHECK(std::abs(rep.cost - cost) <= 1e-6 * cost + 1e-30);
    const double floor = o.g_floor * (1.0 + 1e-9);
    int at_floor = 0;
    double resid = 0;  // max over all cells (SolveReport::residual as documented) ...
    double resid_free = 0;  // ... and over the cells not held at the bound (Status::Bounded)
    double resid_fb = 0;    // complementarity residual max |phi| (BoundedNewton, any status)
    for (Index a = 0; a < g.size(); ++a) {
      const bool held = g[a] <= floor && rel[a] >= 0;
      at_floor += g[a] <= floor ? 1 : 0;
      resid = std::max(resid, std::abs(rel[a]));
      if (!held) resid_free = std::max(resid_free, std::abs(rel[a]));
      const double fa = (g[a] - o.g_floor) / G_exp[a], fb = rel[a];  // Fischer-Burmeister
      resid_fb = std::max(resid_fb, std::abs(std::hypot(fa, fb) - fa - fb));
    }
    if (o.method == Method::BoundedNewton || o.method == Method::ActiveSet ||
        o.method == Method::BoundedLSQ) {
      // SolveReport::at_bound: "cells held at g_floor (bounded methods)"
      CHECK(rep.at_bound == at_floor);
    }
    if (rep.status == Status::Bounded) {
      // complementarity (solve_options.hpp): F(g) = G_exp on the free cells, the others at
      // g_floor and over-predicting G_exp. The report's residual covers the free cells only.
      CHECK(at_floor > 0);
      CHECK(rep.at_bound == at_floor);
      CHECK(resid_free <= o.rtol);
      CHECK(std::abs(rep.residual - resid_free) <= 1e-6 * resid_free + 1e-15);
    } else if (o.method == Method::BoundedNewton || o.method == Method::ActiveSet ||
               rep.used_fallback) {
      // solve_options.hpp: the bounded solvers report the complementarity residual
      CHECK(std::abs(rep.residual - resid_fb) <= 1e-6 * resid_fb + 1e-15);
    } else {
      CHECK(std::abs(rep.residual - resid) <= 1e-6 * resid + 1e-15);
    }
  }
}

struct Outcome {
  VectorXd g;
  SolveReport rep;
};

Outcome solve_cold(Shape s, const VectorXd& G, const SolveOptions& o) {
  Solver solver(s, o);
  Outcome out{VectorXd(s.cells()), {}};
  out.rep = solver.solve(G, out.g, /*warm=*/false);
  check_report(s, G, out.g, out.rep, o);
  return out;
}

}  // namespace

// doctest::Approx(x).epsilon(e) alone allows e·(1 + |x|), an absolute tolerance for small x;
// .scale(1e-300) makes it relative (e·|x|), which is what the small conductances here need.

TEST_CASE("solve: every method recovers random arrays, square and non-square") {
  unsigned seed = 1000;
  for (Shape s : {Shape{4, 4}, Shape{3, 5}, Shape{2, 7}}) {
    const VectorXd g_true = random_g(s, seed++);
    const VectorXd G = F(s, g_true);
    for (Method m : kAllMethods) {
      CAPTURE(s.rows);
      CAPTURE(s.cols);
      CAPTURE(name_of(m));
      const SolveOptions o = options_for(m, s, g_true);
      const Outcome r = solve_cold(s, G, o);
      const double err = max_rel_err(r.g, g_true);
      CAPTURE(err);
      CAPTURE(r.rep.iterations);
      CHECK(r.rep.converged());
      CHECK(err < 1e-6);
      MESSAGE(s.rows << "x" << s.cols << " " << name_of(m) << " it=" << r.rep.iterations
                     << " fact=" << r.rep.factorizations << " ev=" << r.rep.evaluations
                     << " err=" << err << " beta=" << o.beta);
    }
  }
}

TEST_CASE("solve: Newton from a cold start on the reference two-feet image") {
  // G comes from the independent reference implementation, not from our forward model.
  const auto cases = load_forward_reference();
  const RefCase& c = find_case(cases, "16x16_feet");
  SolveOptions o;  // library defaults
  const Outcome r = solve_cold(c.shape, c.G, o);
  CAPTURE(name_of(r.rep.status));
  CAPTURE(r.rep.iterations);
  CAPTURE(r.rep.factorizations);
  CHECK(r.rep.status == Status::Converged);
  double worst = 0, worst_all = 0;
  int loaded = 0;
  for (Index a = 0; a < c.g.size(); ++a) {
    const double e = std::abs(r.g[a] - c.g[a]) / c.g[a];
    worst_all = std::max(worst_all, e);
    if (c.g[a] >= 1e-4) {
      worst = std::max(worst, e);
      ++loaded;
    }
  }
  CAPTURE(worst);
  CAPTURE(worst_all);
  CHECK(loaded > 20);  // the image has feet: enough loaded cells for the check to mean something
  CHECK(worst < 1e-6);
  MESSAGE("feet cold Newton: it=" << r.rep.iterations << " fact=" << r.rep.factorizations
                                  << " err(g>=1e-4)=" << worst << " err(all)=" << worst_all);
  // and the same for the random 16x16 reference case (cells 2e-5 .. 1e-2 S)
  const RefCase& d = find_case(cases, "16x16_random");
  const Outcome q = solve_cold(d.shape, d.G, o);
  CHECK(q.rep.status == Status::Converged);
  CHECK(max_rel_err(q.g, d.g) < 1e-6);
}

TEST_CASE("solve: strong ghost (three loaded corners of a 6x6, fourth corner empty)") {
  // 100 Ohm (1e-2 S) at three corners, 100 kOhm (1e-5 S) everywhere else, the fourth corner
  // (5,5) included. Through the loaded corners (5,0)-(0,0)-(0,5) the empty corner sees three
  // 100 Ohm cells in series: G(5,5) ~ 1e-2/3 S, a "ghost" ~300x its true conductance.
  const Shape s{6, 6};
  VectorXd g_true = VectorXd::Constant(36, 1e-5);
  g_true[0 * 6 + 0] = g_true[0 * 6 + 5] = g_true[5 * 6 + 0] = 1e-2;
  const VectorXd G = F(s, g_true);
  const Index ghost = 5 * 6 + 5;
  CHECK(G[ghost] / g_true[ghost] > 100.0);
  CHECK(G[ghost] == doctest::Approx(1e-2 / 3).epsilon(0.02).scale(1e-300));  // a tiny scale: a relative tolerance (doctest adds 1 by default)
  for (Method m : {Method::Newton, Method::BoundedNewton, Method::LM, Method::BoundedLSQ}) {
    CAPTURE(name_of(m));
    SolveOptions o = options_for(m, s, g_true);
    const Outcome r = solve_cold(s, G, o);
    CAPTURE(name_of(r.rep.status));
    CAPTURE(r.rep.iterations);
    CHECK(r.rep.converged());
    const double err = max_rel_err(r.g, g_true);
    CAPTURE(err);
    CHECK(err < 1e-6);
    CHECK(r.g[ghost] == doctest::Approx(1e-5).epsilon(1e-6).scale(1e-300));
    MESSAGE("ghost " << name_of(m) << " it=" << r.rep.iterations << " err=" << err);
  }
}

TEST_CASE("solve: a warm start from a nearby solution needs fewer iterations than cold") {
  const auto cases = load_forward_reference();
  const RefCase& c = find_case(cases, "16x16_feet");
  const Shape s = c.shape;
  // the next frame: every cell changes by up to 2 % (smooth in space, like a slow sway)
  VectorXd g2 = c.g;
  for (Index a = 0; a < g2.size(); ++a) g2[a] *= 1.0 + 0.02 * std::sin(0.37 * double(a));
  const VectorXd G1 = c.G, G2 = F(s, g2);
  // (LM is left out: from the previous frame it takes more iterations than cold — 17 vs 12
  // on this case — which is a performance observation, not a correctness property.)
  for (Method m : {Method::Newton, Method::ActiveSet, Method::BoundedNewton, Method::BoundedLSQ}) {
    CAPTURE(name_of(m));
    SolveOptions o;
    o.method = m;
    // cold
    const Outcome cold = solve_cold(s, G2, o);
    REQUIRE(cold.rep.converged());
    // warm, in the same Solver right after the previous frame (as BatchJob/StreamSolver do)
    Solver solver(s, o);
    VectorXd g(s.cells());
    REQUIRE(solver.solve(G1, g, false).converged());
    const SolveReport warm = solver.solve(G2, g, /*warm=*/true);
    check_report(s, G2, g, warm, o);
    // warm in a fresh Solver (no stored factorisation), from the previous frame's truth
    Solver fresh(s, o);
    VectorXd gf = c.g;
    const SolveReport warm_fresh = fresh.solve(G2, gf, /*warm=*/true);
    check_report(s, G2, gf, warm_fresh, o);
    CAPTURE(cold.rep.iterations);
    CAPTURE(warm.iterations);
    CAPTURE(warm_fresh.iterations);
    CHECK(warm.converged());
    CHECK(warm_fresh.converged());
    CHECK(warm.iterations < cold.rep.iterations);
    CHECK(warm_fresh.iterations < cold.rep.iterations);
    CHECK(warm.evaluations < cold.rep.evaluations);
    const VectorXd* solutions[] = {&g, &gf, &cold.g};
    for (const VectorXd* sol : solutions)
      for (Index a = 0; a < g2.size(); ++a)
        if (g2[a] >= 1e-4) CHECK(std::abs((*sol)[a] - g2[a]) <= 1e-6 * g2[a]);
    MESSAGE("warm " << name_of(m) << ": cold it=" << cold.rep.iterations << " fact="
                    << cold.rep.factorizations << " | warm it=" << warm.iterations << " fact="
                    << warm.factorizations << " | fresh warm it=" << warm_fresh.iterations);
  }
}

TEST_CASE("solve: a disconnected measurement (row of zeros) is reported as Singular") {
  const Shape s{4, 4};
  for (Index row : {Index(0), Index(2)})  // the ground row and another one
  for (Method m : kAllMethods) {
    VectorXd G = F(s, random_g(s, 1100));
    G.segment(row * 4, 4).setZero();
    CAPTURE(row);
    CAPTURE(name_of(m));
    SolveOptions o;
    o.method = m;
    Solver solver(s, o);
    VectorXd g(s.cells());
    const SolveReport rep = solver.solve(G, g, false);
    CAPTURE(name_of(rep.status));
    CHECK(rep.status == Status::Singular);
    CHECK_FALSE(rep.converged());
  }
}

TEST_CASE("solve: noisy G (no exact positive solution) still gives a sane, converged answer") {
  // 0.1 % Gaussian noise on the reference feet image: background cells (1e-6 S under ~1e-4 S
  // of crosstalk) cannot all be matched exactly by a g >= 0; the loaded cells still can.
  const auto cases = load_forward_reference();
  const RefCase& c = find_case(cases, "16x16_feet");
  const VectorXd noise = random_normal(c.shape.cells(), 1200);
  const VectorXd G = (c.G.array() * (1.0 + 1e-3 * noise.array())).matrix();
  // (LM on log g is left out: cells that touch g_floor stay there — the log-parameterised
  // Jacobian column is scaled by g — and it stalls at a cost ~1e5 x the bounded optimum.)
  for (Method m : {Method::Newton, Method::ActiveSet, Method::BoundedNewton, Method::BoundedLSQ}) {
    CAPTURE(name_of(m));
    SolveOptions o;
    o.method = m;
    o.max_iter = 2000;
    const Outcome r = solve_cold(c.shape, G, o);
    CAPTURE(name_of(r.rep.status));
    CAPTURE(r.rep.residual);
    CHECK(r.rep.converged());
    // loaded cells (>= 1e-3 S: under a foot) within 10 % (0.1 % noise on G is amplified by the
    // inverse, most at the edges of the feet; the thesis reports < 10 % above ~1e-4 S)
    double worst = 0;
    for (Index a = 0; a < c.g.size(); ++a)
      if (c.g[a] >= 1e-3) worst = std::max(worst, std::abs(r.g[a] - c.g[a]) / c.g[a]);
    CAPTURE(worst);
    CHECK(worst < 0.1);
    MESSAGE("noisy " << name_of(m) << " status=" << name_of(r.rep.status) << " it="
                     << r.rep.iterations << " resid=" << r.rep.residual << " at_bound="
                     << r.rep.at_bound << " fallback=" << r.rep.used_fallback << " err(g>=1e-3)=" << worst);
  }
}

TEST_CASE("solve: an iteration limit that is too small is reported, not hidden") {
  const Shape s{4, 4};
  const VectorXd g_true = random_g(s, 1300);
  const VectorXd G = F(s, g_true);
  for (Method m : kAllMethods) {
    CAPTURE(name_of(m));
    SolveOptions o = options_for(m, s, g_true);
    o.max_iter = 1;
    o.fallback = false;
    const Outcome r = solve_cold(s, G, o);  // check_report: fields describe the returned g
    CAPTURE(name_of(r.rep.status));
    CAPTURE(r.rep.residual);
    CHECK(r.rep.status == Status::MaxIterations);
    CHECK_FALSE(r.rep.converged());
    CHECK(r.rep.residual > o.rtol);
    CHECK(r.rep.iterations <= 1);
  }
}

TEST_CASE("solve: an exact starting point converges at once") {
  const Shape s{3, 5};
  const VectorXd g_true = random_g(s, 1400);
  const VectorXd G = F(s, g_true);
  for (Method m : kAllMethods) {
    CAPTURE(name_of(m));
    SolveOptions o = options_for(m, s, g_true);
    Solver solver(s, o);
    VectorXd g = g_true;
    const SolveReport rep = solver.solve(G, g, /*warm=*/true);
    check_report(s, G, g, rep, o);
    CHECK(rep.status == Status::Converged);
    CHECK(rep.iterations == 0);
    CHECK(max_rel_err(g, g_true) < 1e-12);
  }
}
