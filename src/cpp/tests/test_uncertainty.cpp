// Uncertainty propagation through IECM (docs/spec.md §3, thesis §2.3.1, eq. 2.11-2.14): dg/dG is the
// inverse of the dense Jacobian, eq. 2.11 is the quadrature sum over it, and both agree with
// brute force — finite differences of the inverse and a Monte-Carlo of noisy re-solves.
#include <random>

#include "psmat/iecm/jacobian.hpp"
#include "psmat/iecm/solve.hpp"
#include "psmat/iecm/uncertainty.hpp"
#include "support.hpp"

using namespace psmat_test;
using psmat::iecm::Method;
using psmat::iecm::SolveOptions;
using psmat::iecm::Solver;

namespace {

RowMatrixXd dense_jacobian(Shape s, const VectorXd& g) {
  psmat::iecm::NodalInverse net(s);
  VectorXd G(s.cells());
  REQUIRE(psmat::iecm::forward(g, net, G));
  RowMatrixXd J(s.cells(), s.cells());
  psmat::iecm::jacobian(net, G, J);
  return J;
}

RowMatrixXd inverse_jacobian(Shape s, const VectorXd& g) {
  RowMatrixXd K(s.cells(), s.cells());
  REQUIRE(psmat::iecm::inverse_jacobian(s, g, K));
  return K;
}

VectorXd propagate(Shape s, const VectorXd& g, const VectorXd& sigma_G) {
  VectorXd sg(s.cells());
  REQUIRE(psmat::iecm::propagate_uncertainty(s, g, sigma_G, sg));
  return sg;
}

VectorXd newton_solve(Shape s, const VectorXd& G, const VectorXd& start, double rtol) {
  SolveOptions o;
  o.method = Method::Newton;
  o.rtol = rtol;
  Solver solver(s, o);
  VectorXd g = start;
  const auto rep = solver.solve(G, g, /*warm=*/true);
  REQUIRE(rep.status == psmat::iecm::Status::Converged);
  return g;
}

}  // namespace

TEST_CASE("inverse_jacobian: dg/dG times dG/dg is the identity (eq. 2.14)") {
  unsigned seed = 3000;
  for (Shape s : {Shape{2, 2}, Shape{3, 3}, Shape{4, 4}, Shape{3, 5}, Shape{2, 7}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, seed++);
    const RowMatrixXd K = inverse_jacobian(s, g), J = dense_jacobian(s, g);
    const MatrixXd I = MatrixXd::Identity(s.cells(), s.cells());
    CHECK((K * J - I).cwiseAbs().maxCoeff() < 1e-10);
    CHECK((J * K - I).cwiseAbs().maxCoeff() < 1e-10);
  }
  // realistic image: conductances over four decades, J badly scaled but invertible
  const auto cases = load_forward_reference();
  const RefCase& c = find_case(cases, "16x16_feet");
  const RowMatrixXd K = inverse_jacobian(c.shape, c.g), J = dense_jacobian(c.shape, c.g);
  // compare in the scaled (similar) form where the entries are O(1):
  // D_g^-1 (K J - I) D_g is what a relative perturbation of g sees
  const MatrixXd E = c.g.cwiseInverse().asDiagonal() * (K * J - MatrixXd::Identity(256, 256)) *
                     c.g.asDiagonal();
  CAPTURE(E.cwiseAbs().maxCoeff());
  CHECK(E.cwiseAbs().maxCoeff() < 1e-8);
}

TEST_CASE("inverse_jacobian: columns equal finite differences of the inverse problem") {
  // Independent of any Jacobian formula: re-solve F(g) = G +- h e_a with Newton and difference.
  const Shape s{3, 3};
  const VectorXd g = random_g(s, 3100);
  const VectorXd G = F(s, g);
  const RowMatrixXd K = inverse_jacobian(s, g);
  for (Index a = 0; a < s.cells(); ++a) {
    CAPTURE(a);
    const double h = 1e-5 * G[a];
    VectorXd Gp = G, Gm = G;
    Gp[a] += h;
    Gm[a] -= h;
    const VectorXd col = (newton_solve(s, Gp, g, 1e-14) - newton_solve(s, Gm, g, 1e-14)) / (2 * h);
    // error budget: truncation ~ (h/G)^2 = 1e-10, solve accuracy ~1e-14 * G / h ~ 1e-9
    for (Index b = 0; b < s.cells(); ++b)
      CHECK(std::abs(col[b] - K(b, a)) <= 1e-6 * (std::abs(K(b, a)) + g[b] / G[a]));
  }
}

