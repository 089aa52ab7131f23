// How an iterative solve of the C++ core ended: the Status and per-problem diagnostics
// (SolveReport) shared by the IECM inverse (iecm/solve.hpp) and the QZPM inverse
// (qzpm/solve.hpp). Bound once for Python as psmat._core.Status / psmat._core.SolveReport.
#pragma once

namespace psmat {

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

struct SolveReport {
  int iterations = 0;
  int factorizations = 0;        // Cholesky factorisations (preconditioner / Newton / normal matrix)
  int krylov_iterations = 0;     // PCG iterations (IECM Newton and active set)
  int evaluations = 0;           // forward-model evaluations
  double residual = 0.0;         // final max_a |F_a - G_a| / G_a; the bounded IECM methods report
                                 // the complementarity residual max_a |phi_a| (Fischer-Burmeister,
                                 // relative to G_a), which at a Bounded solution is the residual
                                 // over the free cells (bound cells over-predict G by construction)
  double cost = 0.0;             // final 0.5 * sum_a ((F_a - G_a) / G_a)^2
  Status status = Status::MaxIterations;
  bool used_fallback = false;    // IECM: Newton handed the frame to the active-set method, or
                                 // the active-set method to the Fischer-Burmeister Newton
  int at_bound = 0;              // IECM: cells at g_floor (bounded methods, least squares)
  bool converged() const {
    return status == Status::Converged || status == Status::LeastSquares || status == Status::Bounded;
  }
};

inline const char* to_string(Status s) {
  switch (s) {
    case Status::Converged: return "converged";
    case Status::MaxIterations: return "max_iterations";
    case Status::Stalled: return "stalled";
    case Status::Singular: return "singular";
    case Status::LeastSquares: return "least_squares";
    case Status::Bounded: return "bounded";
  }
  return "unknown";
}

}  // namespace psmat
