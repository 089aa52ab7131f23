// Jacobian of the forward model (docs/spec.md §3, thesis eq. 2.13 / B.23), its scaled symmetric form
// S = D_G (T∘T) D_G and the matrix-free product (T∘T) v. Expectations come from finite
// differences, an independent current-distribution argument, Euler's theorem for the
// degree-1 homogeneous F, Cauchy-Schwarz on T, and the reference vectors.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>

#include "psmat/iecm/simd.hpp"
#include "psmat/iecm/jacobian.hpp"
#include "support.hpp"

using namespace psmat_test;
using psmat::iecm::HadamardWork;
using psmat::iecm::NodalInverse;

namespace {

struct AtPoint {
  Shape s;
  VectorXd g, G;
  RowMatrixXd J;
  MatrixXd S;
};

AtPoint at(Shape s, const VectorXd& g) {
  AtPoint p{s, g, VectorXd(s.cells()), RowMatrixXd(s.cells(), s.cells()), MatrixXd()};
  NodalInverse net(s);
  REQUIRE(psmat::iecm::forward(g, net, p.G));
  psmat::iecm::jacobian(net, p.G, p.J);
  psmat::iecm::scaled_hadamard(net, p.G, p.S, /*lower_only=*/false);
  return p;
}

// Central differences, relative step h_b = 1e-6 g_b.
RowMatrixXd finite_difference_jacobian(Shape s, const VectorXd& g) {
  const Index n = s.cells();
  RowMatrixXd Jfd(n, n);
  for (Index b = 0; b < n; ++b) {
    const double h = 1e-6 * g[b];
    VectorXd gp = g, gm = g;
    gp[b] += h;
    gm[b] -= h;
    Jfd.col(b) = (F(s, gp) - F(s, gm)) / (gp[b] - gm[b]);
  }
  return Jfd;
}

// Independent physics: drive 1 A across cell a = (i,p) (column p grounded, plain LU nodal
// analysis). By Rayleigh/Thomson, dR_a/dr_b = (current through b)^2 = (g_b V_b)^2, hence
//   dG_a/dg_b = G_a^2 V_b^2 = (V_b / V_a)^2,   V_b = voltage across cell b, V_a = 1/G_a.
RowMatrixXd current_distribution_jacobian(Shape s, const VectorXd& g) {
  const Index R = s.rows, C = s.cols, n = s.nodes(), N = s.cells();
  MatrixXd L = MatrixXd::Zero(n, n);
  for (Index i = 0; i < R; ++i)
    for (Index p = 0; p < C; ++p) {
      const double w = g[i * C + p];
      L(i, i) += w;
      L(R + p, R + p) += w;
      L(i, R + p) -= w;
      L(R + p, i) -= w;
    }
  RowMatrixXd J(N, N);
  for (Index i = 0; i < R; ++i)
    for (Index p = 0; p < C; ++p) {
      const Index gnd = R + p;
      MatrixXd Lr(n - 1, n - 1);
      auto idx = [&](Index k) { return k < gnd ? k : k - 1; };
      for (Index u = 0; u < n; ++u)
        for (Index v = 0; v < n; ++v)
          if (u != gnd && v != gnd) Lr(idx(u), idx(v)) = L(u, v);
      VectorXd I = VectorXd::Zero(n - 1);
      I[idx(i)] = 1.0;
      const VectorXd Vr = Eigen::FullPivLU<MatrixXd>(Lr).solve(I);
      VectorXd V(n);
      for (Index u = 0; u < n; ++u) V[u] = (u == gnd) ? 0.0 : Vr[idx(u)];
      const double Va = V[i] - V[gnd];
      for (Index j = 0; j < R; ++j)
        for (Index q = 0; q < C; ++q) {
          const double Vb = V[j] - V[R + q];
          J(i * C + p, j * C + q) = (Vb / Va) * (Vb / Va);
        }
    }
  return J;
}

}  // namespace

