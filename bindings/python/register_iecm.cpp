// Bindings of the C++ IECM core: psmat._core.iecm. Arguments are converted to Eigen first,
// then the GIL is released for the numerical work. A solved frame comes with a
// psmat._core.SolveReport (register_solve_report.cpp), a batch with one per frame.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <stdexcept>
#include <string>

#include "psmat/iecm/batch.hpp"
#include "psmat/iecm/forward.hpp"
#include "psmat/iecm/jacobian.hpp"
#include "psmat/iecm/simd.hpp"
#include "psmat/iecm/solve.hpp"
#include "psmat/iecm/stream.hpp"
#include "psmat/iecm/uncertainty.hpp"

namespace py = pybind11;
using namespace psmat;
using namespace psmat::iecm;

namespace {

using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// (R, C) float64 array -> shape and flat copy
Shape shape_of_frame(const CArray& a) {
  if (a.ndim() != 2) throw std::invalid_argument("expected a 2-D (R, C) array");
  return Shape{a.shape(0), a.shape(1)};
}

Eigen::VectorXd flat(const CArray& a) {
  return Eigen::Map<const Eigen::VectorXd>(a.data(), a.size());
}

py::array_t<double> frame_array(const Eigen::VectorXd& v, Shape s) {
  py::array_t<double> out({s.rows, s.cols});
  std::copy(v.data(), v.data() + v.size(), out.mutable_data());
  return out;
}

}  // namespace

