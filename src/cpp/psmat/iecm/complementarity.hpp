// The complementarity problem of bounded IECM (docs/spec.md §3, noisy frames), cell by cell
//   g >= g_floor,   F(g) - G_exp >= 0,   (g - g_floor)(F(g) - G_exp) = 0,
// in the scaled variables a = (g - g_floor)/G_exp, b = (F(g) - G_exp)/G_exp, and its
// Fischer-Burmeister function phi(a, b) = sqrt(a^2 + b^2) - a - b (zero exactly where
// a >= 0, b >= 0, ab = 0). One definition for the two solvers of the problem:
// solve_bounded_newton.cpp (Newton on phi = 0) and solve_active_set.cpp (its merit).
#pragma once
#include <algorithm>
#include <cmath>

#include "psmat/types.hpp"

namespace psmat::iecm {

// phi and the generalised derivatives alpha = dphi/da, beta = dphi/db (both in [-2, 0]); at
// a = b = 0, where phi is not differentiable, the element of the generalised Jacobian on the
// diagonal direction.
struct FischerBurmeister {
  double phi, alpha, beta;
};

inline FischerBurmeister fischer_burmeister(double a, double b) {
  const double r = std::sqrt(a * a + b * b);  // a, b are relative values: no overflow
  if (r == 0.0) return {0.0, 1.0 / std::sqrt(2.0) - 1.0, 1.0 / std::sqrt(2.0) - 1.0};
  return {r - a - b, a / r - 1.0, b / r - 1.0};
}

// The merit 0.5*|phi|^2 at g, with ra = F(g) - G_exp; the largest |phi| (the residual both
// solvers report) in worst.
inline double fb_merit(const ConstVecRef& g, const ConstVecRef& ra, const ConstVecRef& G_exp,
                       double g_floor, double& worst) {
  double m = 0;
  worst = 0;
  for (Index c = 0; c < g.size(); ++c) {
    const double a = (g[c] - g_floor) / G_exp[c], b = ra[c] / G_exp[c];
    const double phi = std::sqrt(a * a + b * b) - a - b;
    m += 0.5 * phi * phi;
    worst = std::max(worst, std::abs(phi));
  }
  return m;
}

}  // namespace psmat::iecm
