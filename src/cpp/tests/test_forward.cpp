// Forward model G = F(g) (docs/spec.md §3, thesis eq. 2.5-2.7): expectations from circuit theory,
// hand-solved networks, an independent brute-force nodal solver and the reference vectors.
#include <limits>
#include <string>

#include "psmat/iecm/simd.hpp"
#include "support.hpp"

using namespace psmat_test;
using psmat::iecm::forward;
using psmat::iecm::NodalInverse;

namespace {
double par(double x, double y) { return x * y / (x + y); }  // resistors in parallel
double series_g(std::initializer_list<double> gs) {           // conductances in series
  double r = 0;
  for (double g : gs) r += 1.0 / g;
  return 1.0 / r;
}
}  // namespace

TEST_CASE("cell_laplacian: 2x2 by hand, the one assembly of IECM and QZPM (eq. 2.7, C.4-C.6)") {
  // rows 0, 1 then columns 2, 3; cell (i, p) joins node i and node 2 + p
  const VectorXd g = (VectorXd(4) << 1.0, 2.0, 3.0, 4.0).finished();
  MatrixXd L;
  REQUIRE(psmat::iecm::cell_laplacian(Shape{2, 2}, g, L));
  const MatrixXd want = (MatrixXd(4, 4) << 3, 0, -1, -2,
                                           0, 7, -3, -4,
                                           -1, -3, 4, 0,
                                           -2, -4, 0, 6).finished();
  CHECK(L == want);
  VectorXd bad = g;
  bad[3] = -1.0;
  CHECK_FALSE(psmat::iecm::cell_laplacian(Shape{2, 2}, bad, L));
  bad[3] = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(psmat::iecm::cell_laplacian(Shape{2, 2}, bad, L));
}

TEST_CASE("forward: 2x2 solved by hand") {
  // Nodes r0, r1 (rows) and c0, c1 (columns); cells a = g00 (r0-c0), b = g01 (r0-c1),
  // c = g10 (r1-c0), d = g11 (r1-c1). The network is the ring r0-c0-r1-c1-r0, so between
  // the two ends of a cell there are exactly two paths: the cell itself and the other three
  // cells in series around the ring:
  //   G00 = a + (b, d, c in series)   path r0-c1-r1-c0
  //   G01 = b + (a, c, d in series)   path r0-c0-r1-c1
  //   G10 = c + (a, b, d in series)   path r1-c1-r0-c0
  //   G11 = d + (b, a, c in series)   path r1-c0-r0-c1
  // With a,b,c,d = 1,2,3,4 S: G00 = 1 + 12/13 = 25/13, G01 = 2 + 12/19 = 50/19,
  // G10 = 3 + 4/7 = 25/7, G11 = 4 + 6/11 = 50/11.
  const Shape s{2, 2};
  VectorXd g(4);
  g << 1, 2, 3, 4;
  const VectorXd G = F(s, g);
  CHECK(G[0] == doctest::Approx(25.0 / 13.0).epsilon(1e-14));
  CHECK(G[1] == doctest::Approx(50.0 / 19.0).epsilon(1e-14));
  CHECK(G[2] == doctest::Approx(25.0 / 7.0).epsilon(1e-14));
  CHECK(G[3] == doctest::Approx(50.0 / 11.0).epsilon(1e-14));
  // the same through the general formula, for a non-integer case
  VectorXd h(4);
  h << 0.3e-3, 7e-3, 1.1e-4, 2.5e-2;
  const VectorXd H = F(s, h);
  CHECK(H[0] == doctest::Approx(h[0] + series_g({h[1], h[3], h[2]})).epsilon(1e-13));
  CHECK(H[1] == doctest::Approx(h[1] + series_g({h[0], h[2], h[3]})).epsilon(1e-13));
  CHECK(H[2] == doctest::Approx(h[2] + series_g({h[0], h[1], h[3]})).epsilon(1e-13));
  CHECK(H[3] == doctest::Approx(h[3] + series_g({h[1], h[0], h[2]})).epsilon(1e-13));
}

TEST_CASE("forward: thesis Fig. 2.14 (10 kOhm at (1,A), 100 Ohm elsewhere)") {
  // R_1A = 10k || (100 + 100 + 100); every other cell sees its 100 Ohm in parallel with the
  // path 100 + 10k + 100 through the loaded cell.
  const Shape s{2, 2};
  VectorXd r(4);
  r << 10e3, 100.0, 100.0, 100.0;
  const VectorXd R = F(s, r.cwiseInverse()).cwiseInverse();
  CHECK(R[0] == doctest::Approx(par(10e3, 300.0)).epsilon(1e-12));
  for (int a = 1; a < 4; ++a) CHECK(R[a] == doctest::Approx(par(100.0, 10.2e3)).epsilon(1e-12));
  // the 10 kOhm cell hides behind 300 Ohm: what the basic circuit measures is < 300 Ohm
  CHECK(R[0] < 300.0);
  CHECK(R[0] == doctest::Approx(291.26).epsilon(1e-4));
  CHECK(R[1] == doctest::Approx(99.03).epsilon(1e-4));
}

