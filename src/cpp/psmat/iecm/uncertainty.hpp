// Uncertainty propagation through IECM (thesis §2.3.1, eq. 2.11-2.14, docs/spec.md §3):
//   dg/dG = (dG/dg)^-1                                                   (eq. 2.14)
//   sigma_g[j,q] = sqrt( sum_{i,p} (dg_jq/dG_ip)^2 sigma_G[i,p]^2 )       (eq. 2.11)
// With J = D_G S D_G^-1 (see jacobian.hpp), J^-1 = D_G S^-1 D_G^-1, so only the SPD matrix S
// is inverted (Cholesky), never the non-symmetric J.
#pragma once
#include "psmat/types.hpp"

namespace psmat::iecm {

// dg/dG (eq. 2.14) at cell conductances g: (R*C) x (R*C), row b = d g_b / d G_:.
// Returns false when the network of g is singular.
bool inverse_jacobian(Shape shape, const ConstVecRef& g, RowMatRef dgdG);

// sigma_g from sigma_G (eq. 2.11). Returns false when the network of g is singular.
bool propagate_uncertainty(Shape shape, const ConstVecRef& g, const ConstVecRef& sigma_G,
                           VecRef sigma_g);

}  // namespace psmat::iecm
