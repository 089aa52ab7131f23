// The active-set Newton for noisy frames (solve_active_set.cpp, docs/spec.md §3 complementarity
// problem): its pieces — the free block of S, the PCG solve with a stale factor — against
// dense linear algebra, and its answer against the Fischer-Burmeister reference
// (solve_bounded_newton.cpp) on a noisy stream: same bound set, same free cells.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "psmat/iecm/free_block_solver.hpp"
#include "psmat/iecm/cholesky.hpp"
#include "psmat/iecm/simd.hpp"
#include "psmat/iecm/jacobian.hpp"
#include "psmat/iecm/solve.hpp"
#include "support.hpp"

using namespace psmat_test;
using psmat::iecm::FreeBlockSolver;
using psmat::iecm::Method;
using psmat::iecm::NewtonOperator;
using psmat::iecm::NodalInverse;

namespace {
// The code paths of the dense kernels: 0 the dispatch (simd.hpp's choice), 1 the baseline sweep
// (where it has a name of its own), 2... each vector unit this build has and this CPU runs.
const std::vector<const psmat::iecm::SimdKernels*>& units() {
  static const auto u = psmat::iecm::simd_kernels_available();
  return u;
}
int n_paths() { return 2 + static_cast<int>(units().size()); }
const char* path_name(int path) {
  return path == 0 ? "dispatch" : path == 1 ? "baseline" : units()[size_t(path - 2)]->name;
}
}  // namespace
using psmat::iecm::SolveOptions;
using psmat::iecm::SolveReport;
using psmat::iecm::Solver;
using psmat::iecm::Status;

namespace {

// Every third cell or so, in a fixed irregular pattern (unsorted on purpose where allowed).
std::vector<Index> some_cells(Index n, Index step, Index offset) {
  std::vector<Index> out;
  for (Index a = offset; a < n; a += step) out.push_back(a);
  return out;
}

MatrixXd dense_S(Shape s, const VectorXd& g) {
  NodalInverse net(s);
  REQUIRE(net.compute(g));
  MatrixXd S;
  scaled_hadamard(net, F(s, g), S, /*lower_only=*/false);
  return S;
}

// A network at random conductances in [lo, hi] (S): g, its nodal inverse and its readings G.
struct RandomNetwork {
  RandomNetwork(Shape shape, unsigned seed, double lo, double hi)
      : s(shape), g(random_g(shape, seed, lo, hi)), net(shape) {
    REQUIRE(net.compute(g));
    G = F(s, g);
  }
  Shape s;
  VectorXd g;
  NodalInverse net;
  VectorXd G;
};

// The dense reference of a free-block solve: S_II y_I = b_I, y_I in the order of I.
VectorXd dense_free_solve(const MatrixXd& S, const std::vector<Index>& I, const VectorXd& b) {
  const Index m = Index(I.size());
  MatrixXd K(m, m);
  VectorXd bI(m);
  for (Index r = 0; r < m; ++r) {
    bI[r] = b[I[size_t(r)]];
    for (Index q = 0; q < m; ++q) K(r, q) = S(I[size_t(r)], I[size_t(q)]);
  }
  return K.llt().solve(bI);
}

// A noisy recording: a loaded blob that drifts over a quiet background (leakage 1e-7 S), read
// with additive noise of 1.5e-7 S on G (the size of 1 mV on the ADC node for a quiet cell,
// docs/spec.md §2), so most background cells end at the bound.
VectorXd noisy_frame(Shape s, int t, unsigned seed) {
  VectorXd g = VectorXd::Constant(s.cells(), 1e-7);
  const double ci = 0.4 * double(s.rows) + 0.3 * std::sin(0.3 * t), cp = 0.5 * double(s.cols);
  for (Index i = 0; i < s.rows; ++i)
    for (Index p = 0; p < s.cols; ++p) {
      const double r2 = (double(i) - ci) * (double(i) - ci) + (double(p) - cp) * (double(p) - cp);
      if (r2 < 6.0) g[i * s.cols + p] = 3e-3 * std::exp(-r2 / 4.0);
    }
  const VectorXd noise = random_normal(s.cells(), seed + static_cast<unsigned>(t));
  return (F(s, g).array() + 1.5e-7 * noise.array()).max(2e-7).matrix();
}

// Free cells agree within 1e-8 g + kAmplification * rtol * G: both solvers stop at a residual
// <= rtol relative to G, which fixes a free cell to about rtol * G_a / lambda, lambda the
// smallest eigenvalue of S on the free cells (~3e-4 on noisy 16x16 twin frames: quiet cells of
// quiet rows are nearly interchangeable). Tightening rtol stops helping near 1e-12, the
// round-off of F at these dynamic ranges. Loaded cells (g >= 1e-4 S) meet 1e-8 g outright.
constexpr double kAmplification = 1e3;
bool same_free_cell(double g, double g_ref, double G, double rtol) {
  return std::abs(g - g_ref) <= 1e-8 * g_ref + kAmplification * rtol * G;
}

}  // namespace

// doctest::Approx(x).epsilon(e) alone allows e·(1 + |x|), an absolute tolerance for small x;
// .scale(1e-300) makes it relative (e·|x|), which is what the small conductances here need.