TEST_CASE("forward: agrees with brute-force nodal analysis (other ground node, LU)") {
  const Shape shapes[] = {{2, 2}, {3, 5}, {5, 3}, {1, 4}, {4, 1}, {6, 4}, {16, 16}};
  unsigned seed = 1;
  for (const Shape& s : shapes) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, seed++);
    const VectorXd G = F(s, g);
    CHECK(max_rel_err(G, brute_force_forward(s, g)) < 1e-11);
  }
}

TEST_CASE("forward: 1 x C and R x 1 arrays have no crosstalk paths") {
  // a single row: every column node hangs off row 0 by one cell, so G = g exactly
  const Shape s{1, 5};
  const VectorXd g = random_g(s, 7);
  CHECK(max_rel_err(F(s, g), g) < 1e-14);
  const Shape t{5, 1};
  CHECK(max_rel_err(F(t, g), g) < 1e-14);
}

TEST_CASE("forward: symmetry, permutation, scaling (linear reciprocal network)") {
  const Shape s{3, 5}, st{5, 3};
  const VectorXd g = random_g(s, 11);
  const VectorXd G = F(s, g);
  SUBCASE("transposing g transposes G (rows and columns play the same role)") {
    CHECK(max_rel_err(F(st, transpose_cells(s, g)), transpose_cells(s, G)) < 1e-12);
  }
  SUBCASE("permuting rows/columns permutes G: the ground node (row 0) is not special") {
    const Eigen::Map<const RowMatrixXd> gm(g.data(), 3, 5), Gm(G.data(), 3, 5);
    const int rp[3] = {2, 0, 1}, cp[5] = {4, 2, 0, 3, 1};
    RowMatrixXd gp(3, 5), Gp(3, 5);
    for (int i = 0; i < 3; ++i)
      for (int p = 0; p < 5; ++p) {
        gp(i, p) = gm(rp[i], cp[p]);
        Gp(i, p) = Gm(rp[i], cp[p]);
      }
    const VectorXd gv = Eigen::Map<const VectorXd>(gp.data(), 15);
    const VectorXd Gv = Eigen::Map<const VectorXd>(Gp.data(), 15);
    CHECK(max_rel_err(F(s, gv), Gv) < 1e-12);
  }
  SUBCASE("F(c g) = c F(g): resistive networks are homogeneous of degree 1") {
    for (double c : {3.7, 1e-3, 1e4}) {
      CAPTURE(c);
      CHECK(max_rel_err(F(s, c * g), c * G) < 1e-12);
    }
  }
}

TEST_CASE("forward: Rayleigh bounds  g + path <= G <= g + (row || column shorted)") {
  // Lower: removing every other cell but one path can only lower G (Rayleigh monotonicity);
  // with all other cells present G > g strictly. Upper: shorting all the other nodes
  // together can only raise G; then the rest of row i (sum_q!=p g_iq) and the rest of
  // column p (sum_j!=i g_jp) are in series, in parallel with g_ip.
  const Shape s{4, 6};
  const VectorXd g = random_g(s, 23);
  const VectorXd G = F(s, g);
  const Index R = s.rows, C = s.cols;
  for (Index i = 0; i < R; ++i)
    for (Index p = 0; p < C; ++p) {
      const Index a = i * C + p;
      double row_rest = 0, col_rest = 0;
      for (Index q = 0; q < C; ++q)
        if (q != p) row_rest += g[i * C + q];
      for (Index j = 0; j < R; ++j)
        if (j != i) col_rest += g[j * C + p];
      const Index j = (i + 1) % R, q = (p + 1) % C;  // one 3-cell detour i-q-j-p
      const double lower = g[a] + series_g({g[i * C + q], g[j * C + q], g[j * C + p]});
      const double upper = g[a] + series_g({row_rest, col_rest});
      CHECK(G[a] > g[a]);
      CHECK(G[a] >= lower * (1 - 1e-14));
      CHECK(G[a] <= upper * (1 + 1e-14));
    }
}