TEST_CASE("jacobian: diagonal is exactly 1 (dG_ip/dg_ip = 1, eq. 2.13)") {
  for (Shape s : {Shape{4, 4}, Shape{3, 5}, Shape{2, 7}, Shape{16, 16}}) {
    const AtPoint p = at(s, random_g(s, 100 + static_cast<unsigned>(s.cells())));
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    CHECK((p.J.diagonal().array() - 1.0).abs().maxCoeff() < 1e-12);
  }
  for (const RefCase& c : load_forward_reference()) {
    CAPTURE(c.name);
    const AtPoint p = at(c.shape, c.g);
    CHECK((p.J.diagonal().array() - 1.0).abs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("jacobian: central finite differences agree with the analytic Jacobian") {
  for (Shape s : {Shape{4, 4}, Shape{3, 5}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, 200 + static_cast<unsigned>(s.cols));
    const AtPoint p = at(s, g);
    const RowMatrixXd Jfd = finite_difference_jacobian(s, g);
    // Error budget of the central difference, entry (a, b) with h_b = 1e-6 g_b:
    //  truncation ~ h_b^2 |d3G/dg3| ~ 1e-12 relative, and round-off of the two F values,
    //  ~ eps_F G_a / h_b with eps_F the forward model's relative accuracy (measured ~1e-15,
    //  allowed 1e-13). Entries are dimensionless in [0, 1]: J_ab = (V_b/V_a)^2.
    const Index n = s.cells();
    double worst = 0;  // max of |FD - J| / tolerance
    double max_abs = 0;
    for (Index a = 0; a < n; ++a)
      for (Index b = 0; b < n; ++b) {
        const double e = std::abs(Jfd(a, b) - p.J(a, b));
        const double tol = 1e-6 * std::abs(p.J(a, b)) + 1e-13 * p.G[a] / (1e-6 * g[b]);
        worst = std::max(worst, e / tol);
        max_abs = std::max(max_abs, e);
      }
    CAPTURE(worst);
    CAPTURE(max_abs);
    CHECK(worst < 1.0);
    CHECK(max_abs < 1e-6);
    CHECK(p.J.minCoeff() >= 0.0);  // squares
  }
}

TEST_CASE("jacobian: equals (V_b / V_a)^2 from the current distribution (Rayleigh)") {
  for (Shape s : {Shape{3, 5}, Shape{5, 4}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, 300 + static_cast<unsigned>(s.rows));
    const AtPoint p = at(s, g);
    const RowMatrixXd Jphys = current_distribution_jacobian(s, g);
    CHECK((Jphys - p.J).cwiseAbs().maxCoeff() < 1e-11);
  }
}

TEST_CASE("jacobian: Euler's theorem J g = G (F is homogeneous of degree 1)") {
  for (Shape s : {Shape{4, 4}, Shape{3, 5}, Shape{2, 7}, Shape{16, 16}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const AtPoint p = at(s, random_g(s, 400 + static_cast<unsigned>(s.cells())));
    CHECK(max_rel_err(p.J * p.g, p.G) < 1e-11);
  }
}

TEST_CASE("jacobian: reference row 0 and last column") {
  for (const RefCase& c : load_forward_reference()) {
    CAPTURE(c.name);
    const AtPoint p = at(c.shape, c.g);
    const Index N = c.shape.cells();
    // entries span many decades (down to ~1e-12 on the feet image): compare entrywise
    // relative to the entry, with an absolute floor far below anything physical
    const VectorXd row0 = p.J.row(0).transpose(), col_last = p.J.col(N - 1);
    const double e_row =
        ((row0 - c.jac_row0).array().abs() / (1e-15 + c.jac_row0.array().abs())).maxCoeff();
    const double e_col = ((col_last - c.jac_col_last).array().abs() /
                          (1e-15 + c.jac_col_last.array().abs()))
                             .maxCoeff();
    CAPTURE(e_row);
    CAPTURE(e_col);
    CHECK(e_row < 1e-9);
    CHECK(e_col < 1e-9);
    CHECK((row0 - c.jac_row0).cwiseAbs().maxCoeff() < 1e-12);
    CHECK((col_last - c.jac_col_last).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("scaled_hadamard: S symmetric, unit diagonal, entries in [0,1], positive definite") {
  for (Shape s : {Shape{4, 4}, Shape{3, 5}, Shape{2, 7}, Shape{16, 16}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const AtPoint p = at(s, random_g(s, 500 + static_cast<unsigned>(s.cells())));
    const MatrixXd& S = p.S;
    REQUIRE(S.rows() == s.cells());
    REQUIRE(S.cols() == s.cells());
    CHECK((S - S.transpose()).cwiseAbs().maxCoeff() < 1e-14);  // round-off: S_ab, S_ba summed in other orders
    CHECK((S.diagonal().array() - 1.0).abs().maxCoeff() < 1e-12);
    // Cauchy-Schwarz on T = (Gram form of the PSD M): T_ab^2 <= T_aa T_bb = 1/(G_a G_b)
    CHECK(S.minCoeff() >= 0.0);
    CHECK(S.maxCoeff() <= 1.0 + 1e-12);
    Eigen::LLT<MatrixXd> llt(S);
    CHECK(llt.info() == Eigen::Success);
    const Eigen::SelfAdjointEigenSolver<MatrixXd> eig(S);
    CAPTURE(eig.eigenvalues().minCoeff());
    CHECK(eig.eigenvalues().minCoeff() > 0.0);
    // similarity with J: S = D_G^-1 J D_G (same eigenvalues, the solvers' premise)
    const MatrixXd fromJ = p.G.cwiseInverse().asDiagonal() * MatrixXd(p.J) * p.G.asDiagonal();
    CHECK((fromJ - S).cwiseAbs().maxCoeff() < 1e-13);
  }
}

TEST_CASE("scaled_hadamard: lower_only writes the same lower triangle") {
  const Shape s{3, 5};
  const VectorXd g = random_g(s, 600);
  NodalInverse net(s);
  VectorXd G(s.cells());
  REQUIRE(psmat::iecm::forward(g, net, G));
  MatrixXd Sfull, Slow;
  psmat::iecm::scaled_hadamard(net, G, Sfull, false);
  psmat::iecm::scaled_hadamard(net, G, Slow, true);
  const MatrixXd a = Sfull.triangularView<Eigen::Lower>(), b = Slow.triangularView<Eigen::Lower>();
  CHECK((a - b).cwiseAbs().maxCoeff() == 0.0);
}

TEST_CASE("hadamard_product: matrix-free (T∘T) v equals D_G^-1 S D_G^-1 v") {
  HadamardWork work;
  unsigned seed = 700;
  for (Shape s : {Shape{4, 4}, Shape{3, 5}, Shape{7, 2}, Shape{16, 16}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, seed++);
    NodalInverse net(s);
    VectorXd G(s.cells());
    REQUIRE(psmat::iecm::forward(g, net, G));
    MatrixXd S;
    psmat::iecm::scaled_hadamard(net, G, S, false);
    const MatrixXd TT = G.cwiseInverse().asDiagonal() * S * G.cwiseInverse().asDiagonal();
    for (int k = 0; k < 3; ++k) {
      const VectorXd v = random_normal(s.cells(), seed++);  // signs mixed on purpose
      VectorXd out(s.cells());
      psmat::iecm::hadamard_product(net, v, out, work);  // work reused across shapes
      const VectorXd ref = TT * v;
      CHECK((out - ref).cwiseAbs().maxCoeff() < 1e-10 * ref.cwiseAbs().maxCoeff());
    }
    // with v = g: (T∘T) g = D_G^-2 J g = 1/G (Euler), no dense matrix involved
    VectorXd out(s.cells());
    psmat::iecm::hadamard_product(net, g, out, work);
    CHECK(max_rel_err(out, G.cwiseInverse()) < 1e-10);
  }
}

TEST_CASE("hadamard_product: every vector unit and the baseline kernel, zero entries skipped") {
  // every build of the kernel (hadamard_kernel.hpp: the dispatch, the baseline, each vector unit
  // of simd.hpp this CPU runs) against the dense T∘T of scaled_hadamard, on shapes whose node
  // count is and is not a multiple of the kernel's strip of 16 rows and whose rows and columns
  // are and are not a multiple of the vector units' groups of four nodes, with v zero on a third
  // of the cells (the bound cells of the active-set method), then also on a quiet corner of cells
  // (groups of four nodes whose coefficients are all zero are skipped, and groups partly in it
  // are not)
  const std::string in_use = psmat::iecm::simd_kernels_name();
  CAPTURE(in_use);
  const auto units = psmat::iecm::simd_kernels_available();
  HadamardWork work;
  unsigned seed = 900;
  for (Shape s : {Shape{1, 5}, Shape{5, 1}, Shape{3, 5}, Shape{16, 16}, Shape{17, 9}, Shape{24, 40}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, seed++);
    NodalInverse net(s);
    VectorXd G(s.cells());
    REQUIRE(psmat::iecm::forward(g, net, G));
    MatrixXd S;
    psmat::iecm::scaled_hadamard(net, G, S, false);
    const MatrixXd TT = G.cwiseInverse().asDiagonal() * S * G.cwiseInverse().asDiagonal();
    VectorXd v = random_normal(s.cells(), seed++);
    for (Index a = 0; a < v.size(); a += 3) v[a] = 0.0;
    VectorXd out1(s.cells()), out2(s.cells());
    for (int pattern = 0; pattern < 2; ++pattern) {
      CAPTURE(pattern);
      if (pattern == 1)  // a quiet corner of 6 x 6 cells: groups of four nodes partly in it
        for (Index i = 0; i < std::min<Index>(6, s.rows); ++i)
          for (Index p = 0; p < std::min<Index>(6, s.cols); ++p) v[i * s.cols + p] = 0.0;
      const VectorXd ref = TT * v;
      psmat::iecm::hadamard_product(net, v, out1, work);
      psmat::iecm::hadamard_product_portable(net, v, out2, work);
      CHECK((out1 - ref).cwiseAbs().maxCoeff() <= 1e-10 * ref.cwiseAbs().maxCoeff());
      CHECK((out2 - ref).cwiseAbs().maxCoeff() <= 1e-10 * ref.cwiseAbs().maxCoeff());
      for (const psmat::iecm::SimdKernels* u : units) {
        const std::string unit = u->name;
        CAPTURE(unit);
        const Index n = s.nodes();
        work.P.resize(n, n);
        work.kdiag.resize(n + 4 * s.rows);
        VectorXd out3 = VectorXd::Constant(s.cells(), 1e300);
        u->hadamard_kernel(net.M().data(), s.rows, s.cols, v.data(), out3.data(), work.P.data(),
                           work.kdiag.data());
        CHECK((out3 - ref).cwiseAbs().maxCoeff() <= 1e-10 * ref.cwiseAbs().maxCoeff());
      }
    }
    v.setZero();  // nothing to sum: exactly 0
    psmat::iecm::hadamard_product(net, v, out1, work);
    CHECK(out1.cwiseAbs().maxCoeff() == 0.0);
  }
}