TEST_CASE("scaled_hadamard_block: the principal submatrix of S, lower triangle") {
  RandomNetwork x({5, 7}, 2100, 1e-7, 1e-2);
  const Shape s = x.s;
  const NodalInverse& net = x.net;
  const VectorXd& G = x.G;
  MatrixXd S;
  scaled_hadamard(net, G, S, /*lower_only=*/false);
  const std::vector<Index> cells = some_cells(s.cells(), 3, 1);
  const Index m = Index(cells.size());
  MatrixXd K(m, m);
  psmat::iecm::scaled_hadamard_block<double>(net, G, cells, K);
  Eigen::MatrixXf Kbig = Eigen::MatrixXf::Zero(m + 3, m + 3);  // into the corner of a larger one
  psmat::iecm::scaled_hadamard_block<float>(net, G, cells, Kbig.topLeftCorner(m, m));
  for (Index q = 0; q < K.cols(); ++q)
    for (Index r = q; r < K.rows(); ++r) {
      const double ref = S(cells[size_t(r)], cells[size_t(q)]);
      CHECK(K(r, q) == doctest::Approx(ref).epsilon(1e-12).scale(1e-300));
      CHECK(double(Kbig(r, q)) == doctest::Approx(ref).epsilon(1e-6).scale(1e-300));
    }
  CHECK(Kbig.rightCols(3).norm() == 0.0f);
  // one column, with a hole (-1) in the list
  std::vector<Index> with_hole = cells;
  with_hole[2] = -1;
  const Index b = 4;
  Eigen::VectorXf col(m);
  psmat::iecm::scaled_hadamard_column(net, G, with_hole, b, col);
  for (Index r = 0; r < m; ++r) {
    const double ref = r == 2 ? 0.0 : S(cells[size_t(r)], b);
    CHECK(double(col[r]) == doctest::Approx(ref).epsilon(1e-6).scale(1e-300));
  }
}

TEST_CASE("cholesky_in_place: L L^T = A across block edges and both sweeps; false if indefinite") {
  // sizes around the 16-column blocks, the switch to the right-looking sweep at 400 rows, and
  // its 32-column blocks; L against Eigen's LLT in double on the same float matrix
  for (Index m : {1, 15, 16, 17, 130, 400, 401, 450}) {
    CAPTURE(m);
    const Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(
        m, m, [m](Index i, Index j) { return std::sin(1.3 * double(i * m + j) + 0.7); });
    const Eigen::MatrixXf A = (X * X.transpose() / double(m) +
                               Eigen::MatrixXd::Identity(m, m)).cast<float>();
    Eigen::MatrixXf L = A;
    L.triangularView<Eigen::StrictlyUpper>().setConstant(1e30f);  // not read
    REQUIRE(psmat::iecm::cholesky_in_place(L));
    const Eigen::MatrixXd Lref = A.cast<double>().llt().matrixL();
    const Eigen::MatrixXd Lf = L.triangularView<Eigen::Lower>().toDenseMatrix().cast<double>();
    CHECK((Lf - Lref).norm() <= 1e-5 * Lref.norm());
  }
  Eigen::MatrixXf B = Eigen::MatrixXf::Identity(40, 40);
  B(25, 25) = -1.0f;
  CHECK_FALSE(psmat::iecm::cholesky_in_place(B));
}

TEST_CASE("cholesky_in_place: every vector unit and the baseline sweep, in a corner of a larger matrix") {
  // the free block lives in the corner of a bigger buffer (FreeBlockSolver): a leading dimension
  // above m; every code path against Eigen's LLT in double, the rest untouched
  const std::string in_use = psmat::iecm::simd_kernels_name();
  CAPTURE(in_use);
  CAPTURE(units().size());
  for (Index m : {17, 130, 401, 700}) {
    CAPTURE(m);
    const Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(
        m, m, [m](Index i, Index j) { return std::cos(0.7 * double(i * m + j) + 0.3); });
    const Eigen::MatrixXf A = (X * X.transpose() / double(m) +
                               Eigen::MatrixXd::Identity(m, m)).cast<float>();
    const Eigen::MatrixXd Lref = A.cast<double>().llt().matrixL();
    for (int kernel = 0; kernel < n_paths(); ++kernel) {
      const std::string path = path_name(kernel);
      CAPTURE(path);
      Eigen::MatrixXf big = Eigen::MatrixXf::Constant(m + 5, m + 5, 7.0f);
      big.topLeftCorner(m, m) = A;
      const bool ok = kernel == 0   ? psmat::iecm::cholesky_in_place(big.topLeftCorner(m, m))
                      : kernel == 1 ? psmat::iecm::cholesky_in_place_portable(big.topLeftCorner(m, m))
                                    : units()[size_t(kernel - 2)]->cholesky_in_place(big.data(), m, big.outerStride());
      REQUIRE(ok);
      const Eigen::MatrixXd Lf =
          big.topLeftCorner(m, m).triangularView<Eigen::Lower>().toDenseMatrix().cast<double>();
      CHECK((Lf - Lref).norm() <= 1e-5 * Lref.norm());
      CHECK(big.bottomRows(5).isConstant(7.0f));
      CHECK(big.rightCols(5).isConstant(7.0f));
    }
  }
  for (const psmat::iecm::SimdKernels* u : units()) {
    const std::string unit = u->name;
    CAPTURE(unit);
    Eigen::MatrixXf B = Eigen::MatrixXf::Identity(450, 450);
    B(420, 420) = -1.0f;  // indefinite in the right-looking sweep's last blocks
    CHECK_FALSE(u->cholesky_in_place(B.data(), B.rows(), B.outerStride()));
  }
}

