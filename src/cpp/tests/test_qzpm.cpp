// QZPM readout (thesis App. C): forward model against a brute-force Kirchhoff solve of
// eq. C.4-C.6 and the r_s -> 0 limit; Jacobian against finite differences; closed form exact
// under its own assumptions; inverse round trip with a shared switch.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <random>

#include "psmat/qzpm/closed_form.hpp"
#include "psmat/qzpm/forward.hpp"
#include "psmat/qzpm/solve.hpp"

using namespace psmat;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

struct Case {
  Shape s;
  VectorXd g, gr, gc;
};

Case random_case(Index R, Index C, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ur(100.0, 1e4), us(5.0, 15.0);
  Case c{Shape{R, C}, VectorXd(R * C), VectorXd(R), VectorXd(C)};
  for (auto& x : c.g) x = 1.0 / ur(rng);
  for (auto& x : c.gr) x = 1.0 / us(rng);
  for (auto& x : c.gc) x = 1.0 / us(rng);
  return c;
}

// eq. C.4-C.6 written out: unknowns V_1..V_R, V^1..V^C, V_in; I_ref = 1 into "in".
double brute_force(const Case& c, Index sel_row, Index sel_col) {
  const Index R = c.s.rows, C = c.s.cols, n = R + C + 1, in = R + C;
  MatrixXd Y = MatrixXd::Zero(n, n);
  auto edge = [&](Index a, Index b, double y) {  // b < 0: ground
    Y(a, a) += y;
    if (b >= 0) {
      Y(b, b) += y;
      Y(a, b) -= y;
      Y(b, a) -= y;
    }
  };
  for (Index i = 0; i < R; ++i)
    for (Index p = 0; p < C; ++p) edge(i, R + p, c.g[i * C + p]);
  for (Index i = 0; i < R; ++i) edge(i, i == sel_row ? in : -1, c.gr[i]);
  for (Index p = 0; p < C; ++p) edge(R + p, p == sel_col ? in : -1, c.gc[p]);
  VectorXd I = VectorXd::Zero(n);
  I[in] = 1.0;
  const VectorXd V = Y.partialPivLu().solve(I);
  return 1.0 / V[in];
}

}  // namespace

// doctest::Approx(x).epsilon(e) alone allows e·(1 + |x|), an absolute tolerance for small x;
// .scale(1e-300) makes it relative (e·|x|), which is what the small conductances here need.

TEST_CASE("qzpm forward equals a brute-force solve of eq. C.4-C.6") {
  for (auto [R, C] : {std::pair<Index, Index>{2, 2}, {3, 4}, {5, 3}}) {
    const Case c = random_case(R, C, static_cast<unsigned>(10 * R + C));
    qzpm::Network net(c.s);
    qzpm::Readings G;
    REQUIRE(qzpm::forward(c.g, c.gr, c.gc, net, G));
    for (Index i = 0; i < R; ++i) {
      for (Index p = 0; p < C; ++p)
        CHECK(G.pairs[i * C + p] == doctest::Approx(brute_force(c, i, p)).epsilon(1e-12).scale(1e-300));
      CHECK(G.rows[i] == doctest::Approx(brute_force(c, i, -1)).epsilon(1e-12).scale(1e-300));
    }
    for (Index p = 0; p < C; ++p) CHECK(G.cols[p] == doctest::Approx(brute_force(c, -1, p)).epsilon(1e-12).scale(1e-300));
  }
}

TEST_CASE("qzpm forward: ideal switches give the zero-potential values") {
  Case c = random_case(4, 3, 7);
  c.gr.setConstant(1e5);
  c.gc.setConstant(1e5);
  qzpm::Network net(c.s);
  qzpm::Readings G;
  REQUIRE(qzpm::forward(c.g, c.gr, c.gc, net, G));
  const Eigen::Map<const RowMatrixXd> g(c.g.data(), 4, 3);
  for (Index i = 0; i < 4; ++i) {
    CHECK(G.rows[i] == doctest::Approx(g.row(i).sum()).epsilon(1e-5).scale(1e-300));
    for (Index p = 0; p < 3; ++p)
      CHECK(G.pairs[i * 3 + p] ==
            doctest::Approx(g.row(i).sum() + g.col(p).sum() - 2 * g(i, p)).epsilon(1e-5).scale(1e-300));
  }
}

