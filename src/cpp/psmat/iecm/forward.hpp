// IECM forward model G = F(g) (thesis eq. 2.5-2.7, docs/spec.md §3): equivalent conductance between
// row i and column p with every other line floating,
//     1/G[i,p] = M[i,i] + M[R+p,R+p] - 2 M[i,R+p]           (eq. 2.5 with I_ref = 1)
// One Cholesky of the grounded nodal matrix gives all R*C values. Every other part of psmat
// (solvers, uncertainty, simulator) evaluates the forward model through this file.
#pragma once
#include "psmat/iecm/laplacian.hpp"

namespace psmat::iecm {

// Equivalent conductances from an already computed NodalInverse (eq. 2.5).
void equivalent_conductance(const NodalInverse& net, VecRef G);

// G = F(g): factorises the network of g into `net` and writes G. Returns false when the
// network is singular (see NodalInverse::compute).
bool forward(const ConstVecRef& g, NodalInverse& net, VecRef G);

}  // namespace psmat::iecm