TEST_CASE("cholesky_solve_in_place: (L L^T)^-1 b, every code path, the factor in a corner") {
  // the preconditioner's two triangular solves against a dense double solve with A itself
  for (Index m : {1, 9, 140, 333}) {
    CAPTURE(m);
    const Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(
        m, m, [m](Index i, Index j) { return std::cos(0.5 * double(i * m + j) + 0.1); });
    const Eigen::MatrixXd A = X * X.transpose() / double(m) + Eigen::MatrixXd::Identity(m, m);
    const VectorXd b = random_normal(m, 77);
    const VectorXd ref = A.ldlt().solve(b);
    Eigen::MatrixXf big = Eigen::MatrixXf::Constant(m + 4, m + 4, 1e30f);  // the rest: never read
    big.topLeftCorner(m, m) = A.cast<float>();
    REQUIRE(psmat::iecm::cholesky_in_place(big.topLeftCorner(m, m)));
    for (int kernel = 0; kernel < n_paths(); ++kernel) {
      const std::string path = path_name(kernel);
      CAPTURE(path);
      Eigen::VectorXf x = b.cast<float>();
      if (kernel == 0)
        psmat::iecm::cholesky_solve_in_place(big.topLeftCorner(m, m), x);
      else if (kernel == 1)
        psmat::iecm::cholesky_solve_in_place_portable(big.topLeftCorner(m, m), x);
      else
        units()[size_t(kernel - 2)]->cholesky_solve_in_place(big.data(), m, big.outerStride(), x.data());
      CHECK((x.cast<double>() - ref).norm() <= 1e-5 * ref.norm());
    }
  }
}

TEST_CASE("cholesky_rank1_update: the factor of A + w w^T, in a corner of a larger matrix") {
  for (Index m : {1, 2, 17, 150}) {
    CAPTURE(m);
    const Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(
        m, m, [m](Index i, Index j) { return std::cos(0.9 * double(i * m + j) + 0.2); });
    const Eigen::MatrixXd A = X * X.transpose() / double(m) + Eigen::MatrixXd::Identity(m, m);
    Eigen::VectorXd w = Eigen::VectorXd::NullaryExpr(m, [](Index i) { return std::sin(2.1 * double(i) + 1.0); });
    w[0] = 0.0;  // a zero entry: nothing to rotate in that column
    Eigen::MatrixXf big = Eigen::MatrixXf::Constant(m + 3, m + 3, 7.0f);
    big.topLeftCorner(m, m) = Eigen::MatrixXd(A.llt().matrixL()).cast<float>();
    big.topLeftCorner(m, m).triangularView<Eigen::StrictlyUpper>().setConstant(1e30f);  // not read
    Eigen::VectorXf wf = w.cast<float>();
    psmat::iecm::cholesky_rank1_update(big.topLeftCorner(m, m), wf);
    const Eigen::MatrixXd L = big.topLeftCorner(m, m).triangularView<Eigen::Lower>().toDenseMatrix().cast<double>();
    const Eigen::MatrixXd ref = A + w * w.transpose();  // the definition, in double
    CHECK((L * L.transpose() - ref).norm() <= 1e-5 * ref.norm());
    for (Index k = 0; k < m; ++k) CHECK(L(k, k) > 0.0);  // still a Cholesky factor
    CHECK(big.rightCols(3).isConstant(7.0f));  // the rest of the matrix untouched
    CHECK(big.bottomRows(3).isConstant(7.0f));
    for (Index j = 1; j < m; ++j) CHECK(big.col(j).head(j).isConstant(1e30f));  // strict upper: untouched
  }
}

TEST_CASE("FreeBlockSolver: PCG with the factor of another point and free set solves the free block") {
  const Shape s{6, 6};
  const VectorXd g_old = random_g(s, 2200, 1e-6, 1e-2);
  VectorXd g = g_old;  // the point moved by up to 30 %
  for (Index a = 0; a < g.size(); ++a) g[a] *= 1.0 + 0.3 * std::sin(1.7 * double(a));
  NodalInverse net_old(s), net(s);
  REQUIRE(net_old.compute(g_old));
  REQUIRE(net.compute(g));
  const VectorXd G_old = F(s, g_old), G = F(s, g);
  const std::vector<Index> P = some_cells(s.cells(), 2, 0);  // factor's free set
  std::vector<Index> I = some_cells(s.cells(), 3, 0);         // current free set: some of P, others
  FreeBlockSolver fs;
  REQUIRE(fs.factor(net_old, G_old, P));
  CHECK(fs.changes(I) > 0);
  NewtonOperator op(s);
  const VectorXd b = random_normal(s.cells(), 2201);
  VectorXd y;
  VectorXd Sy;
  const int k = fs.solve(op, net, G, I, b, y, Sy, 1e-12, 200);
  CAPTURE(k);
  CHECK(k > 1);  // a stale preconditioner: more than one iteration, but it converges
  // dense reference: S_II y_I = b_I
  const MatrixXd S = dense_S(s, g);
  const Index m = Index(I.size());
  const VectorXd yI = dense_free_solve(S, I, b);
  std::vector<char> in_I(size_t(s.cells()), 0);
  for (Index r = 0; r < m; ++r) {
    in_I[size_t(I[size_t(r)])] = 1;
    CHECK(y[I[size_t(r)]] == doctest::Approx(yI[r]).epsilon(1e-8).scale(1e-300));
  }
  for (Index a = 0; a < s.cells(); ++a)
    if (!in_I[size_t(a)]) CHECK(y[a] == 0.0);
  // Sy: the dense S times the returned y, on every cell (the multipliers of the bound cells)
  const VectorXd Sy_ref = S * y;
  for (Index a = 0; a < s.cells(); ++a)
    CHECK(Sy[a] == doctest::Approx(Sy_ref[a]).epsilon(1e-9).scale(Sy_ref.norm()));
  // from a guess (the active-set method's later solves of one QP): the solution perturbed, with
  // entries outside I that must be ignored; fewer iterations, the same y and S y
  VectorXd yg = y + 1e-3 * y.norm() / std::sqrt(double(m)) * VectorXd::Ones(s.cells()), Syg;
  const int kg = fs.solve(op, net, G, I, b, yg, Syg, 1e-12, 200, /*from_guess=*/true);
  CAPTURE(kg);
  CHECK(kg >= 1);
  CHECK(kg < k);
  for (Index a = 0; a < s.cells(); ++a) {
    if (in_I[size_t(a)]) CHECK(yg[a] == doctest::Approx(y[a]).epsilon(1e-8).scale(y.norm()));
    else CHECK(yg[a] == 0.0);
    CHECK(Syg[a] == doctest::Approx(Sy_ref[a]).epsilon(1e-8).scale(Sy_ref.norm()));
  }
  // with a fresh factor at this very point PCG needs one or two iterations
  REQUIRE(fs.factor(net, G, I));
  CHECK(fs.changes(I) == 0);
  VectorXd y2;
  VectorXd Sy2;
  const int k2 = fs.solve(op, net, G, I, b, y2, Sy2, 1e-10, 200);
  CHECK(k2 >= 1);
  CHECK(k2 <= 3);
  CHECK((y2 - y).norm() <= 1e-8 * y.norm());
}