TEST_CASE("qzpm jacobian equals central finite differences") {
  const Case c = random_case(3, 4, 3);
  const Shape s = c.s;
  qzpm::Network net(s);
  VectorXd sw(s.nodes());
  sw << c.gr, c.gc;
  REQUIRE(net.compute(c.g, sw));
  RowMatrixXd J(qzpm::n_readings(s), qzpm::n_parameters(s));
  qzpm::jacobian(net, J);
  VectorXd theta(qzpm::n_parameters(s));
  theta << c.g, sw;
  auto F = [&](const VectorXd& th) {
    qzpm::Network n2(s);
    REQUIRE(n2.compute(th.head(s.cells()), th.tail(s.nodes())));
    VectorXd G(qzpm::n_readings(s));
    qzpm::readings(n2, G);
    return G;
  };
  for (Index b = 0; b < theta.size(); ++b) {
    const double h = 1e-5 * theta[b];
    VectorXd tp = theta, tm = theta;
    tp[b] += h;
    tm[b] -= h;
    const VectorXd fd = (F(tp) - F(tm)) / (2 * h);
    // finite-difference round-off is ~1e-8 absolute (readings ~1e-2 S, steps ~1e-9 S)
    for (Index a = 0; a < fd.size(); ++a) CHECK(std::abs(J(a, b) - fd[a]) <= 1e-7 + 1e-6 * std::abs(fd[a]));
  }
}

TEST_CASE("qzpm closed form is exact with ideal grounding and the assumed switch") {
  // unselected lines held at 0 V exactly (grounding switches ideal), selected switches = r_s:
  // emulate by huge grounding conductance and compute readings with the selected switch at
  // 1/r_s via the brute-force solver.
  const double rs = 10.0;
  Case c = random_case(4, 4, 11);
  const Index R = 4, C = 4;
  qzpm::Readings G(c.s);
  for (Index i = 0; i < R; ++i)
    for (Index p = -1; p < C; ++p) {
      Case k = c;
      k.gr.setConstant(1e9);
      k.gc.setConstant(1e9);
      k.gr[i] = 1.0 / rs;
      if (p >= 0) k.gc[p] = 1.0 / rs;
      const double val = brute_force(k, i, p);
      if (p >= 0) G.pairs[i * C + p] = val; else G.rows[i] = val;
    }
  for (Index p = 0; p < C; ++p) {
    Case k = c;
    k.gr.setConstant(1e9);
    k.gc.setConstant(1e9);
    k.gc[p] = 1.0 / rs;
    G.cols[p] = brute_force(k, -1, p);
  }
  const VectorXd g = qzpm::closed_form(c.s, G, rs);
  CHECK(((g - c.g).array() / c.g.array()).abs().maxCoeff() < 1e-6);
}

TEST_CASE("qzpm inverse recovers cells and a shared switch") {
  Case c = random_case(5, 5, 21);
  c.gr.setConstant(1.0 / 13.0);
  c.gc.setConstant(1.0 / 13.0);
  qzpm::Network net(c.s);
  qzpm::Readings G;
  REQUIRE(qzpm::forward(c.g, c.gr, c.gc, net, G));
  qzpm::SolveOptions o;
  const auto sol = qzpm::solve(c.s, G, o);
  CHECK(sol.report.status == qzpm::Status::Converged);
  CHECK(((sol.g - c.g).array() / c.g.array()).abs().maxCoeff() < 1e-8);
  CHECK(sol.g_row[0] == doctest::Approx(1.0 / 13.0).epsilon(1e-8).scale(1e-300));
}
