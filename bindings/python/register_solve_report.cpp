// Bindings of how an iterative solve ended (src/cpp/psmat/solve_report.hpp): psmat._core.Status and
// psmat._core.SolveReport, one type for a frame of the IECM inverse (psmat._core.iecm: solve_frame,
// each frame of a BatchJob, StreamSolver.pop) and for a QZPM problem (psmat._core.qzpm).
#include <pybind11/pybind11.h>

#include <string>

#include "psmat/solve_report.hpp"

namespace py = pybind11;
using psmat::SolveReport;
using psmat::Status;

void register_solve_report(py::module_& m) {
  // the names are the status strings of the Python API (psmat.iecm.SolveInfo.status)
  py::enum_<Status>(m, "Status", "How an iterative solve ended (src/cpp/psmat/solve_report.hpp)")
      .value("converged", Status::Converged, "max relative residual <= rtol")
      .value("max_iterations", Status::MaxIterations, "iteration limit reached")
      .value("stalled", Status::Stalled, "no further decrease of the residual possible")
      .value("singular", Status::Singular, "the network of the iterate is disconnected / not SPD")
      .value("least_squares", Status::LeastSquares,
             "least-squares stationary point with a non-zero residual (counts as converged)")
      .value("bounded", Status::Bounded,
             "complementarity solution with cells at g_floor (noisy G; counts as converged)");

  py::class_<SolveReport>(m, "SolveReport", "Diagnostics of one solved frame / problem (read-only)")
      .def_readonly("iterations", &SolveReport::iterations, "method iterations")
      .def_readonly("factorizations", &SolveReport::factorizations, "Cholesky factorisations")
      .def_readonly("krylov_iterations", &SolveReport::krylov_iterations, "PCG iterations (IECM)")
      .def_readonly("evaluations", &SolveReport::evaluations, "forward-model evaluations")
      .def_readonly("residual", &SolveReport::residual,
                    "final max relative residual (bounded IECM: complementarity residual max |phi|)")
      .def_readonly("cost", &SolveReport::cost, "final 0.5 * sum(((F - G) / G)^2)")
      .def_readonly("status", &SolveReport::status)
      .def_readonly("used_fallback", &SolveReport::used_fallback,
                    "IECM: Newton handed over to the active-set method (or it to the bounded Newton)")
      .def_readonly("at_bound", &SolveReport::at_bound, "IECM: cells at g_floor")
      .def_property_readonly("converged", &SolveReport::converged,
                             "status is converged, least_squares or bounded")
      .def("__repr__", [](const SolveReport& r) {
        return std::string("SolveReport(status=") + psmat::to_string(r.status) +
               ", iterations=" + std::to_string(r.iterations) +
               ", residual=" + py::repr(py::float_(r.residual)).cast<std::string>() + ")";
      });
}