TEST_CASE("FreeBlockSolver::update: cells leave and join; PCG then solves the new free block") {
  RandomNetwork x({6, 7}, 2300, 1e-6, 1e-2);
  const Shape s = x.s;
  const NodalInverse& net = x.net;
  const VectorXd& G = x.G;
  const MatrixXd S = dense_S(s, x.g);
  const std::vector<Index> P = some_cells(s.cells(), 2, 0);  // even cells
  // I: P without three cells (first, middle, last position) and with four odd cells
  std::vector<Index> I;
  for (size_t k = 0; k < P.size(); ++k)
    if (k != 0 && k != P.size() / 2 && k + 1 != P.size()) I.push_back(P[k]);
  for (Index c : {1, 9, 17, 33}) I.push_back(c);
  FreeBlockSolver fs;
  REQUIRE(fs.factor(net, G, P));
  CHECK(fs.changes(I) == 7);
  REQUIRE(fs.update(net, G, I));
  CHECK(fs.changes(I) == 0);
  CHECK(fs.size() == Index(I.size()));
  // the updated factor is that of S_II (float round-off): PCG needs one or two steps and
  // returns the dense solution
  NewtonOperator op(s);
  const VectorXd b = random_normal(s.cells(), 2301);
  VectorXd y, Sy;
  const int k = fs.solve(op, net, G, I, b, y, Sy, 1e-10, 50);
  CHECK(k >= 1);
  CHECK(k <= 3);
  const Index m = Index(I.size());
  const VectorXd yI = dense_free_solve(S, I, b);
  for (Index r = 0; r < m; ++r) CHECK(y[I[size_t(r)]] == doctest::Approx(yI[r]).epsilon(1e-8).scale(1e-300));
  // back to P (the cells that left join again, the odd ones leave)
  REQUIRE(fs.update(net, G, P));
  CHECK(fs.changes(P) == 0);
  const int k2 = fs.solve(op, net, G, P, b, y, Sy, 1e-10, 50);
  CHECK(k2 >= 1);
  CHECK(k2 <= 3);
}

TEST_CASE("cholesky_partial_in_place: the leading factor and the Schur complement, every code path") {
  // against the definitions in double: L11 L11^T = A11, L21 = A21 L11^-T, Z = A22 - L21 L21^T;
  // sizes and leading widths across the 32-column blocks, the matrix in a corner
  for (auto mc : {std::pair<Index, Index>{1, 1}, {40, 0}, {70, 33}, {130, 64}, {450, 401}}) {
    const Index m = mc.first, c = mc.second, f = m - c;
    CAPTURE(m);
    CAPTURE(c);
    const Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(
        m, m, [m](Index i, Index j) { return std::sin(0.9 * double(i * m + j) + 0.4); });
    const Eigen::MatrixXd A = X * X.transpose() / double(m) + Eigen::MatrixXd::Identity(m, m);
    const Eigen::MatrixXd L11 = A.topLeftCorner(c, c).llt().matrixL();
    const Eigen::MatrixXd L21 =
        L11.triangularView<Eigen::Lower>().solve(A.bottomLeftCorner(f, c).transpose()).transpose();
    const Eigen::MatrixXd Z = A.bottomRightCorner(f, f) - L21 * L21.transpose();
    for (int kernel = 0; kernel < n_paths(); ++kernel) {
      const std::string path = path_name(kernel);
      CAPTURE(path);
      Eigen::MatrixXf big = Eigen::MatrixXf::Constant(m + 3, m + 3, 7.0f);
      big.topLeftCorner(m, m) = A.cast<float>();
      auto corner = big.topLeftCorner(m, m);
      REQUIRE((kernel == 0   ? psmat::iecm::cholesky_partial_in_place(corner, c)
               : kernel == 1 ? psmat::iecm::cholesky_partial_in_place_portable(corner, c)
                             : units()[size_t(kernel - 2)]->cholesky_partial_in_place(
                                   big.data(), m, big.outerStride(), c)));
      const Eigen::MatrixXd Lf = corner.cast<double>();
      const double tol = 1e-5 * A.norm();
      CHECK((Eigen::MatrixXd(Lf.topLeftCorner(c, c).triangularView<Eigen::Lower>()) - L11).norm() <= tol);
      CHECK((Lf.bottomLeftCorner(f, c) - L21).norm() <= tol);
      CHECK((Eigen::MatrixXd(Lf.bottomRightCorner(f, f).triangularView<Eigen::Lower>()) -
             Eigen::MatrixXd(Z.triangularView<Eigen::Lower>())).norm() <= tol);
      CHECK(big.bottomRows(3).isConstant(7.0f));
    }
  }
}

