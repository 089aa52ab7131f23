// The vector units of simd.hpp give the same bits wherever their arrays lie. Eigen's vectorised
// sums follow the alignment of their data (a sum that starts on a 64-byte boundary groups its
// terms otherwise than one that does not), so a kernel whose result depended on where the heap
// put its arrays would make a solve differ in its last bits between two processes, or between a
// fresh solver and a reused one, and break the bit-for-bit equality of study results across
// workers (docs/spec.md §12). Each kernel runs on copies of the same data shifted by 8 to 56
// bytes (floats: 4 to 60) and must return identical bits.
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "psmat/iecm/simd.hpp"
#include "support.hpp"

using namespace psmat_test;

namespace simd_test {

// The same values at an address shifted by `shift` elements from the start of a fresh buffer.
template <class T>
struct Shifted {
  std::vector<T> buf;
  T* p;
  Shifted(const T* src, size_t n, size_t shift) : buf(n + 16), p(buf.data() + shift) {
    std::memcpy(p, src, n * sizeof(T));
  }
};

template <class T>
bool same_bits(const T* a, const T* b, size_t n) {
  return std::memcmp(a, b, n * sizeof(T)) == 0;
}

}  // namespace simd_test

using simd_test::Shifted;
using simd_test::same_bits;

TEST_CASE("vector units: the same bits wherever their arrays lie") {
  const auto units = psmat::iecm::simd_kernels_available();
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> U(0.05, 1.0);
  for (const psmat::iecm::SimdKernels* u : units) {
    const std::string unit = u->name;
    CAPTURE(unit);
    for (Shape s : {Shape{5, 5}, Shape{6, 6}, Shape{5, 8}, Shape{16, 19}, Shape{17, 20}}) {
      const Index R = s.rows, C = s.cols, n = R + C, cells = R * C;
      CAPTURE(R);
      CAPTURE(C);
      std::vector<double> g(static_cast<size_t>(cells)), v(static_cast<size_t>(cells));
      for (auto& x : g) x = U(rng);
      for (auto& x : v) x = U(rng) < 0.3 ? 0.0 : U(rng) - 0.5;
      const size_t nn = static_cast<size_t>(n * n), nw = static_cast<size_t>(
                                                       psmat::iecm::nodal_inverse_work_size(R, C));
      std::vector<double> m0, out0;
      for (size_t shift = 0; shift < 8; ++shift) {
        CAPTURE(shift);
        // the block inverse of the nodal matrix
        Shifted<double> gs(g.data(), g.size(), shift);
        std::vector<double> zeros(nn, 0.0), w(nw, 0.0);
        Shifted<double> ms(zeros.data(), nn, shift), ws(w.data(), nw, shift);
        REQUIRE(u->nodal_inverse(gs.p, R, C, ms.p, ws.p));
        if (shift == 0) m0.assign(ms.p, ms.p + nn);
        CHECK(same_bits(m0.data(), ms.p, nn));
        // the matrix-free product on that M
        Shifted<double> Ms(m0.data(), nn, shift), vs(v.data(), v.size(), shift);
        std::vector<double> out(static_cast<size_t>(cells) + 16), Pt(nn + 16),
            kdiag(static_cast<size_t>(n + 4 * R) + 16);
        u->hadamard_kernel(Ms.p, R, C, vs.p, out.data() + shift, Pt.data() + shift,
                           kdiag.data() + shift);
        if (shift == 0) out0.assign(out.data(), out.data() + cells);
        CHECK(same_bits(out0.data(), out.data() + shift, static_cast<size_t>(cells)));
      }
    }
    // the float kernels of the preconditioners: a Cholesky factor (full and partial), its solves,
    // C -= A B and y -= A x, A^T x
    for (Index m : {Index(21), Index(150)}) {
      CAPTURE(m);
      const Index k = 6, part = 2 * m / 3;
      const Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(
          m, m, [m](Index i, Index j) { return std::cos(0.37 * double(i * m + j) + 0.1); });
      const Eigen::MatrixXf A = (X * X.transpose() / double(m) + Eigen::MatrixXd::Identity(m, m)).cast<float>();
      const Eigen::MatrixXf B = Eigen::MatrixXf::NullaryExpr(
          m, k, [](Index i, Index j) { return std::sin(0.9 * float(i) + 0.4f * float(j)); });
      const size_t mm = static_cast<size_t>(m * m), mk = static_cast<size_t>(m * k);
      std::vector<float> L0, P0, S0, T0, G0, y00, y10;
      for (size_t shift = 0; shift < 16; ++shift) {
        CAPTURE(shift);
        Shifted<float> L(A.data(), mm, shift), P(A.data(), mm, shift);
        REQUIRE(u->cholesky_in_place(L.p, m, m));
        REQUIRE(u->cholesky_partial_in_place(P.p, m, m, part));
        Shifted<float> S(B.data(), mk, shift), T(B.data(), static_cast<size_t>(m), shift);
        u->lower_solve_matrix(L.p, m, m, S.p, k, m, 1);
        u->cholesky_solve_in_place(L.p, m, m, T.p);
        Shifted<float> Gm(B.data(), mk, shift), y0(B.data(), static_cast<size_t>(m), shift),
            y1(B.data(), static_cast<size_t>(k), shift);
        u->gemm_subtract(Gm.p, m, k, m, L.p, k, m, S.p, m);  // C -= L[:, :k] S[:k, :]
        u->gemv_subtract(y0.p, L.p, m, k, m, T.p, false);
        u->gemv_subtract(y1.p, L.p, m, k, m, T.p, true);
        if (shift == 0) {
          L0.assign(L.p, L.p + mm);
          P0.assign(P.p, P.p + mm);
          S0.assign(S.p, S.p + mk);
          T0.assign(T.p, T.p + m);
          G0.assign(Gm.p, Gm.p + mk);
          y00.assign(y0.p, y0.p + m);
          y10.assign(y1.p, y1.p + k);
        }
        // the lower triangles (the factor; the partial one's trailing Schur complement): the strict
        // upper triangles are workspace
        bool factors_same = true;
        for (Index j = 0; j < m; ++j)
          for (Index i = j; i < m; ++i) {
            const size_t a = static_cast<size_t>(j * m + i);
            factors_same &= same_bits(&L0[a], L.p + a, 1) && same_bits(&P0[a], P.p + a, 1);
          }
        CHECK(factors_same);
        CHECK(same_bits(S0.data(), S.p, mk));
        CHECK(same_bits(T0.data(), T.p, static_cast<size_t>(m)));
        CHECK(same_bits(G0.data(), Gm.p, mk));
        CHECK(same_bits(y00.data(), y0.p, static_cast<size_t>(m)));
        CHECK(same_bits(y10.data(), y1.p, static_cast<size_t>(k)));
      }
    }
  }
}
