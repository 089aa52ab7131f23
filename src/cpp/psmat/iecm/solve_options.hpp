// Options and per-frame diagnostics of the IECM inverse g = F^-1(G_exp) (eq. 2.8-2.10).
#pragma once
#include <string>

namespace psmat::iecm {

enum class Method {
  Newton,      // damped Newton-Krylov on log g: PCG on S = D_G (T∘T) D_G (matrix-free), reused
               // float32 Cholesky preconditioner, line search
  BoundedNewton,  // semismooth (Fischer-Burmeister) Newton on g >= g_floor for the complementarity problem
                  // g >= 0, F(g) >= G_exp, g (F(g) - G_exp) = 0 (noisy G; unique: J is a P-matrix)
  LM,          // Levenberg-Marquardt least squares (eq. 2.9) on log g (positivity by construction)
  BoundedLSQ,  // projected Gauss-Newton/LM least squares (eq. 2.9) on g with g >= g_floor
  FixedPoint,  // thesis eq. 2.10: g <- g + beta (G_exp - F(g)), clipped at g_floor
  ActiveSet,   // the complementarity problem of BoundedNewton by sequential bound-constrained
               // QPs, each solved by a primal-dual active-set method; warm-starts from the bound set
};

enum class Status {
  Converged = 0,     // max relative residual <= rtol (or, least squares: stationary point)
  MaxIterations = 1, // iteration limit reached
  Stalled = 2,       // no further decrease of the residual possible (e.g. G_exp not reachable)
  Singular = 3,      // the network of the iterate is disconnected / not SPD
  LeastSquares = 4,  // least-squares stationary point with a non-zero residual (noisy G_exp
                     // that no positive g reproduces exactly); counts as converged
  Bounded = 5,       // complementarity solution: F(g) = G_exp on the free cells, the other
                     // cells at g_floor where even an empty cell over-predicts G_exp (noise)
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
                                 // from g0 with the active-set (complementarity) Newton
};

struct SolveReport {
  int iterations = 0;
  int factorizations = 0;        // Cholesky factorisations (preconditioner / Newton / normal matrix)
  int krylov_iterations = 0;     // PCG iterations (Newton)
  int evaluations = 0;           // forward-model evaluations F(g)
  double residual = 0.0;         // final max_a |F(g)_a - G_a| / G_a; the bounded Newton reports
                                 // the complementarity residual max_a |phi_a| (Fischer-Burmeister,
                                 // relative to G_a), which at a Bounded solution is the residual
                                 // over the free cells (bound cells over-predict G by construction)
  double cost = 0.0;             // final 0.5 * sum_a ((F(g)_a - G_a) / G_a)^2
  Status status = Status::MaxIterations;
  bool used_fallback = false;
  bool converged() const {
    return status == Status::Converged || status == Status::LeastSquares || status == Status::Bounded;
  }
  int at_bound = 0;              // cells at g_floor (bounded Newton, least squares)
};

const char* to_string(Status s);
const char* to_string(Method m);

}  // namespace psmat::iecm