TEST_CASE("lower_solve_matrix and gemm_subtract: L^-1 B, (L L^T)^-1 B, L^-T B and C - A B") {
  const Index m = 90, k = 7;
  const Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(
      m, m, [](Index i, Index j) { return std::cos(0.3 * double(i * 90 + j) + 0.2); });
  const Eigen::MatrixXd A = X * X.transpose() / double(m) + Eigen::MatrixXd::Identity(m, m);
  const Eigen::MatrixXd L = A.llt().matrixL();
  const Eigen::MatrixXd B = Eigen::MatrixXd::NullaryExpr(
      m, k, [](Index i, Index j) { return std::sin(1.1 * double(i) + 0.7 * double(j)); });
  const Eigen::MatrixXf Lf = L.cast<float>();
  for (int mode = 0; mode < 3; ++mode)
    for (Index cols : {k, Index(1)}) {
      CAPTURE(mode);
      CAPTURE(cols);
      const Eigen::MatrixXd Bc = B.leftCols(cols);
      const Eigen::MatrixXd ref = mode == 0   ? Eigen::MatrixXd(L.triangularView<Eigen::Lower>().solve(Bc))
                                  : mode == 1 ? Eigen::MatrixXd(A.llt().solve(Bc))
                                              : Eigen::MatrixXd(L.transpose().triangularView<Eigen::Upper>().solve(Bc));
      for (int kernel = 0; kernel < n_paths(); ++kernel) {  // (no baseline of its own: path 1)
        if (kernel == 1) continue;
        const std::string path = path_name(kernel);
        CAPTURE(path);
        Eigen::MatrixXf Bf = Bc.cast<float>();
        if (kernel == 0)
          psmat::iecm::lower_solve_matrix(Lf, Bf, mode);
        else
          units()[size_t(kernel - 2)]->lower_solve_matrix(Lf.data(), m, m, Bf.data(), cols, m, mode);
        CHECK((Bf.cast<double>() - ref).norm() <= 1e-5 * ref.norm());
      }
    }
  const Eigen::MatrixXd P = B.topRows(k);  // k x k
  const Eigen::MatrixXf Bk = B.cast<float>(), Pk = P.cast<float>();
  const Eigen::MatrixXd Cref = Eigen::MatrixXd::Ones(m, k) - B * P;
  for (int kernel = 0; kernel < n_paths(); ++kernel) {
    if (kernel == 1) continue;
    const std::string path = path_name(kernel);
    CAPTURE(path);
    Eigen::MatrixXf C = Eigen::MatrixXf::Ones(m, k);
    if (kernel == 0)
      psmat::iecm::gemm_subtract(C, Bk, Pk);
    else
      units()[size_t(kernel - 2)]->gemm_subtract(C.data(), m, k, m, Bk.data(), k, m, Pk.data(), k);
    CHECK((C.cast<double>() - Cref).norm() <= 1e-5 * Cref.norm());
  }
  // y - A x and y - A^T x, A a block with a leading dimension larger than its rows (B's top m - 5
  // rows), x and y segments of longer vectors (as in FreeBlockSolver::precondition)
  const Index r = m - 5;
  const Eigen::VectorXd x = B.col(1), y0 = B.col(2).reverse();
  const Eigen::VectorXd ref_n = y0.head(r) - B.topRows(r) * x.head(k);
  const Eigen::VectorXd ref_t = y0.head(k) - B.topRows(r).transpose() * x.head(r);
  const Eigen::VectorXf xf = x.cast<float>();
  for (int kernel = 0; kernel < n_paths(); ++kernel) {
    const std::string path = path_name(kernel);
    CAPTURE(path);
    for (bool transpose : {false, true}) {
      CAPTURE(transpose);
      Eigen::VectorXf y = y0.cast<float>();
      const Index ny = transpose ? k : r, nx = transpose ? r : k;
      if (kernel == 0)
        psmat::iecm::gemv_subtract(y.head(ny), Bk.topRows(r), xf.head(nx), transpose);
      else if (kernel == 1)
        psmat::iecm::gemv_subtract_portable(y.head(ny), Bk.topRows(r), xf.head(nx), transpose);
      else
        units()[size_t(kernel - 2)]->gemv_subtract(y.data(), Bk.data(), r, k, m, xf.data(), transpose);
      const Eigen::VectorXd& ref = transpose ? ref_t : ref_n;
      CHECK((y.head(ny).cast<double>() - ref).norm() <= 1e-5 * ref.norm());
      CHECK(y.tail(m - ny).cast<double>() == y0.tail(m - ny).cast<float>().cast<double>());  // untouched
    }
  }
}

