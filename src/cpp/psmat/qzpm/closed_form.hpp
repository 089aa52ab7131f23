// The "QZPM" closed-form method: cell conductances from the readings assuming a KNOWN switch
// resistance r_s (the same for every switch) and that the lines which are not selected sit at
// zero potential ("quasi zero potential"). Derived from the circuit of eq. C.4-C.6 under those
// two assumptions; it stands in for the analytical method of Hidalgo et al. (thesis ref. [138],
// not available here), the comparison column "QZPM" of Tables C.1/C.2. Derivation: docs/qzpm.md.
//
//  single row i:   G_i = series(1/r_s, S_i)          =>  S_i = G_i / (1 - r_s G_i)
//  single column:  S^p = G^p / (1 - r_s G^p)
//  pair (i, p):    two nodes (row i, column p), each fed from "in" through r_s, joined by
//                  c = g[i,p], tied to 0 V through a = S_i - c and b = S^p - c. Its admittance
//                  G = g (g (a+b) + 2ab + 2c(a+b)) / ((g+a)(g+b) + c(2g+a+b)),  g = 1/r_s,
//                  is, in terms of c, the quadratic  alpha c^2 + beta c + gamma = 0  with
//                  (divided by g^2; sigma = S_i + S^p, P = S_i S^p, r = r_s)
//                     alpha = 2r - G r^2,  beta = 2,  gamma = (G - sigma) + r (G sigma - 2P) + r^2 G P
//                  and the root that stays finite as r -> 0:
//                     c = -gamma / (1 + sqrt(1 - alpha gamma))    (-> (sigma - G)/2 = ZPM at r = 0)
// Exact when the unselected lines are truly at 0 V (ideal grounding switches) and the selected
// switches have resistance r_s; in the full circuit its error vanishes as r_s -> 0.
#pragma once
#include "psmat/qzpm/forward.hpp"

namespace psmat::qzpm {

// Line totals S_i (rows) and S^p (columns) of the single-line readings, S = G / (1 - r_s G).
// Entries are NaN where r_s G >= 1 (inconsistent with the assumed switch).
void line_totals(const Readings& G, double r_switch, VecRef S_rows, VecRef S_cols);

// Cell conductances (R*C, row-major). NaN where the readings are inconsistent with r_switch
// (negative discriminant or r_s G >= 1); values may be <= 0 when they are merely inaccurate.
Eigen::VectorXd closed_form(Shape s, const Readings& G, double r_switch);

}  // namespace psmat::qzpm
