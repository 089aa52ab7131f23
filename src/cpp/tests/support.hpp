// Shared helpers of the psmat C++ unit tests: reference vectors, random arrays, and an
// independent brute-force circuit solver used as ground truth for the forward model.
#pragma once
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "psmat/iecm/forward.hpp"
#include "psmat/types.hpp"

#ifndef PSMAT_REFERENCE_DIR
#error "PSMAT_REFERENCE_DIR must be defined by the build (src/cpp/tests/CMakeLists.txt)"
#endif

namespace psmat_test {

using psmat::Index;
using psmat::RowMatrixXd;
using psmat::Shape;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// ---- reference vectors (tests/data/reference, independent NumPy implementation) -------------

inline std::string reference_path(const std::string& name) {
  return std::string(PSMAT_REFERENCE_DIR) + "/" + name;
}

struct RefCase {
  std::string name;
  Shape shape;
  VectorXd g, G, jac_row0, jac_col_last;  // row-major flattened
};

// All numbers of a (nested) JSON array in row-major order; a non-number FAILS the test.
inline void flatten_into(const nlohmann::json& v, std::vector<double>& out) {
  if (v.is_array()) {
    for (const auto& x : v) flatten_into(x, out);
  } else {
    REQUIRE(v.is_number());
    out.push_back(v.get<double>());
  }
}

inline VectorXd to_vec(const nlohmann::json& v) {
  std::vector<double> flat;
  flatten_into(v, flat);
  return Eigen::Map<const VectorXd>(flat.data(), static_cast<Index>(flat.size()));
}

// Loads every case of iecm_forward.json. A missing or malformed file FAILS the calling test
// (REQUIRE), it never passes silently.
inline std::vector<RefCase> load_forward_reference() {
  const std::string path = reference_path("iecm_forward.json");
  {
    std::ifstream probe(path);
    INFO("reference vectors expected at " << path << " (tests/data/reference in the repository)");
    REQUIRE(probe.good());
  }
  std::ifstream in(path);
  const nlohmann::json root = nlohmann::json::parse(in);  // throws (fails the test) if malformed
  std::vector<RefCase> out;
  for (const auto& [name, c] : root.at("cases").items()) {
    RefCase rc;
    rc.name = name;
    const auto& gj = c.at("g");
    rc.shape = Shape{static_cast<Index>(gj.size()), static_cast<Index>(gj.at(0).size())};
    rc.g = to_vec(gj);
    rc.G = to_vec(c.at("G"));
    rc.jac_row0 = to_vec(c.at("jacobian_row0"));
    rc.jac_col_last = to_vec(c.at("jacobian_col_last"));
    REQUIRE(rc.g.size() == rc.shape.cells());
    REQUIRE(rc.G.size() == rc.shape.cells());
    REQUIRE(rc.jac_row0.size() == rc.shape.cells());
    REQUIRE(rc.jac_col_last.size() == rc.shape.cells());
    out.push_back(std::move(rc));
  }
  // the README lists four cases; fewer means the file is not the one the tests were written for
  REQUIRE(out.size() == 4);
  return out;
}

inline const RefCase& find_case(const std::vector<RefCase>& cases, const std::string& name) {
  for (const auto& c : cases)
    if (c.name == name) return c;
  FAIL("reference case missing: " << name);
  throw std::runtime_error("unreachable");
}

// ---- arrays -------------------------------------------------------------------------------

// Cell conductances log-uniform in [lo, hi] S (100 Ohm .. 10 kOhm by default).
inline VectorXd random_g(Shape s, unsigned seed, double lo = 1e-4, double hi = 1e-2) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(std::log(lo), std::log(hi));
  VectorXd g(s.cells());
  for (Index a = 0; a < g.size(); ++a) g[a] = std::exp(u(rng));
  return g;
}

inline VectorXd random_normal(Index n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, 1.0);
  VectorXd v(n);
  for (Index a = 0; a < n; ++a) v[a] = nd(rng);
  return v;
}

// Forward model through the code under test (for round trips; its correctness is tested
// separately against hand solutions, the brute-force solver below and the reference).
inline VectorXd F(Shape s, const VectorXd& g) {
  psmat::iecm::NodalInverse net(s);
  VectorXd G(s.cells());
  REQUIRE(psmat::iecm::forward(g, net, G));
  return G;
}

// Transpose of a row-major R x C cell vector (gives the C x R array's cell vector).
inline VectorXd transpose_cells(Shape s, const VectorXd& v) {
  const Eigen::Map<const RowMatrixXd> m(v.data(), s.rows, s.cols);
  const RowMatrixXd t = m.transpose();
  return Eigen::Map<const VectorXd>(t.data(), t.size());
}

inline double max_rel_err(const VectorXd& x, const VectorXd& ref) {
  return ((x - ref).array().abs() / ref.array().abs()).maxCoeff();
}

// ---- independent ground truth: plain nodal analysis, one linear solve per measurement -------
//
// For the measurement (i, p) the column node R+p is grounded (not row 0 as in the core) and a
// 1 A current is injected at row node i; with every other line floating, Kirchhoff's current
// law on the remaining n-1 nodes is L' V = e_i (L' = full Laplacian without the grounded
// node). Then the voltage across the pair is V_i, and G[i,p] = 1 / V_i. A full-pivoting LU
// is used so nothing depends on the Cholesky path or the M-matrix formula of eq. 2.5.
inline VectorXd brute_force_forward(Shape s, const VectorXd& g) {
  const Index R = s.rows, C = s.cols, n = s.nodes();
  MatrixXd L = MatrixXd::Zero(n, n);
  for (Index i = 0; i < R; ++i)
    for (Index p = 0; p < C; ++p) {
      const double w = g[i * C + p];
      const Index u = i, v = R + p;
      L(u, u) += w;
      L(v, v) += w;
      L(u, v) -= w;
      L(v, u) -= w;
    }
  VectorXd G(s.cells());
  for (Index p = 0; p < C; ++p) {
    const Index ground = R + p;
    std::vector<Index> keep;
    for (Index k = 0; k < n; ++k)
      if (k != ground) keep.push_back(k);
    MatrixXd Lr(n - 1, n - 1);
    for (Index a = 0; a < n - 1; ++a)
      for (Index b = 0; b < n - 1; ++b) Lr(a, b) = L(keep[a], keep[b]);
    const Eigen::FullPivLU<MatrixXd> lu(Lr);
    for (Index i = 0; i < R; ++i) {
      VectorXd I = VectorXd::Zero(n - 1);
      I[i] = 1.0;  // row nodes keep their index (they come before the grounded column node)
      const VectorXd V = lu.solve(I);
      G[i * C + p] = 1.0 / V[i];
    }
  }
  return G;
}

}  // namespace psmat_test