TEST_CASE("FreeBlockSolver split: core and fringe; select with fringe cells out, new cells and core cells out") {
  RandomNetwork x({7, 8}, 2400, 1e-6, 1e-2);
  const Shape s = x.s;
  const NodalInverse& net = x.net;
  const VectorXd& G = x.G;
  const MatrixXd S = dense_S(s, x.g);
  const std::vector<Index> core = some_cells(s.cells(), 3, 0);    // 0, 3, 6, ...
  const std::vector<Index> fringe = some_cells(s.cells(), 3, 1);  // 1, 4, 7, ...
  FreeBlockSolver fs;
  REQUIRE(fs.factor_split(net, G, core, fringe));
  CHECK(fs.is_split());
  NewtonOperator op(s);
  const VectorXd b = random_normal(s.cells(), 2401);
  // free sets: all of U; half the fringe; half the fringe and cells outside U (2, 5, 8, ...)
  // joining; and then two, then five core cells out (the capacitance correction)
  std::vector<std::vector<Index>> sets;
  std::vector<Index> U = core;
  U.insert(U.end(), fringe.begin(), fringe.end());
  sets.push_back(U);
  std::vector<Index> half = core;
  for (size_t k = 0; k < fringe.size(); k += 2) half.push_back(fringe[k]);
  sets.push_back(half);
  std::vector<Index> joined = half;
  for (Index c : {2, 5, 8, 29, 53}) joined.push_back(c);
  sets.push_back(joined);
  for (Index out : {2, 5}) {
    std::vector<Index> fewer;
    for (size_t k = 0; k < joined.size(); ++k)
      if (!(k < core.size() && k % 3 == 1 && Index(k / 3) < out)) fewer.push_back(joined[k]);
    sets.push_back(fewer);
  }
  for (size_t t = 0; t < sets.size(); ++t) {
    CAPTURE(t);
    const std::vector<Index>& I = sets[t];
    REQUIRE(fs.select(net, G, I));
    CHECK(fs.is_split());
    const Index out = fs.core_outside(I);
    CHECK(out == (t == 3 ? 2 : t == 4 ? 5 : 0));
    CHECK(fs.changes(I) == 0);  // the core cells out are not in the preconditioner's set
    VectorXd y, Sy;
    const int k = fs.solve(op, net, G, I, b, y, Sy, 1e-10, 50);
    CAPTURE(k);
    CHECK(k >= 1);
    CHECK(k <= 3);  // the preconditioner is S_II's (float round-off)
    const VectorXd yI = dense_free_solve(S, I, b);
    for (Index r = 0; r < Index(I.size()); ++r)
      CHECK(y[I[size_t(r)]] == doctest::Approx(yI[r]).epsilon(1e-8).scale(1e-300));
  }
  // a plain factor ends the split
  REQUIRE(fs.factor(net, G, core));
  CHECK_FALSE(fs.is_split());
  CHECK_FALSE(fs.select(net, G, core));
}

TEST_CASE("FreeBlockSolver split: a fringe that follows many small changes (updates, holes, compaction)") {
  // 12x12: core every fourth cell, fringe the next; each step two fringe cells leave and two cells
  // from outside U join, so the fringe factor is updated cell by cell (holes accumulate until a
  // quarter of its rows, then it is factorised anew) and the fringe outgrows its room (36 + 2 k
  // cells against 54 rows: the cells outside I are dropped)
  RandomNetwork x({12, 12}, 2500, 1e-6, 1e-2);
  const Shape s = x.s;
  const MatrixXd S = dense_S(s, x.g);
  const std::vector<Index> core = some_cells(s.cells(), 4, 0);
  std::vector<Index> fringe = some_cells(s.cells(), 4, 1);
  FreeBlockSolver fs;
  REQUIRE(fs.factor_split(x.net, x.G, core, fringe));
  NewtonOperator op(s);
  const VectorXd b = random_normal(s.cells(), 2501);
  std::vector<Index> outside = some_cells(s.cells(), 4, 2);
  const std::vector<Index> more = some_cells(s.cells(), 4, 3);
  outside.insert(outside.end(), more.begin(), more.end());
  std::vector<Index> in_fringe = fringe;
  size_t next = 0;
  for (int step = 0; step < 16; ++step) {
    CAPTURE(step);
    // two leave (the oldest), two join (cells never free before)
    in_fringe.erase(in_fringe.begin(), in_fringe.begin() + 2);
    in_fringe.push_back(outside[next++]);
    in_fringe.push_back(outside[next++]);
    std::vector<Index> I = core;
    I.insert(I.end(), in_fringe.begin(), in_fringe.end());
    REQUIRE(fs.select(x.net, x.G, I));
    CHECK(fs.changes(I) == 0);
    VectorXd y, Sy;
    const int k = fs.solve(op, x.net, x.G, I, b, y, Sy, 1e-10, 50);
    CAPTURE(k);
    CHECK(k >= 1);
    CHECK(k <= 3);  // the preconditioner is still S_II's factor (float round-off)
    const VectorXd yI = dense_free_solve(S, I, b);
    for (Index r = 0; r < Index(I.size()); ++r)
      CHECK(y[I[size_t(r)]] == doctest::Approx(yI[r]).epsilon(1e-8).scale(1e-300));
    for (Index c = 0; c < s.cells(); ++c)
      if (std::find(I.begin(), I.end(), c) == I.end()) CHECK(y[c] == 0.0);
  }
}

