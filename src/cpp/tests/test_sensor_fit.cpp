// Identification of the sensor model (docs/spec.md §4, thesis §2.5.1, eq. 2.26): the creep
// regression basis in closed form, SSE_N by hand, the separable least squares giving back the
// linear parameters of noise-free data exactly, and the simulated annealing on energies whose
// minimum is known. Data come from an independent plain implementation of the model
// (sensor_reference.hpp), never from the code under test.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "psmat/sensor/anneal.hpp"
#include "psmat/sensor/fit.hpp"
#include "psmat/sensor/separable.hpp"
#include "sensor_reference.hpp"

namespace sensor_fit_tests {

using Eigen::VectorXd;
using psmat::Index;
using psmat::RowMatrixXd;
using psmat::sensor::Experiment;
using psmat_sensor_test::RefModel;

VectorXd as_vec(const std::vector<double>& v) {
  return Eigen::Map<const VectorXd>(v.data(), static_cast<Index>(v.size()));
}

// theta = (rho, tau, a1, a2, a3, l_1..l_Nc, w_1..w_Nc) of a reference model
VectorXd theta_of(const RefModel& m) {
  const Index nc = static_cast<Index>(m.l.size());
  VectorXd th(5 + 2 * nc);
  th.head(5) << m.rho, m.tau, m.a1, m.a2, m.a3;
  for (Index j = 0; j < nc; ++j) {
    th[5 + j] = m.l[static_cast<size_t>(j)];
    th[5 + nc + j] = m.w[static_cast<size_t>(j)];
  }
  return th;
}

// The two experiments of thesis §2.5.1 (descending and ascending hysteresis, 2 Hz), shortened
// to `reps` repetitions, with the conductance of `truth` from rest (noise-free).
std::vector<Experiment> hysteresis_experiments(const RefModel& truth, int reps) {
  std::vector<Experiment> out;
  for (const std::vector<double>& p : {psmat_sensor_test::descending_protocol(reps),
                                       psmat_sensor_test::ascending_protocol(reps)}) {
    Experiment e;
    e.p = as_vec(p);
    e.g = as_vec(psmat_sensor_test::reference_direct(truth, p, 0.5));
    e.dt = 0.5;
    out.push_back(e);
  }
  return out;
}

TEST_CASE("creep_basis: from rest, a constant load gives P (1 - e^{-l k T}) per rate (eq. 2.23)") {
  const double P = 15.0, T = 0.5;
  const Index K = 300;
  VectorXd l(3);
  l << 0.05, 8.25e-4, 0.0;  // 1/s; l = 0 never moves
  RowMatrixXd Yc(K, 3);
  psmat::sensor::creep_basis(VectorXd::Constant(K, P), l, T, Yc);
  for (Index k = 0; k < K; ++k)
    for (Index j = 0; j < 3; ++j) {
      const double want = P * (1.0 - std::exp(-l[j] * static_cast<double>(k) * T));
      INFO("k = " << k << ", l = " << l[j]);
      CHECK(std::abs(Yc(k, j) - want) <= 1e-12 * P);
    }
}

TEST_CASE("sse_n_each and mean_sse_n: eq. 2.26 per experiment, averaged over experiments") {
  // g_exp = model + a constant 1e-5 S: SSE_N = 1e-10 S^2; g_exp = model -/+ 2e-5 S
  // alternating: SSE_N = 4e-10 S^2; their mean 2.5e-10 S^2.
  const RefModel t = psmat_sensor_test::table_2_11();
  const psmat::sensor::MPICreep m(psmat::sensor::params_from_theta(theta_of(t), 6, 32.0));
  std::vector<Experiment> ex = hysteresis_experiments(t, 1);
  ex[0].g.array() += 1e-5;
  for (Index k = 0; k < ex[1].g.size(); ++k) ex[1].g[k] += (k % 2 ? 2e-5 : -2e-5);
  const VectorXd each = psmat::sensor::sse_n_each(m, ex);
  REQUIRE(each.size() == 2);
  CHECK_CLOSE(each[0], 1e-10, 1e-6, 0.0);
  CHECK_CLOSE(each[1], 4e-10, 1e-6, 0.0);
  CHECK_CLOSE(psmat::sensor::mean_sse_n(m, ex), 2.5e-10, 1e-6, 0.0);
}

TEST_CASE("params_from_theta: theta = (rho, tau, a1, a2, a3, l.., w..); a malformed theta throws") {
  VectorXd th(9);
  th << 1, 2, 3, 4, 5, 6, 7, 8, 9;
  const psmat::sensor::MPICreepParams p = psmat::sensor::params_from_theta(th, 4, 20.0);
  CHECK(p.rho == 1);
  CHECK(p.tau == 2);
  CHECK(p.a1 == 3);
  CHECK(p.a2 == 4);
  CHECK(p.a3 == 5);
  CHECK(p.l == std::vector<double>{6, 7});
  CHECK(p.w == std::vector<double>{8, 9});
  CHECK(p.n_ops == 4);
  CHECK(p.p_max == 20.0);
  CHECK_THROWS_AS(psmat::sensor::params_from_theta(VectorXd::Zero(8), 6, 32.0),
                  std::invalid_argument);
  CHECK_THROWS_AS(psmat::sensor::params_from_theta(VectorXd::Zero(4), 6, 32.0),
                  std::invalid_argument);
}

TEST_CASE(
    "SeparableProblem: at the true (tau, l), noise-free data give back the linear parameters") {
  // Once tau and the l_j are fixed, g is linear in (a1, a2, a3, rho, w_j) (docs/spec.md §4):
  // the least-squares solution on noise-free data is the truth, with zero cost.
  const RefModel t = psmat_sensor_test::table_2_11();
  const psmat::sensor::SeparableProblem prob(hysteresis_experiments(t, 3), 6, 32.0, 2);
  CHECK(prob.n_nonlinear() == 3);
  CHECK(prob.n_linear() == 6);
  VectorXd z(3);
  z << t.tau, std::log10(t.l[0]), std::log10(t.l[1]);
  const psmat::sensor::SeparableProblem::Solution s = prob.solve(z);
  const VectorXd want = theta_of(t);
  REQUIRE(s.theta.size() == want.size());
  for (Index k = 0; k < want.size(); ++k) {
    INFO("theta[" << k << "] = " << s.theta[k] << ", true " << want[k]);
    CHECK(std::abs(s.theta[k] - want[k]) <= 1e-6 * std::abs(want[k]));
  }
  CHECK(s.cost <= 1e-24);  // S^2; the data are of order 1e-3 S
  CHECK(s.invertibility_problem.empty());

  SUBCASE("a wrong tau leaves a residual") {
    VectorXd zw = z;
    zw[0] *= 1.5;
    CHECK(prob.solve(zw).cost > 1e6 * std::max(s.cost, 1e-30));
  }
}

TEST_CASE("SeparableProblem::design: ||A c - b||^2 is the mean SSE_N (eq. 2.26) of the model c") {
  // Two experiments of different lengths, so the 1/sqrt(E N_e) row weights matter.
  const RefModel t = psmat_sensor_test::table_2_11();
  std::vector<Experiment> ex = hysteresis_experiments(t, 1);
  ex[1].p.conservativeResize(ex[1].p.size() / 3);
  ex[1].g.conservativeResize(ex[1].g.size() / 3);
  const psmat::sensor::SeparableProblem prob(ex, 6, 32.0, 2);
  VectorXd z(3);
  z << t.tau, std::log10(t.l[0]), std::log10(t.l[1]);
  Eigen::MatrixXd A;
  VectorXd b;
  prob.design(z, A, b);
  REQUIRE(A.rows() == ex[0].p.size() + ex[1].p.size());
  REQUIRE(A.cols() == 6);
  // another model with the same tau and l: every linear parameter off by a different factor
  RefModel other = t;
  other.a1 *= 1.10;
  other.a2 *= 0.95;
  other.a3 *= 1.02;
  other.rho *= 0.90;
  other.w = {t.w[0] * 1.3, t.w[1] * 0.7};
  VectorXd c(6);
  c << other.a1, other.a2, other.a3, other.rho, other.w[0], other.w[1];
  double mean = 0.0;
  for (const Experiment& e : ex) {
    const std::vector<double> p(e.p.data(), e.p.data() + e.p.size());
    const std::vector<double> g = psmat_sensor_test::reference_direct(other, p, e.dt);
    double sse = 0.0;
    for (size_t k = 0; k < g.size(); ++k)
      sse += (e.g[static_cast<Index>(k)] - g[k]) * (e.g[static_cast<Index>(k)] - g[k]);
    mean += sse / static_cast<double>(g.size()) / static_cast<double>(ex.size());
  }
  REQUIRE(mean > 0.0);
  CHECK_CLOSE((A * c - b).squaredNorm(), mean, 1e-9, 0.0);
}

TEST_CASE("anneal: finds the global minimum of a double well on a box") {
  // E(x) = (x0^2 - 1)^2 + 0.3 x0 + (x1 - 0.5)^2 on [-2, 2]^2: a shallow well near x0 = +0.96
  // (the start) and the global one near x0 = -1.04, where 4 x0^3 - 4 x0 + 0.3 = 0.
  double lo = -2.0, hi = -0.5;  // bisection for the global root, E' < 0 at -2 and > 0 at -0.5
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (4 * mid * mid * mid - 4 * mid + 0.3 < 0 ? lo : hi) = mid;
  }
  const double x0_star = 0.5 * (lo + hi);
  auto energy = [](const VectorXd& x) {
    return (x[0] * x[0] - 1) * (x[0] * x[0] - 1) + 0.3 * x[0] + (x[1] - 0.5) * (x[1] - 0.5);
  };
  int outside = 0;
  auto watched = [&](const VectorXd& x) {
    if ((x.array() < -2.0).any() || (x.array() > 2.0).any()) ++outside;
    return energy(x);
  };
  psmat::sensor::AnnealOptions o;
  o.max_evals = 6000;
  o.t0 = 1.0;
  o.t_end = 1e-4;
  o.seed = 3;
  std::atomic<int> progress{0};
  o.progress = &progress;
  const VectorXd start = (VectorXd(2) << 0.96, -1.5).finished();
  const VectorXd box_lo = VectorXd::Constant(2, -2.0), box_hi = VectorXd::Constant(2, 2.0);
  const psmat::sensor::AnnealResult r = psmat::sensor::anneal(watched, start, box_lo, box_hi, o);
  CHECK(outside == 0);
  CHECK(r.evaluations == o.max_evals);
  CHECK(progress.load() == o.max_evals);
  CHECK_CLOSE(r.x[0], x0_star, 0.0, 0.02);
  CHECK_CLOSE(r.x[1], 0.5, 0.0, 0.02);
  CHECK_CLOSE(r.energy, energy(r.x), 1e-15, 0.0);
  CHECK(r.energy < energy(start));

