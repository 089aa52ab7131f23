// Velostat sensor model (docs/spec.md §4, thesis §2.5.1, eq. 2.15-2.25): the one-side play
// operator on a hand-worked sequence, the loading and unloading branches in closed form, the
// creep operator's sampled step response and recovery, the analytic MPI inverse (eq. 2.21) by
// hand, direct∘inverse = identity, and the documented handling of NaN, clipping and bad
// parameters. Expectations come from hand calculation, closed forms and an independent plain
// implementation of the equations (sensor_reference.hpp).
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "psmat/sensor/fit.hpp"
#include "psmat/sensor/mpi_creep.hpp"
#include "psmat/sensor/operators.hpp"
#include "sensor_reference.hpp"

namespace sensor_model_tests {

using Eigen::VectorXd;
using psmat::Index;
using psmat::RowMatrixXd;
using psmat::sensor::MPICreep;
using psmat::sensor::MPICreepParams;
using psmat_sensor_test::RefModel;

MPICreepParams to_params(const RefModel& m) {
  MPICreepParams p;
  p.rho = m.rho;
  p.tau = m.tau;
  p.a1 = m.a1;
  p.a2 = m.a2;
  p.a3 = m.a3;
  p.l = m.l;
  p.w = m.w;
  p.n_ops = m.n_ops;
  p.p_max = m.p_max;
  return p;
}

VectorXd to_vec(const std::vector<double>& v) {
  return Eigen::Map<const VectorXd>(v.data(), static_cast<Index>(v.size()));
}

// The direct model of one cell from rest over the whole stream.
VectorXd direct_1(const MPICreep& m, const std::vector<double>& p, double dt) {
  const Index T = static_cast<Index>(p.size());
  psmat::sensor::MPICreepState st = m.rest_state(1);
  RowMatrixXd g(T, 1);
  m.direct(Eigen::Map<const RowMatrixXd>(p.data(), T, 1), dt, st, g);
  return g.col(0);
}

TEST_CASE("OSP operator: a hand-worked sequence with load reversals (eq. 2.15-2.16)") {
  // r = 2 psi: from rest the output follows p - r while the load rises, follows p while it
  // falls, and keeps its value while the input moves inside the play.
  const std::vector<double> p{0, 3, 5, 4, 3, 1, 2, 4, 6, 0};
  const std::vector<double> want{0, 1, 3, 3, 3, 1, 1, 2, 4, 0};
  double y = 0.0;  // at rest
  for (size_t k = 0; k < p.size(); ++k) {
    y = psmat::sensor::osp_step(p[k], 2.0, y);
    CHECK(y == want[k]);
  }
  // the same through the regression basis of the fit; r = 0 is the identity, r = 10 psi never
  // leaves 0 below 10 psi
  VectorXd r(3);
  r << 0.0, 2.0, 10.0;
  RowMatrixXd Y(static_cast<Index>(p.size()), 3);
  psmat::sensor::play_basis(to_vec(p), r, Y);
  for (size_t k = 0; k < p.size(); ++k) {
    const Index t = static_cast<Index>(k);
    CHECK(Y(t, 0) == p[k]);
    CHECK(Y(t, 1) == want[k]);
    CHECK(Y(t, 2) == 0.0);
  }
}

TEST_CASE("direct: two operators by hand; r_i = (i-1)/N p_max, b_i = rho e^{-tau r_i} (eq. 2.18)") {
  // N = 2, p_max = 4 psi: r = {0, 2} psi; rho = 1, tau = ln 2 / 2 per psi: b = {1, 1/2}.
  // No polynomial, no creep: g = y_0 + y_2 / 2 = p + y_2 / 2, y_2 from the sequence above.
  MPICreepParams q;
  q.rho = 1.0;
  q.tau = std::log(2.0) / 2.0;
  q.n_ops = 2;
  q.p_max = 4.0;
  const MPICreep m(q);
  CHECK(m.thresholds()[0] == 0.0);
  CHECK(m.thresholds()[1] == 2.0);
  CHECK_CLOSE(m.weights()[0], 1.0, 1e-15, 0.0);
  CHECK_CLOSE(m.weights()[1], 0.5, 1e-15, 0.0);
  const std::vector<double> p{0, 3, 5, 4, 3, 1, 2, 4, 6, 0};
  const std::vector<double> want{0, 3.5, 6.5, 5.5, 4.5, 1.5, 2.5, 5, 8, 0};
  const VectorXd g = direct_1(m, p, 0.5);
  for (size_t k = 0; k < p.size(); ++k) CHECK_CLOSE(g[static_cast<Index>(k)], want[k], 1e-15, 0.0);
}

TEST_CASE("direct: Table 2.11 follows the closed-form loading and unloading branches (eq. 2.17)") {
  // Without creep, from rest: on a rising load every operator sits at max(p - r_i, 0); after
  // the peak M, on the way down, at min(p, M - r_i). The unloading branch lies above the
  // loading one: the hysteresis loop.
  RefModel ref = psmat_sensor_test::table_2_11();
  ref.l.clear();
  ref.w.clear();
  const MPICreep m(to_params(ref));
  const double M = 32.0;
  std::vector<double> p;
  for (int k = 0; k <= 64; ++k) p.push_back(0.5 * k);  // 0 .. 32 psi
  for (int k = 63; k >= 0; --k) p.push_back(0.5 * k);  // 31.5 .. 0 psi
  const VectorXd g = direct_1(m, p, 0.5);
  auto poly = [&](double x) { return ref.a1 * x + ref.a2 * x * x + ref.a3 * x * x * x; };
  auto loading = [&](double x) {
    double v = poly(x);
    for (int i = 1; i <= ref.n_ops; ++i)
      v += psmat_sensor_test::weight(ref, i) *
           std::max(x - psmat_sensor_test::threshold(ref, i), 0.0);
    return v;
  };
  auto unloading = [&](double x) {
    double v = poly(x);
    for (int i = 1; i <= ref.n_ops; ++i)
      v += psmat_sensor_test::weight(ref, i) *
           std::min(x, std::max(M - psmat_sensor_test::threshold(ref, i), 0.0));
    return v;
  };
  for (Index k = 0; k <= 64; ++k)
    CHECK_CLOSE(g[k], loading(p[static_cast<size_t>(k)]), 1e-12, 1e-18);
  for (Index k = 65; k < g.size(); ++k)
    CHECK_CLOSE(g[k], unloading(p[static_cast<size_t>(k)]), 1e-12, 1e-18);
  // docs/spec.md §4: with these values 32 psi gives about 6.7e-3 S (about 150 Ohm)
  CHECK_CLOSE(g[64], 6.7e-3, 0.01, 0.0);
  // the loop: at 16 psi unloading is above loading, by b_2..b_6 times the play widths
  const double up16 = g[32], down16 = g[65 + (63 - 32)];
  REQUIRE(p[32] == 16.0);
  REQUIRE(p[65 + (63 - 32)] == 16.0);
  CHECK(down16 - up16 > 0.0);
  CHECK_CLOSE(down16 - up16, unloading(16.0) - loading(16.0), 1e-9, 0.0);
}

TEST_CASE("creep: a constant load gives the sampled first-order step response, then recovery") {
  // Only a linear term and two creep operators. Eq. 2.23 sees the previous sample, so under a
  // load P applied from sample 0: y_j(t_k) = P (1 - e^{-l_j k T}); when the load is removed
  // at sample K: y_j(t_{K+m}) = P (1 - e^{-l_j K T}) e^{-l_j m T}.
  MPICreepParams q;
  q.a1 = 1e-4;
  q.l = {0.05, 0.002};  // 1/s
  q.w = {8e-6, 2e-6};   // S/psi
  const MPICreep m(q);
  const double P = 15.0, T = 0.5;
  const int K = 400, U = 200;
  std::vector<double> p(K, P);
  p.resize(K + U, 0.0);
  const VectorXd g = direct_1(m, p, T);
  for (int k = 0; k < K; ++k) {
    double want = q.a1 * P;
    for (size_t j = 0; j < 2; ++j) want += q.w[j] * P * (1.0 - std::exp(-q.l[j] * k * T));
    CHECK_CLOSE(g[k], want, 1e-12, 0.0);
  }
  for (int n = 0; n < U; ++n) {
    double want = 0.0;
    for (size_t j = 0; j < 2; ++j)
      want += q.w[j] * P * (1.0 - std::exp(-q.l[j] * K * T)) * std::exp(-q.l[j] * n * T);
    CHECK_CLOSE(g[K + n], want, 1e-12, 0.0);
  }

  SUBCASE("an irregular clock: sample k steps by dt[k], the time since the sample before it") {
    VectorXd dt(K);
    for (int k = 0; k < K; ++k) dt[k] = (k % 3 == 0) ? 1.5 : 0.25;
    psmat::sensor::MPICreepState st = m.rest_state(1);
    RowMatrixXd gi(K, 1);
    m.direct(RowMatrixXd::Constant(K, 1, P), dt, st, gi);
    double elapsed = 0.0;  // t_k - t_0
    for (int k = 0; k < K; ++k) {
      if (k > 0) elapsed += dt[k];
      double want = q.a1 * P;
      for (size_t j = 0; j < 2; ++j) want += q.w[j] * P * (1.0 - std::exp(-q.l[j] * elapsed));
      CHECK_CLOSE(gi(k, 0), want, 1e-12, 0.0);
    }
  }
}

TEST_CASE("creep: l -> infinity is a one-sample delay of the load, l = 0 never moves") {
  // e^{-l T} -> 0: y_c(t_k) = p(t_{k-1}), the constant term of thesis §2.5.1 seen one sample
  // late; e^{-0} = 1: y_c stays at rest.
  MPICreepParams q;
  q.l = {1e3, 0.0};
  q.w = {1.0, 1.0};
  const MPICreep m(q);
  const std::vector<double> p{0, 3, 5, 4, 3, 1, 2, 4, 6, 0};
  const VectorXd g = direct_1(m, p, 0.5);
  CHECK(g[0] == 0.0);
  for (size_t k = 1; k < p.size(); ++k) CHECK_CLOSE(g[static_cast<Index>(k)], p[k - 1], 1e-15, 0.0);
}

TEST_CASE("direct: equals a plain implementation of eq. 2.15-2.24, per cell and chunk by chunk") {
  const RefModel ref = psmat_sensor_test::table_2_11();
  const MPICreep m(to_params(ref));
  const Index T = 3000, cells = 3;
  RowMatrixXd p(T, cells);
  std::vector<std::vector<double>> want;
  for (Index c = 0; c < cells; ++c) {
    const std::vector<double> pc =
        psmat_sensor_test::random_stream(static_cast<size_t>(T), 11u + static_cast<unsigned>(c));
    p.col(c) = to_vec(pc);
    want.push_back(psmat_sensor_test::reference_direct(ref, pc, 0.5));
  }
  psmat::sensor::MPICreepState st = m.rest_state(cells);
  RowMatrixXd g(T, cells);
  m.direct(p, 0.5, st, g);
  double g_max = 0.0;
  for (const auto& w : want)
    for (double v : w) g_max = std::max(g_max, std::abs(v));
  REQUIRE(g_max > 1e-3);  // the stream reaches the upper part of the range
  for (Index c = 0; c < cells; ++c)
    for (Index t = 0; t < T; ++t)
      CHECK_CLOSE(g(t, c), want[static_cast<size_t>(c)][static_cast<size_t>(t)], 0.0,
                  1e-14 * g_max);

  // a stream resumed from its state gives the same numbers as one call (docs/spec.md §4)
  psmat::sensor::MPICreepState s2 = m.rest_state(cells);
  RowMatrixXd g2(T, cells);
  const Index cut = 1234;
  m.direct(p.topRows(cut), 0.5, s2, g2.topRows(cut));
  m.direct(p.bottomRows(T - cut), 0.5, s2, g2.bottomRows(T - cut));
  CHECK((g2 - g).cwiseAbs().maxCoeff() == 0.0);
}

TEST_CASE("direct: a NaN sample gives NaN and is skipped; the other cell is untouched") {
  const RefModel ref = psmat_sensor_test::table_2_11();
  const MPICreep m(to_params(ref));
  const std::vector<double> pc = psmat_sensor_test::random_stream(200, 5u);
  const Index T = 200, bad = 57;
  RowMatrixXd p(T, 2);
  p.col(0) = to_vec(pc);
  p.col(1) = to_vec(pc);
  p(bad, 0) = std::numeric_limits<double>::quiet_NaN();
  psmat::sensor::MPICreepState st = m.rest_state(2);
  RowMatrixXd g(T, 2);
  m.direct(p, 0.5, st, g);
  CHECK(std::isnan(g(bad, 0)));
  // cell 0 behaves as if the sample had not been there
  std::vector<double> skipped = pc;
  skipped.erase(skipped.begin() + bad);
  const std::vector<double> want0 = psmat_sensor_test::reference_direct(ref, skipped, 0.5);
  const std::vector<double> want1 = psmat_sensor_test::reference_direct(ref, pc, 0.5);
  for (Index t = 0; t < T; ++t) {
    if (t != bad)
      CHECK_CLOSE(g(t, 0), want0[static_cast<size_t>(t < bad ? t : t - 1)], 1e-12, 1e-18);
    CHECK_CLOSE(g(t, 1), want1[static_cast<size_t>(t)], 1e-12, 1e-18);
  }
}

TEST_CASE("play_inverse: eq. 2.21 by hand; its thresholds are the loading curve at r_j") {
  // F[p] = p + 1 y_0 + 2 y_1 with r = {0, 1} psi: on a rising load F = 2p up to 1 psi, then
  // 4p - 2. The inverse is p = u/2 up to u = 2, then (u + 2)/4: a1^ = 1, b^ = {-1/2, -1/4},
  // r^ = {0, 2}.
  VectorXd b(2), r(2);
  b << 1.0, 2.0;
  r << 0.0, 1.0;
  const psmat::sensor::PlayInverse inv = psmat::sensor::play_inverse(1.0, b, r);
  CHECK(inv.a1_hat == 1.0);
  CHECK(inv.b_hat[0] == -0.5);
  CHECK(inv.b_hat[1] == -0.25);
  CHECK(inv.r_hat[0] == 0.0);
  CHECK(inv.r_hat[1] == 2.0);
  // by hand: y_1 = 0, 0, 0, 1, 1, 0 on p = 0, 0.5, 1, 2, 1, 0
  VectorXd p(6), u_want(6);
  p << 0, 0.5, 1, 2, 1, 0;
  u_want << 0, 1, 2, 6, 4, 0;
  const VectorXd u = psmat::sensor::apply_play(1.0, b, r, p);
  for (Index k = 0; k < 6; ++k) CHECK(u[k] == u_want[k]);
  const VectorXd back = psmat::sensor::apply_play(inv.a1_hat, inv.b_hat, inv.r_hat, u);
  for (Index k = 0; k < 6; ++k) CHECK_CLOSE(back[k], p[k], 1e-15, 0.0);

  SUBCASE("Table 2.11: r^_j is F at r_j on the loading curve (one sample from rest)") {
    const RefModel ref = psmat_sensor_test::table_2_11();
    const MPICreep m(to_params(ref));
    const psmat::sensor::PlayInverse t =
        psmat::sensor::play_inverse(ref.a1, m.weights(), m.thresholds());
    for (Index j = 0; j < m.thresholds().size(); ++j) {
      const VectorXd at = VectorXd::Constant(1, m.thresholds()[j]);
      CHECK_CLOSE(t.r_hat[j], psmat::sensor::apply_play(ref.a1, m.weights(), m.thresholds(), at)[0],
                  1e-14, 1e-300);
    }
  }
}

TEST_CASE("play_inverse: F^-1[F[p]] = p on Table 2.11 and a stream with reversals (eq. 2.20)") {
  const RefModel ref = psmat_sensor_test::table_2_11();
  const MPICreep m(to_params(ref));
  const VectorXd p = to_vec(psmat_sensor_test::random_stream(3000, 3u));
  const VectorXd u = psmat::sensor::apply_play(ref.a1, m.weights(), m.thresholds(), p);
  const psmat::sensor::PlayInverse inv =
      psmat::sensor::play_inverse(ref.a1, m.weights(), m.thresholds());
  const VectorXd back = psmat::sensor::apply_play(inv.a1_hat, inv.b_hat, inv.r_hat, u);
  CHECK((back - p).cwiseAbs().maxCoeff() <= 1e-11);
}

TEST_CASE(
    "inverse: inverse(direct(p)) = p, direct(inverse(g)) = g on Table 2.11 (docs/spec.md §4)") {
  const RefModel ref = psmat_sensor_test::table_2_11();
  const MPICreep m(to_params(ref));
  REQUIRE(m.check_invertible().empty());
  const Index T = 3000, cells = 3;
  RowMatrixXd p(T, cells);
  for (Index c = 0; c < cells; ++c)
    p.col(c) = to_vec(
        psmat_sensor_test::random_stream(static_cast<size_t>(T), 21u + static_cast<unsigned>(c)));
  RowMatrixXd g(T, cells), back(T, cells), g_again(T, cells);
  psmat::sensor::MPICreepState sd = m.rest_state(cells);
  m.direct(p, 0.5, sd, g);
  // inverted in two chunks, the state carried over
  psmat::sensor::MPICreepState si = m.rest_state(cells);
  const Index cut = 1700;
  m.inverse(g.topRows(cut), 0.5, si, back.topRows(cut));
  m.inverse(g.bottomRows(T - cut), 0.5, si, back.bottomRows(T - cut));
  CHECK((back - p).cwiseAbs().maxCoeff() <= 1e-9);  // psi
  psmat::sensor::MPICreepState s3 = m.rest_state(cells);
  m.direct(back, 0.5, s3, g_again);
  CHECK(((g_again - g).cwiseAbs().array() <= 1e-9 * g.cwiseAbs().array() + 1e-18).all());

  SUBCASE("a stream that never rests at 0 inside the range clips nothing") {
    RowMatrixXd q = p.cwiseMax(0.5);
    RowMatrixXd gq(T, cells), pq(T, cells);
    psmat::sensor::MPICreepState a = m.rest_state(cells), b = m.rest_state(cells);
    m.direct(q, 0.5, a, gq);
    Index clipped = -1;
    m.inverse(gq, 0.5, b, pq, &clipped);
    CHECK(clipped == 0);
    CHECK((pq - q).cwiseAbs().maxCoeff() <= 1e-9);
  }
}

TEST_CASE("inverse: a conductance out of the model's range gives 0 or p_max and is counted") {
  const MPICreep m(to_params(psmat_sensor_test::table_2_11()));
  RowMatrixXd g(3, 1), p(3, 1);
  g << -1e-4,  // below what zero pressure gives
      1.0,     // far above what 32 psi gives (about 6.7e-3 S)
      3e-3;    // inside the range
  psmat::sensor::MPICreepState st = m.rest_state(1);
  Index clipped = -1;
  m.inverse(g, 0.5, st, p, &clipped);
  CHECK(p(0, 0) == 0.0);
  CHECK(p(1, 0) == 32.0);
  CHECK(p(2, 0) > 0.0);
  CHECK(p(2, 0) < 32.0);
  CHECK(clipped == 2);
  RowMatrixXd nan_in(1, 1), nan_out(1, 1);
  nan_in(0, 0) = std::numeric_limits<double>::quiet_NaN();
  m.inverse(nan_in, 0.5, st, nan_out);
  CHECK(std::isnan(nan_out(0, 0)));
}

TEST_CASE(
    "check_invertible: Table 2.11 passes; bad play slope, total slope or creep weights fail") {
  // docs/spec.md §4: a1 + sum_{i<=j} b_i > 0 for every j, a positive total slope on [0, p_max],
  // and (for a stable inverse) sum |w_j| below the smallest slope.
  const RefModel t = psmat_sensor_test::table_2_11();
  CHECK(MPICreep(to_params(t)).check_invertible().empty());
  // each failure says which condition failed
  RefModel play = t;
  play.a1 = -2.0 * t.rho;  // a1 + b_1 = -rho (r_1 = 0, b_1 = rho)
  const std::string why_play = MPICreep(to_params(play)).check_invertible();
  INFO(why_play);
  CHECK(why_play.find("play") != std::string::npos);
  CHECK(why_play.find("polynomial") == std::string::npos);
  RefModel poly = t;
  poly.a2 = -1e-4;  // slope at 32 psi: about 2.7e-4 - 6.4e-3 + 2.3e-4 S/psi < 0
  const std::string why_poly = MPICreep(to_params(poly)).check_invertible();
  INFO(why_poly);
  CHECK(why_poly.find("polynomial") != std::string::npos);
  RefModel creep = t;
  creep.w = {1e-3, 0.0};  // larger than any slope the model has (about 2.7e-4 S/psi at 0)
  const std::string why_creep = MPICreep(to_params(creep)).check_invertible();
  INFO(why_creep);
  CHECK(why_creep.find("creep") != std::string::npos);
}

TEST_CASE("MPICreep: inconsistent parameters and periods are rejected with std::invalid_argument") {
  const MPICreepParams ok = to_params(psmat_sensor_test::table_2_11());
  MPICreepParams q = ok;
  q.w.pop_back();  // two rates, one weight
  CHECK_THROWS_AS(MPICreep{q}, std::invalid_argument);
  q = ok;
  q.l[0] = -1e-3;
  CHECK_THROWS_AS(MPICreep{q}, std::invalid_argument);
  q = ok;
  q.n_ops = 0;
  CHECK_THROWS_AS(MPICreep{q}, std::invalid_argument);
  q = ok;
  q.p_max = 0.0;
  CHECK_THROWS_AS(MPICreep{q}, std::invalid_argument);
  q = ok;
  q.rho = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(MPICreep{q}, std::invalid_argument);

  const MPICreep m(ok);
  psmat::sensor::MPICreepState st = m.rest_state(1);
  RowMatrixXd p = RowMatrixXd::Constant(4, 1, 1.0), g(4, 1);
  CHECK_THROWS_AS(m.direct(p, 0.0, st, g), std::invalid_argument);
  CHECK_THROWS_AS(m.direct(p, VectorXd::Constant(3, 0.5), st, g), std::invalid_argument);
}

}  // namespace sensor_model_tests