TEST_CASE("active_set: the Fischer-Burmeister solution on a noisy stream, bound set included") {
  // 10x10; and 24x24, whose free blocks (~200-300 cells) take the split factor of
  // FreeBlockSolver (solve_active_set.cpp, kSplitFrom)
  for (const Shape s : {Shape{10, 10}, Shape{24, 24}}) {
    CAPTURE(s.rows);
    const int frames = s.rows == 10 ? 12 : 5;
    SolveOptions o_as, o_fb;
    o_as.method = Method::ActiveSet;
    o_fb.method = Method::BoundedNewton;
    o_as.max_iter = o_fb.max_iter = 1000;
    Solver as(s, o_as), fb(s, o_fb);
    VectorXd g_as(s.cells()), g_fb(s.cells());
    int bound_total = 0;
    for (int t = 0; t < frames; ++t) {
      CAPTURE(t);
      const VectorXd G = noisy_frame(s, t, 2300);
      const SolveReport r_as = as.solve(G, g_as, t > 0), r_fb = fb.solve(G, g_fb, t > 0);
      REQUIRE(r_fb.converged());
      CAPTURE(r_as.iterations);
      CHECK(r_as.status == Status::Bounded);
      CHECK(r_as.residual <= o_as.rtol);
      CHECK(r_as.at_bound == r_fb.at_bound);
      bound_total += r_as.at_bound;
      const double floor = o_as.g_floor * (1.0 + 1e-9);
      double diff2 = 0.0, ref2 = 0.0;  // over the free cells: |g_as - g_fb| / |g_fb| <= 1e-8
      for (Index a = 0; a < s.cells(); ++a) {
        CHECK((g_as[a] <= floor) == (g_fb[a] <= floor));
        if (g_fb[a] > floor) {
          CHECK(same_free_cell(g_as[a], g_fb[a], G[a], o_as.rtol));
          diff2 += (g_as[a] - g_fb[a]) * (g_as[a] - g_fb[a]);
          ref2 += g_fb[a] * g_fb[a];
        }
        if (g_fb[a] >= 1e-4) CHECK(std::abs(g_as[a] - g_fb[a]) <= 1e-8 * g_fb[a]);
      }
      CHECK(std::sqrt(diff2) <= 1e-8 * std::sqrt(ref2));
      // complementarity checked directly: bound cells over-predict, free cells match G
      const VectorXd Fg = F(s, g_as);
      for (Index a = 0; a < s.cells(); ++a) {
        if (g_as[a] <= floor) CHECK(Fg[a] >= G[a] * (1.0 - 1e-9));
        else CHECK(std::abs(Fg[a] - G[a]) <= 1e-9 * G[a]);
      }
    }
    CHECK(bound_total > frames * 10);  // the noise puts background cells at the bound in every frame
  }
}

TEST_CASE("active_set: cold start and a warm start from a point with no cell at the bound") {
  const Shape s{8, 8};
  SolveOptions o;
  o.method = Method::ActiveSet;
  const VectorXd G = noisy_frame(s, 3, 2400);
  Solver cold(s, o);
  VectorXd g_cold(s.cells());
  const SolveReport rc = cold.solve(G, g_cold, false);
  CHECK(rc.status == Status::Bounded);
  Solver warm(s, o);
  VectorXd g_warm = VectorXd::Constant(s.cells(), 1e-4);
  const SolveReport rw = warm.solve(G, g_warm, true);
  CHECK(rw.status == Status::Bounded);
  for (Index a = 0; a < s.cells(); ++a) {
    if (g_cold[a] > o.g_floor * 2) CHECK(same_free_cell(g_warm[a], g_cold[a], G[a], o.rtol));
    else CHECK(g_warm[a] <= o.g_floor * 2);
  }
}

TEST_CASE("active_set: a warm start far from the frame is replaced by the cold point g = G") {
  // kFarStart (solve_active_set.cpp): a quiet mat with one blob, then a frame of another mat
  // loaded everywhere (2e-3 S under every cell). Warm-started from the first frame's solution
  // (background at the floor, where the second frame needs ~2e-3 S) max |phi| starts near 2, over
  // the cold point's bound of 1 (F(G) >= G): the frame starts from g = G and runs as a cold solve.
  const Shape s{16, 16};
  SolveOptions o;
  o.method = Method::ActiveSet;
  o.max_iter = 1000;
  const VectorXd A = noisy_frame(s, 0, 2500);
  VectorXd g_loaded = VectorXd::Constant(s.cells(), 2e-3);
  for (Index a = 0; a < s.cells(); a += 7) g_loaded[a] = 6e-3;
  const VectorXd noise = random_normal(s.cells(), 2501);
  const VectorXd B = F(s, g_loaded) + 1.5e-7 * noise;
  Solver warm(s, o), cold(s, o);
  VectorXd g_warm(s.cells()), g_cold(s.cells());
  REQUIRE(warm.solve(A, g_warm, false).converged());
  const SolveReport rw = warm.solve(B, g_warm, true), rc = cold.solve(B, g_cold, false);
  REQUIRE(rc.converged());
  CHECK(rw.converged());
  CHECK(!rw.used_fallback);
  CHECK(rw.iterations == rc.iterations);
  CHECK(rw.evaluations == rc.evaluations + 1);  // the cold point evaluated beside the warm start
  for (Index a = 0; a < s.cells(); ++a) CHECK(same_free_cell(g_warm[a], g_cold[a], B[a], o.rtol));
}