  SUBCASE("the same seed gives the same result; points of infinite energy are never kept") {
    o.progress = nullptr;
    const psmat::sensor::AnnealResult again =
        psmat::sensor::anneal(energy, start, box_lo, box_hi, o);
    CHECK(again.x == r.x);
    CHECK(again.energy == r.energy);
    auto walled = [&](const VectorXd& x) {  // the global well forbidden
      return x[0] < 0.0 ? std::numeric_limits<double>::infinity() : energy(x);
    };
    const psmat::sensor::AnnealResult w = psmat::sensor::anneal(walled, start, box_lo, box_hi, o);
    CHECK(w.x[0] >= 0.0);
    CHECK(std::isfinite(w.energy));
  }
}

TEST_CASE("anneal: bad options and boxes are rejected with std::invalid_argument") {
  auto e = [](const VectorXd& x) { return x.squaredNorm(); };
  const VectorXd x0 = VectorXd::Zero(2), lo = VectorXd::Constant(2, -1.0),
                 hi = VectorXd::Constant(2, 1.0);
  psmat::sensor::AnnealOptions o;
  o.max_evals = 10;
  CHECK_THROWS_AS(psmat::sensor::anneal(e, x0, hi, lo, o), std::invalid_argument);  // lo > hi
  CHECK_THROWS_AS(psmat::sensor::anneal(e, x0, lo, VectorXd::Ones(3), o), std::invalid_argument);
  o.max_evals = 0;
  CHECK_THROWS_AS(psmat::sensor::anneal(e, x0, lo, hi, o), std::invalid_argument);
}

