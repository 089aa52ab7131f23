#include "psmat/qzpm/closed_form.hpp"

#include <cmath>
#include <limits>

namespace psmat::qzpm {

namespace {
double line_total(double G, double r) {
  const double den = 1.0 - r * G;
  return den > 0.0 ? G / den : std::numeric_limits<double>::quiet_NaN();
}
}  // namespace

void line_totals(const Readings& G, double r, VecRef S_rows, VecRef S_cols) {
  for (Index i = 0; i < G.rows.size(); ++i) S_rows[i] = line_total(G.rows[i], r);
  for (Index p = 0; p < G.cols.size(); ++p) S_cols[p] = line_total(G.cols[p], r);
}

Eigen::VectorXd closed_form(Shape s, const Readings& G, double r) {
  Eigen::VectorXd Sr(s.rows), Sc(s.cols), g(s.cells());
  line_totals(G, r, Sr, Sc);
  for (Index i = 0; i < s.rows; ++i)
    for (Index p = 0; p < s.cols; ++p) {
      const double Gp = G.pairs[i * s.cols + p];
      const double sigma = Sr[i] + Sc[p], P = Sr[i] * Sc[p];
      const double alpha = r * (2.0 - Gp * r);
      const double gamma = (Gp - sigma) + r * (Gp * sigma - 2.0 * P) + r * r * Gp * P;
      const double disc = 1.0 - alpha * gamma;
      g[i * s.cols + p] = disc >= 0.0 ? -gamma / (1.0 + std::sqrt(disc))
                                      : std::numeric_limits<double>::quiet_NaN();
    }
  return g;
}

}  // namespace psmat::qzpm