TEST_CASE("active_set: the result does not depend on what the heap held before the solve") {
  // Every buffer a frame reads is written first: a frame's numbers depend on its inputs and the
  // solver's state only, not on leftovers of freed memory (a process that ran other work before
  // computes the same numbers). The case that read one: a mat loaded everywhere (a split factor,
  // its core the 30 cells of a blob, the fringe the rest), then a frame far from it (kFarStart:
  // the cold point g = G, whose PDAS rule frees no cell at all). The first inner step with free
  // cells keeps the earlier frame's factor and used to start PCG from the QP's earlier solution,
  // which did not exist (no cell was free before): an uninitialised vector. Freed blocks of the
  // solver's vector size, filled with NaN, are what it would then find.
  const Shape s{16, 16};
  const Index n = s.cells();
  VectorXd gA(n);
  const VectorXd z = random_normal(n, 2600);
  for (Index a = 0; a < n; ++a) gA[a] = 1e-4 * std::exp(0.3 * z[a]);  // all above the noise
  for (Index r = 5; r < 10; ++r)
    for (Index c = 4; c < 10; ++c) gA[r * 16 + c] = 1e-2 * std::exp(0.3 * z[(r * 16 + c + 1) % n]);
  const VectorXd nA = random_normal(n, 2601), nB = random_normal(n, 2602);
  const VectorXd GA = F(s, gA).cwiseProduct((1.0 + 1e-4 * nA.array()).matrix());
  const VectorXd GB = F(s, VectorXd(0.05 * gA)).cwiseProduct((1.0 + 1e-4 * nB.array()).matrix());
  SolveOptions o;
  o.method = Method::ActiveSet;
  o.max_iter = 1000;
  auto run = [&](bool poison, SolveReport& rB) {
    Solver sv(s, o);
    VectorXd g(n);
    REQUIRE(sv.solve(GA, g, false).converged());
    if (poison) {  // in this thread: the blocks the next allocations of n doubles reuse
      std::vector<double*> blocks;
      for (int k = 0; k < 256; ++k) {
        double* p = static_cast<double*>(std::malloc(sizeof(double) * size_t(n)));
        REQUIRE(p != nullptr);
        std::fill(p, p + n, std::numeric_limits<double>::quiet_NaN());
        blocks.push_back(p);
      }
      for (double* p : blocks) std::free(p);
    }
    rB = sv.solve(GB, g, true);
    return g;
  };
  SolveReport clean, poisoned;
  const VectorXd g_clean = run(false, clean), g_poisoned = run(true, poisoned);
  REQUIRE(clean.converged());
  CHECK(poisoned.converged());
  CHECK(poisoned.iterations == clean.iterations);
  CHECK(poisoned.factorizations == clean.factorizations);
  CHECK(poisoned.krylov_iterations == clean.krylov_iterations);
  CHECK(poisoned.residual == clean.residual);
  Index same = 0;
  for (Index a = 0; a < n; ++a) same += g_poisoned[a] == g_clean[a];
  CHECK(same == n);  // bit for bit
}

TEST_CASE("pcg and pcg_from: the same solution from 0 and from a guess; Sy accumulated") {
  // numerics/pcg.hpp on an SPD system with a diagonal preconditioner: from y = 0 and from a guess
  // near the solution both reach the tolerance; the guess needs fewer steps, an exact guess none
  // (on_start sees A y0 in w.q); the hook accumulates A y along the way (as FreeBlockSolver's Sy)
  const Index m = 60;
  const Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(
      m, m, [](Index i, Index j) { return std::cos(0.7 * double(i * 60 + j) + 0.3); });
  const Eigen::MatrixXd A = X * X.transpose() / double(m) + 0.05 * Eigen::MatrixXd::Identity(m, m);
  const Eigen::VectorXd b = Eigen::VectorXd::NullaryExpr(m, [](Index i) { return std::sin(0.4 * double(i)); });
  const Eigen::VectorXd exact = A.llt().solve(b);
  const Eigen::VectorXd dinv = A.diagonal().cwiseInverse();
  psmat::numerics::PcgWork w;
  Eigen::VectorXd Ay;
  auto apply = [&](const Eigen::VectorXd& v, Eigen::VectorXd& q) { q = A * v; };
  auto pre = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = dinv.cwiseProduct(r); };
  auto step = [&](double alpha) { Ay.noalias() += alpha * w.q; };
  const double tol = 1e-10;
  Eigen::VectorXd y0;
  Ay.setZero(m);
  const int k0 = psmat::numerics::pcg(b, y0, tol, 500, w, apply, pre, step);
  REQUIRE(k0 > 0);
  CHECK((A * y0 - b).norm() <= tol * b.norm() * (1 + 1e-6));
  CHECK((Ay - A * y0).norm() <= 1e-10 * b.norm());
  Eigen::VectorXd y1 = exact + 1e-4 * Eigen::VectorXd::Ones(m);  // a guess near the solution
  bool started = false;
  auto start = [&] {
    started = true;
    Ay = w.q;
  };
  const int k1 = psmat::numerics::pcg_from(b, y1, tol, 500, w, apply, pre, step, start);
  CHECK(started);
  REQUIRE(k1 > 0);
  CHECK(k1 < k0);
  CHECK((A * y1 - b).norm() <= tol * b.norm() * (1 + 1e-6));
  CHECK((Ay - A * y1).norm() <= 1e-10 * b.norm());
  Eigen::VectorXd y2 = exact;  // already there: no step
  CHECK(psmat::numerics::pcg_from(b, y2, 1e-6, 500, w, apply, pre, step, start) == 0);
  CHECK(y2 == exact);
  CHECK((w.q - A * exact).norm() <= 1e-12 * b.norm());
}