TEST_CASE("anneal_separable: finds tau of noise-free data and a model that fits them") {
  // Only tau and log10 l_j are searched; the linear parameters are solved exactly at every
  // point. tau shapes the play weights and is well identified. The creep rates are not
  // checked: over one 14-min repetition the slow operator (l_2 = 5.26e-6 1/s) moves by
  // ~1e-7 S, so two operators of other rates fit the data as well.
  const RefModel t = psmat_sensor_test::table_2_11();
  const psmat::sensor::SeparableProblem prob(hysteresis_experiments(t, 1), 6, 32.0, 2);
  VectorXd z0(3), lo(3), hi(3);
  z0 << 0.10, -2.0, -5.0;
  lo << 0.01, -5.0, -8.0;
  hi << 1.00, -1.0, -3.0;
  psmat::sensor::AnnealOptions o;
  o.max_evals = 1200;
  o.t0 = 1.0;
  o.t_end = 1e-3;
  o.seed = 1;
  const psmat::sensor::AnnealResult r = psmat::sensor::anneal_separable(prob, z0, lo, hi, o);
  INFO("z = " << r.x.transpose() << ", mean SSE_N = " << r.sse_n << " S^2");
  CHECK_CLOSE(r.x[0], t.tau, 0.01, 0.0);
  CHECK(r.sse_n < 1e-6 * prob.solve(z0).cost);
  CHECK_CLOSE(r.sse_n, prob.solve(r.x).cost, 1e-9, 0.0);
}