TEST_CASE("forward: Foster's theorem  sum_a g_a / G_a = R + C - 1") {
  // For any connected resistor network, sum over edges of g_e * R_eff(e) = (nodes - 1):
  // here the edges are the cells, R_eff = 1/G, and the network has R + C nodes.
  unsigned seed = 51;
  for (Shape s : {Shape{2, 2}, Shape{3, 5}, Shape{7, 2}, Shape{16, 16}}) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    const VectorXd g = random_g(s, seed++, 1e-6, 1e-1);
    const double sum = (g.array() / F(s, g).array()).sum();
    CHECK(sum == doctest::Approx(double(s.nodes() - 1)).epsilon(1e-12));
  }
  for (const RefCase& c : load_forward_reference()) {
    CAPTURE(c.name);
    CHECK((c.g.array() / F(c.shape, c.g).array()).sum() ==
          doctest::Approx(double(c.shape.nodes() - 1)).epsilon(1e-12));
  }
}

TEST_CASE("forward: reference vectors (independent NumPy implementation), rel 1e-12") {
  for (const RefCase& c : load_forward_reference()) {
    CAPTURE(c.name);
    const VectorXd G = F(c.shape, c.g);
    const double err = max_rel_err(G, c.G);
    CAPTURE(err);
    CHECK(err < 1e-12);
    // and the reference itself agrees with plain nodal analysis (checks the checker)
    CHECK(max_rel_err(brute_force_forward(c.shape, c.g), c.G) < 1e-10);
  }
}

TEST_CASE("forward: reusing one NodalInverse gives the same answer (no stale state)") {
  const Shape s{5, 4};
  const VectorXd g1 = random_g(s, 31), g2 = random_g(s, 32, 1e-6, 1.0);
  NodalInverse net(s);
  VectorXd G1(s.cells()), G2(s.cells()), G1b(s.cells());
  REQUIRE(forward(g1, net, G1));
  REQUIRE(forward(g2, net, G2));
  REQUIRE(forward(g1, net, G1b));
  CHECK((G1 - G1b).cwiseAbs().maxCoeff() == 0.0);
  CHECK(max_rel_err(G2, brute_force_forward(s, g2)) < 1e-10);
}

TEST_CASE("forward: a cell with g = 0 in a connected network") {
  // g01 = 0 in the 2x2 ring: only the series path a-c-d remains between r0 and c1
  const Shape s{2, 2};
  VectorXd g(4);
  g << 1.0, 0.0, 3.0, 4.0;
  const VectorXd G = F(s, g);
  CHECK(G[1] == doctest::Approx(series_g({1.0, 3.0, 4.0})).epsilon(1e-14));
  CHECK(G[0] == doctest::Approx(1.0).epsilon(1e-14));  // the ring is open: no second path
}

TEST_CASE("forward: disconnected or invalid networks are reported as false") {
  const Shape s{4, 4};
  NodalInverse net(s);
  VectorXd G(s.cells());
  SUBCASE("a row with no conducting cell") {
    for (Index i : {Index(0), Index(2)}) {  // the ground row and another row
      CAPTURE(i);
      VectorXd g = random_g(s, 41);
      g.segment(i * 4, 4).setZero();
      CHECK_FALSE(forward(g, net, G));
    }
  }
  SUBCASE("a column with no conducting cell") {
    VectorXd g = random_g(s, 42);
    for (Index i = 0; i < 4; ++i) g[i * 4 + 3] = 0.0;
    CHECK_FALSE(forward(g, net, G));
  }
  SUBCASE("two islands, no zero row or column (block diagonal g)") {
    VectorXd g = VectorXd::Zero(16);
    g[0 * 4 + 0] = g[0 * 4 + 1] = g[1 * 4 + 0] = g[1 * 4 + 1] = 1e-3;  // rows 0,1 x cols 0,1
    g[2 * 4 + 2] = g[2 * 4 + 3] = g[3 * 4 + 2] = g[3 * 4 + 3] = 1e-3;  // rows 2,3 x cols 2,3
    CHECK_FALSE(forward(g, net, G));
  }
  SUBCASE("the ground row (row 0) empty: the rest floats, for any values of g") {
    // Without row 0 nothing is tied to ground: the grounded matrix is a plain Laplacian,
    // singular in exact arithmetic whatever the other conductances are. A Cholesky may still
    // "succeed" on a round-off pivot, so this is checked over many shapes and values.
    VectorXd g2(4), G2(4);
    g2 << 0.0, 0.0, 0.1, 0.3;  // smallest case: 2x2, row 0 empty
    NodalInverse net2(Shape{2, 2});
    CHECK_FALSE(forward(g2, net2, G2));
    int reported_connected = 0, trials = 0;
    for (Index R = 2; R <= 6; ++R)
      for (Index C = 2; C <= 6; ++C)
        for (unsigned seed = 0; seed < 3; ++seed) {
          const Shape t{R, C};
          VectorXd g = random_g(t, 60 + seed * 100 + static_cast<unsigned>(R * 10 + C));
          g.head(C).setZero();
          NodalInverse n(t);
          VectorXd Gt(t.cells());
          ++trials;
          if (forward(g, n, Gt)) ++reported_connected;
        }
    CAPTURE(trials);
    CHECK(reported_connected == 0);
  }
  SUBCASE("a floating island (no cell between two blocks), random g") {
    int reported_connected = 0, trials = 0;
    for (Index R = 2; R <= 6; ++R)
      for (Index C = 2; C <= 6; ++C)
        for (unsigned seed = 0; seed < 3; ++seed) {
          const Shape t{R, C};
          VectorXd g = random_g(t, 70 + seed * 100 + static_cast<unsigned>(R * 10 + C));
          for (Index i = 0; i < R; ++i)
            for (Index p = 0; p < C; ++p)
              if ((i < R / 2) != (p < C / 2)) g[i * C + p] = 0.0;
          NodalInverse n(t);
          VectorXd Gt(t.cells());
          ++trials;
          if (forward(g, n, Gt)) ++reported_connected;
        }
    CAPTURE(trials);
    CHECK(reported_connected == 0);
  }
  SUBCASE("non-finite entries") {
    VectorXd g = random_g(s, 43);
    g[5] = std::numeric_limits<double>::quiet_NaN();
    CHECK_FALSE(forward(g, net, G));
    g[5] = std::numeric_limits<double>::infinity();
    CHECK_FALSE(forward(g, net, G));
  }
  SUBCASE("after a failure the same workspace recovers") {
    VectorXd bad = random_g(s, 44);
    bad.segment(0, 4).setZero();
    CHECK_FALSE(forward(bad, net, G));
    const VectorXd g = random_g(s, 45);
    REQUIRE(forward(g, net, G));
    CHECK(max_rel_err(G, brute_force_forward(s, g)) < 1e-11);
  }
}