TEST_CASE("propagate_uncertainty: eq. 2.11 from inverse_jacobian by hand") {
  unsigned seed = 3200;
  for (Shape s : {Shape{3, 3}, Shape{4, 4}, Shape{3, 5}, Shape{16, 16}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, seed++);
    const VectorXd G = F(s, g);
    // sigma_G: 1 % of G plus a per-cell random part, so the weights differ from cell to cell
    const VectorXd sigma_G = (G.array() * (0.01 + 0.005 * random_normal(s.cells(), seed++).array().abs())).matrix();
    const RowMatrixXd K = inverse_jacobian(s, g);
    VectorXd by_hand(s.cells());
    for (Index b = 0; b < s.cells(); ++b) {
      double acc = 0;
      for (Index a = 0; a < s.cells(); ++a) acc += K(b, a) * K(b, a) * sigma_G[a] * sigma_G[a];
      by_hand[b] = std::sqrt(acc);
    }
    const VectorXd sg = propagate(s, g, sigma_G);
    CHECK(max_rel_err(sg, by_hand) < 1e-10);
    CHECK(sg.minCoeff() > 0.0);
  }
}

TEST_CASE("propagate_uncertainty: physical scalings and the no-crosstalk case") {
  const Shape s{4, 5};
  const VectorXd g = random_g(s, 3300);
  const VectorXd sigma_G = 0.01 * F(s, g);
  const VectorXd sg = propagate(s, g, sigma_G);
  // linear in sigma_G (first-order propagation)
  CHECK(max_rel_err(propagate(s, g, 3.0 * sigma_G), 3.0 * sg) < 1e-12);
  // dG/dg is invariant under g -> c g (F is homogeneous of degree 1), so sigma_g scales with
  // sigma_G only: scaling both by c scales sigma_g by c
  CHECK(max_rel_err(propagate(s, 250.0 * g, 250.0 * sigma_G), 250.0 * sg) < 1e-10);
  // a single row has no crosstalk paths: G = g, dg/dG = I, sigma_g = sigma_G
  const Shape row{1, 6};
  const VectorXd g1 = random_g(row, 3301), s1 = 0.02 * g1;
  CHECK(max_rel_err(propagate(row, g1, s1), s1) < 1e-12);
  // a disconnected network has no uncertainty to report
  VectorXd bad = g;
  bad.segment(0, 5).setZero();
  VectorXd out(s.cells());
  CHECK_FALSE(psmat::iecm::propagate_uncertainty(s, bad, sigma_G, out));
  RowMatrixXd K(s.cells(), s.cells());
  CHECK_FALSE(psmat::iecm::inverse_jacobian(s, bad, K));
}

TEST_CASE("propagate_uncertainty: agrees with a Monte-Carlo of noisy re-solves (small noise)") {
  // Thesis Fig. 2.11: add Gaussian noise to G, re-solve, take the SD per cell. With 0.1 %
  // noise the inverse is linear to well below the 10 % tolerance; with N = 2000 draws the SD
  // itself has a sampling error of ~1/sqrt(2N) = 1.6 %.
  for (Shape s : {Shape{2, 2}, Shape{3, 3}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, 3400 + static_cast<unsigned>(s.rows));
    const VectorXd G = F(s, g);
    const VectorXd sigma_G = 1e-3 * G;
    const VectorXd sg = propagate(s, g, sigma_G);
    const int N = 2000;
    std::mt19937_64 rng(3500);
    std::normal_distribution<double> nd(0.0, 1.0);
    VectorXd sum = VectorXd::Zero(s.cells()), sum2 = VectorXd::Zero(s.cells());
    for (int k = 0; k < N; ++k) {
      VectorXd Gn = G;
      for (Index a = 0; a < Gn.size(); ++a) Gn[a] += sigma_G[a] * nd(rng);
      SolveOptions o;  // Newton, library defaults, cold start as for an unseen frame
      Solver solver(s, o);
      VectorXd gn(s.cells());
      const auto rep = solver.solve(Gn, gn, /*warm=*/false);
      REQUIRE(rep.converged());
      const VectorXd d = gn - g;
      sum += d;
      sum2 += d.cwiseProduct(d);
    }
    const VectorXd mean = sum / N;
    const VectorXd sd = ((sum2 - N * mean.cwiseProduct(mean)) / (N - 1)).cwiseSqrt();
    const double worst = ((sd - sg).array().abs() / sg.array()).maxCoeff();
    CAPTURE(worst);
    MESSAGE(s.rows << "x" << s.cols << " Monte-Carlo SD vs eq. 2.11: worst relative gap " << worst);
    CHECK(worst < 0.10);
    // no bias beyond the sampling error of the mean (5 standard errors)
    for (Index b = 0; b < s.cells(); ++b) CHECK(std::abs(mean[b]) < 5.0 * sg[b] / std::sqrt(double(N)));
  }
}