void register_iecm(py::module_& m) {
  py::enum_<Method>(m, "Method")
      .value("newton", Method::Newton)
      .value("bounded_newton", Method::BoundedNewton)
      .value("lm", Method::LM)
      .value("bounded_lsq", Method::BoundedLSQ)
      .value("fixed_point", Method::FixedPoint)
      .value("active_set", Method::ActiveSet);

  py::class_<SolveOptions>(m, "SolveOptions", "Options of the IECM inverse (see psmat.iecm.solve)")
      .def(py::init<>())
      .def_readwrite("method", &SolveOptions::method)
      .def_readwrite("max_iter", &SolveOptions::max_iter)
      .def_readwrite("rtol", &SolveOptions::rtol)
      .def_readwrite("ftol", &SolveOptions::ftol)
      .def_readwrite("beta", &SolveOptions::beta)
      .def_readwrite("g_floor", &SolveOptions::g_floor)
      .def_readwrite("max_log_step", &SolveOptions::max_log_step)
      .def_readwrite("reuse_factorization", &SolveOptions::reuse_factorization)
      .def_readwrite("krylov_max_iter", &SolveOptions::krylov_max_iter)
      .def_readwrite("forcing", &SolveOptions::forcing)
      .def_readwrite("fallback", &SolveOptions::fallback);

  m.def(
      "forward",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& g) {
        // g: (T, R, C) -> G (T, R, C) and ok (T,) (false where the network is singular)
        if (g.ndim() != 3) throw std::invalid_argument("expected a (T, R, C) array");
        const Shape s{g.shape(1), g.shape(2)};
        const py::ssize_t T = g.shape(0);
        py::array_t<double> G({T, s.rows, s.cols});
        py::array_t<bool> ok(T);
        const double* src = g.data();
        double* dst = G.mutable_data();
        bool* okp = ok.mutable_data();
        {
          py::gil_scoped_release release;
          NodalInverse net(s);
          for (py::ssize_t t = 0; t < T; ++t) {
            Eigen::Map<const Eigen::VectorXd> gt(src + t * s.cells(), s.cells());
            Eigen::Map<Eigen::VectorXd> Gt(dst + t * s.cells(), s.cells());
            okp[t] = forward(gt, net, Gt);
            if (!okp[t]) Gt.setConstant(std::numeric_limits<double>::quiet_NaN());
          }
        }
        return py::make_tuple(G, ok);
      },
      py::arg("g"), "Equivalent conductances G = F(g) (eq. 2.5) of a (T, R, C) stack, in S.");

  m.def(
      "jacobian",
      [](const CArray& g) {
        const Shape s = shape_of_frame(g);
        const Eigen::VectorXd gv = flat(g);
        RowMatrixXd J(s.cells(), s.cells());
        bool ok;
        {
          py::gil_scoped_release release;
          NodalInverse net(s);
          Eigen::VectorXd G(s.cells());
          ok = forward(gv, net, G);
          if (ok) jacobian(net, G, J);
        }
        if (!ok) throw std::domain_error("the resistor network of g is singular (disconnected)");
        return J;
      },
      py::arg("g"), "dG/dg (eq. 2.13), (R*C, R*C), row-major cell order.");

  m.def(
      "hadamard_product",
      [](const CArray& g, const CArray& v) {
        const Shape s = shape_of_frame(g);
        const Eigen::VectorXd gv = flat(g), vv = flat(v);
        if (vv.size() != s.cells()) throw std::invalid_argument("v must have the shape of g");
        Eigen::VectorXd out(s.cells());
        bool ok;
        {
          py::gil_scoped_release release;
          NodalInverse net(s);
          ok = net.compute(gv);
          HadamardWork work;
          if (ok) hadamard_product(net, vv, out, work);
        }
        if (!ok) throw std::domain_error("the resistor network of g is singular (disconnected)");
        return frame_array(out, s);
      },
      py::arg("g"), py::arg("v"), "Matrix-free (T∘T) v in O(n^3) (docs/spec.md §3), shape of g.");

  m.def(
      "inverse_jacobian",
      [](const CArray& g) {
        const Shape s = shape_of_frame(g);
        const Eigen::VectorXd gv = flat(g);
        RowMatrixXd D(s.cells(), s.cells());
        bool ok;
        {
          py::gil_scoped_release release;
          ok = inverse_jacobian(s, gv, D);
        }
        if (!ok) throw std::domain_error("dG/dg is singular at g");
        return D;
      },
      py::arg("g"), "dg/dG = (dG/dg)^-1 (eq. 2.14), (R*C, R*C).");

  m.def(
      "propagate_uncertainty",
      [](const CArray& g, const CArray& sigma_G) {
        const Shape s = shape_of_frame(g);
        const Eigen::VectorXd gv = flat(g), sv = flat(sigma_G);
        if (sv.size() != s.cells()) throw std::invalid_argument("sigma_G must have the shape of g");
        Eigen::VectorXd out(s.cells());
        bool ok;
        {
          py::gil_scoped_release release;
          ok = propagate_uncertainty(s, gv, sv, out);
        }
        if (!ok) throw std::domain_error("dG/dg is singular at g");
        return frame_array(out, s);
      },
      py::arg("g"), py::arg("sigma_G"), "sigma_g from sigma_G (eq. 2.11-2.14), shape of g.");

  m.def(
      "solve_frame",
      [](const CArray& G, const SolveOptions& opts, std::optional<CArray> g0) {
        const Shape s = shape_of_frame(G);
        const Eigen::VectorXd Gv = flat(G);
        Eigen::VectorXd g = g0 ? flat(*g0) : Gv;
        if (g.size() != s.cells()) throw std::invalid_argument("g0 must have the shape of G");
        SolveReport rep;
        {
          py::gil_scoped_release release;
          Solver solver(s, opts);
          rep = solver.solve(Gv, g, g0.has_value());
        }
        return py::make_tuple(frame_array(g, s), rep);
      },
      py::arg("G"), py::arg("options"), py::arg("g0") = py::none(),
      "Solve one (R, C) frame; returns (g, SolveReport).");

  py::class_<BatchJob>(m, "BatchJob", "A (T, R, C) batch solved on worker threads")
      .def(py::init([](const py::array_t<double, py::array::c_style | py::array::forcecast>& G,
                       const SolveOptions& opts, bool streaming, int threads,
                       std::optional<py::array_t<double, py::array::c_style | py::array::forcecast>>
                           initial) {
             if (G.ndim() != 3) throw std::invalid_argument("expected a (T, R, C) array");
             const Shape s{G.shape(1), G.shape(2)};
             const Index T = G.shape(0);
             RowMatrixXd Gm = Eigen::Map<const RowMatrixXd>(G.data(), T, s.cells());
             RowMatrixXd init;
             if (initial) {
               if (initial->size() != G.size())
                 throw std::invalid_argument("initial must have the shape of G");
               init = Eigen::Map<const RowMatrixXd>(initial->data(), T, s.cells());
             }
             return std::make_unique<BatchJob>(s, std::move(Gm), opts, streaming, threads,
                                               std::move(init));
           }),
           py::arg("G"), py::arg("options"), py::arg("streaming"), py::arg("threads"),
           py::arg("initial") = py::none())
      .def("start", &BatchJob::start)
      .def("wait", &BatchJob::wait, py::arg("seconds"), py::call_guard<py::gil_scoped_release>(),
           "Wait up to `seconds` (negative: no limit); True when all frames are done.")
      .def("cancel", &BatchJob::cancel)
      .def_property_readonly("completed", &BatchJob::completed)
      .def_property_readonly("frames", &BatchJob::frames)
      .def("g", [](const BatchJob& j) { return RowMatrixXd(j.g()); }, "(T, R*C) solutions")
      .def("reports", &BatchJob::reports, "list of T SolveReport, in frame order");

  m.def("hardware_threads", &hardware_threads);
  m.def("simd_kernels", [] { return std::string(psmat::iecm::simd_kernels_name()); },
        "The vector unit the dense IECM kernels run in: 'avx512', 'avx2', 'baseline' (the build's "
        "own instruction set) or 'native' (a PSMAT_NATIVE build: the CPU's). The widest unit the "
        "build has and the CPU runs; the environment variable PSMAT_SIMD, read on first use, caps "
        "it at 'avx2' or 'baseline'");

  py::class_<StreamSolver>(m, "StreamSolver", "Frames in, crosstalk-free frames out, in order")
      .def(py::init([](Index rows, Index cols, const SolveOptions& opts, int threads,
                       std::size_t max_pending) {
             return std::make_unique<StreamSolver>(Shape{rows, cols}, opts, threads, max_pending);
           }),
           py::arg("rows"), py::arg("cols"), py::arg("options"), py::arg("threads"),
           py::arg("max_pending"))
      .def(
          "push",
          [](StreamSolver& s, const CArray& G, double timeout) -> py::object {
            const Shape sh = shape_of_frame(G);
            if (sh.rows != s.shape().rows || sh.cols != s.shape().cols)
              throw std::invalid_argument("frame shape does not match the stream");
            const Eigen::VectorXd Gv = flat(G);
            std::uint64_t seq;
            {
              py::gil_scoped_release release;
              seq = s.push(Gv, timeout);
            }
            if (seq == StreamSolver::kFull) return py::none();
            return py::int_(seq);
          },
          py::arg("G"), py::arg("timeout") = -1.0,
          "Queue a frame; None if the stream stayed full for `timeout` s (negative: wait).")
      .def(
          "pop",
          [](StreamSolver& s, double timeout) -> py::object {
            StreamResult r;
            bool ok;
            {
              py::gil_scoped_release release;
              ok = s.pop(r, timeout);
            }
            if (!ok) return py::none();
            return py::make_tuple(r.seq, frame_array(r.g, s.shape()), r.report);
          },
          py::arg("timeout"),
          "Next frame in order as (seq, g, SolveReport); None if none within `timeout` s.")
      .def_property_readonly("pending", &StreamSolver::pending)
      .def("close", &StreamSolver::close);
}