TEST_CASE("NodalInverse: M is the inverse of the grounded Laplacian, at a floor-to-load range") {
  // M by blocks (Schur complement of the column nodes, laplacian.hpp) against an LU inverse of the
  // whole grounded Laplacian (eq. 2.7, row 0 dropped) in long double, with rows and columns of
  // cells at the bounded solvers' floor (1e-12 S) beside loaded ones (1e-4...1e-2 S), as on noisy
  // frames. The ground row stays loaded: a network tied to ground only through floor cells has a
  // condition number ~1e10 and loses ~1e-8 to round-off in any double inverse.
  const Shape shapes[] = {{1, 4}, {4, 1}, {2, 2}, {3, 5}, {7, 2}, {16, 16}, {9, 20}};
  unsigned seed = 40;
  for (const Shape& s : shapes) {
    CAPTURE(s.rows);
    CAPTURE(s.cols);
    for (int floor = 0; floor < 2; ++floor) {
      CAPTURE(floor);
      VectorXd g = random_g(s, seed++);
      if (floor == 1)
        for (Index a = 0; a < g.size(); ++a)
          if (a >= s.cols && ((a / s.cols) % 3 == 1 || (a % s.cols) % 4 == 2 || a % 5 == 0))
            g[a] = 1e-12;
      Eigen::MatrixXd L;
      REQUIRE(psmat::iecm::cell_laplacian(s, g, L));
      const Index n = s.nodes();
      using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
      const MatrixXld Lld = L.bottomRightCorner(n - 1, n - 1).cast<long double>();
      const Eigen::MatrixXd inner = MatrixXld(Lld.fullPivLu().inverse()).cast<double>();
      // the dispatch (the widest vector unit), the baseline kernel, and each unit this CPU runs
      // (nodal_inverse_kernel.hpp through simd.hpp's table)
      const auto units = psmat::iecm::simd_kernels_available();
      for (size_t path = 0; path < 2 + units.size(); ++path) {
        const std::string name = path == 0 ? "dispatch" : path == 1 ? "baseline" : units[path - 2]->name;
        CAPTURE(name);
        Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
        if (path < 2) {
          NodalInverse net(s);
          REQUIRE(net.compute(g, path == 1));
          M = net.M();
        } else {
          VectorXd work(psmat::iecm::nodal_inverse_work_size(s.rows, s.cols));
          REQUIRE(units[path - 2]->nodal_inverse(g.data(), s.rows, s.cols, M.data(), work.data()));
        }
        CHECK(M.row(0).cwiseAbs().maxCoeff() == 0.0);  // the ground node
        CHECK(M.col(0).cwiseAbs().maxCoeff() == 0.0);
        const Eigen::MatrixXd d = M.bottomRightCorner(n - 1, n - 1) - inner;
        CHECK(d.cwiseAbs().maxCoeff() <= 1e-12 * inner.cwiseAbs().maxCoeff());
        CHECK((M - M.transpose()).cwiseAbs().maxCoeff() <= 1e-14 * M.cwiseAbs().maxCoeff());
      }
    }
  }
}
