// Options and per-frame diagnostics of the IECM inverse g = F^-1(G_exp) (eq. 2.8-2.10).
#pragma once
#include "psmat/solve_report.hpp"

namespace psmat::iecm {

// The status and diagnostics of a frame (psmat/solve_report.hpp, shared with the QZPM inverse).
using psmat::SolveReport;
using psmat::Status;
using psmat::to_string;

// The recommended methods are Newton (any frame; noisy ones go to ActiveSet) and ActiveSet;
// the others are the references they are checked against (the thesis' iterations and the
// slower complementarity Newton; Python: psmat.iecm.reference).
enum class Method {
  Newton,      // damped Newton-Krylov on log g: PCG on S = D_G (T∘T) D_G (matrix-free), reused
               // float32 Cholesky preconditioner, line search (solve_newton.cpp)
  BoundedNewton,  // reference: semismooth (Fischer-Burmeister) Newton on g >= g_floor for the
                  // complementarity problem g >= 0, F(g) >= G_exp, g (F(g) - G_exp) = 0 (noisy G;
                  // unique: J is a P-matrix); finishes an ActiveSet frame whose line search fails
  LM,          // reference: Levenberg-Marquardt least squares (eq. 2.9) on log g (positivity by
               // construction; solve_lsq.cpp)
  BoundedLSQ,  // reference: projected Levenberg-Marquardt least squares (eq. 2.9) on g with
               // g >= g_floor (solve_lsq.cpp)
  FixedPoint,  // reference: thesis eq. 2.10: g <- g + beta (G_exp - F(g)), clipped at g_floor
  ActiveSet,   // the complementarity problem of BoundedNewton by sequential bound-constrained
               // QPs, each solved by a primal-dual active-set method; warm-starts from the bound
               // set (solve_active_set.cpp)
};

struct SolveOptions {
  Method method = Method::Newton;
  int max_iter = 100;            // per frame
  double rtol = 1e-10;           // stop when max_a |F(g)_a - G_a| / G_a <= rtol
  double ftol = 1e-14;           // least squares: relative decrease of the cost below this
  double beta = 0.05;            // fixed point damping (eq. 2.10)
  double g_floor = 1e-12;        // S; lower bound that keeps conductances positive
  double max_log_step = 3.0;     // Newton/LM trust region: |delta log g| per cell and iteration
  bool reuse_factorization = true;  // Newton: keep the preconditioner across iterations/frames
  int krylov_max_iter = 0;       // Newton: PCG iterations before refactorising (0: 10 + R*C/64)
  double forcing = 1e-2;         // Newton: PCG tolerance is min(forcing, 0.1*residual), >= 1e-8
  bool fallback = true;          // Newton: when it stalls (noisy G unreachable by g > 0), restart
                                 // from the frame's starting point with the active-set method
                                 // (the complementarity solution); a start with cells at g_floor
                                 // goes to it directly
};

const char* to_string(Method m);

}  // namespace psmat::iecm