TEST_CASE("anneal_fit: energy = log mean SSE_N of the point returned, never a non-invertible one") {
  const RefModel t = psmat_sensor_test::table_2_11();
  const std::vector<Experiment> ex = hysteresis_experiments(t, 1);
  // x = (rho, tau, a1 + rho, a2, a3, log10 l_1, log10 l_2, w_1, w_2), scaled to O(1)
  VectorXd scale(9), x0(9), lo(9), hi(9);
  scale << 1e-4, 1.0, 1e-4, 1e-6, 1e-8, 1.0, 1.0, 1e-6, 1e-6;
  const std::vector<bool> log10{false, false, false, false, false, true, true, false, false};
  x0 << 1.0, 0.3, 2.0, -4.0, 5.0, -3.0, -5.0, 5.0, 1.0;
  lo << 0.1, 0.01, -3.0, -10.0, -10.0, -6.0, -8.0, 0.0, 0.0;
  hi << 3.0, 1.0, 5.0, 10.0, 10.0, -1.0, -3.0, 20.0, 20.0;
  psmat::sensor::AnnealOptions o;
  o.max_evals = 400;
  o.seed = 2;
  const psmat::sensor::AnnealResult r =
      psmat::sensor::anneal_fit(ex, 6, 32.0, x0, lo, hi, scale, log10, o);
  const VectorXd th = psmat::sensor::theta_from_x(r.x, scale, log10);
  // theta_from_x by hand: x_2 is the initial slope a1 + rho, log10 coordinates are powers of 10
  CHECK_CLOSE(th[0], 1e-4 * r.x[0], 1e-14, 0.0);
  CHECK_CLOSE(th[2], 1e-4 * r.x[2] - th[0], 0.0, 1e-18);
  CHECK_CLOSE(th[5], std::pow(10.0, r.x[5]), 1e-14, 0.0);
  RefModel found;
  found.rho = th[0];
  found.tau = th[1];
  found.a1 = th[2];
  found.a2 = th[3];
  found.a3 = th[4];
  found.l = {th[5], th[6]};
  found.w = {th[7], th[8]};
  double mean = 0.0;
  for (const Experiment& e : ex) {
    const std::vector<double> p(e.p.data(), e.p.data() + e.p.size());
    const std::vector<double> g = psmat_sensor_test::reference_direct(found, p, e.dt);
    double sse = 0.0;
    for (size_t k = 0; k < g.size(); ++k)
      sse += (e.g[static_cast<Index>(k)] - g[k]) * (e.g[static_cast<Index>(k)] - g[k]);
    mean += sse / static_cast<double>(g.size()) / static_cast<double>(ex.size());
  }
  CHECK_CLOSE(r.sse_n, mean, 1e-9, 0.0);
  CHECK(psmat::sensor::MPICreep(psmat::sensor::params_from_theta(th, 6, 32.0))
            .check_invertible()
            .empty());
  // a start with a1 + rho < 0 is not invertible: its energy is infinite, so the search moves
  // away from it and never returns it as the best point
  VectorXd bad = x0;
  bad[2] = -2.0;
  lo[2] = -3.0;
  const psmat::sensor::AnnealResult rb =
      psmat::sensor::anneal_fit(ex, 6, 32.0, bad, lo, hi, scale, log10, o);
  CHECK(std::isfinite(rb.energy));
  CHECK(psmat::sensor::MPICreep(psmat::sensor::params_from_theta(
                                    psmat::sensor::theta_from_x(rb.x, scale, log10), 6, 32.0))
            .check_invertible()
            .empty());
}

}  // namespace sensor_fit_tests
