// Bindings of the C++ QZPM core (thesis App. C): psmat._core.qzpm. Arguments are converted to
// Eigen first, then the GIL is released for the numerical work. Each problem comes with a
// psmat._core.SolveReport (register_solve_report.cpp). Validation with readable
// messages is done by the Python package (psmat.qzpm); here only shapes are checked.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <stdexcept>

#include "psmat/numerics/thread_pool.hpp"
#include "psmat/qzpm/closed_form.hpp"
#include "psmat/qzpm/forward.hpp"
#include "psmat/qzpm/solve.hpp"

namespace py = pybind11;
using namespace psmat;

namespace {

using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

Eigen::VectorXd flat(const CArray& a) { return Eigen::Map<const Eigen::VectorXd>(a.data(), a.size()); }

Shape frame_shape(const CArray& g) {
  if (g.ndim() != 2) throw std::invalid_argument("expected a 2-D (R, C) array");
  return Shape{g.shape(0), g.shape(1)};
}

void check_len(const CArray& a, Index n, const char* name) {
  if (a.ndim() != 1 || a.shape(0) != n)
    throw std::invalid_argument(std::string(name) + ": expected a 1-D array of length " + std::to_string(n));
}

py::array_t<double> to_array(const Eigen::VectorXd& v, std::vector<py::ssize_t> shape) {
  py::array_t<double> out(shape);
  std::copy(v.data(), v.data() + v.size(), out.mutable_data());
  return out;
}

qzpm::Readings readings_of(const CArray& pairs, const CArray& rows, const CArray& cols, Shape& s) {
  s = frame_shape(pairs);
  check_len(rows, s.rows, "rows");
  check_len(cols, s.cols, "cols");
  qzpm::Readings r;
  r.pairs = flat(pairs);
  r.rows = flat(rows);
  r.cols = flat(cols);
  return r;
}

qzpm::SolveOptions options(int switches, int max_iter, double rtol, double ftol, double max_log_step,
                           double r_switch0) {
  qzpm::SolveOptions o;
  o.switches = switches ? qzpm::Switches::Separate : qzpm::Switches::Shared;
  o.max_iter = max_iter;
  o.rtol = rtol;
  o.ftol = ftol;
  o.max_log_step = max_log_step;
  o.r_switch0 = r_switch0;
  return o;
}

}  // namespace

void register_qzpm(py::module_& m) {
  m.def(
      "forward",
      [](const CArray& g, const CArray& g_row, const CArray& g_col) {
        const Shape s = frame_shape(g);
        check_len(g_row, s.rows, "g_row");
        check_len(g_col, s.cols, "g_col");
        const Eigen::VectorXd gv = flat(g), gr = flat(g_row), gc = flat(g_col);
        qzpm::Readings out;
        bool ok;
        {
          py::gil_scoped_release release;
          qzpm::Network net(s);
          ok = qzpm::forward(gv, gr, gc, net, out);
        }
        if (!ok) throw std::invalid_argument("invalid network: cells must be >= 0 and switches > 0, all finite");
        return py::make_tuple(to_array(out.pairs, {s.rows, s.cols}), to_array(out.rows, {s.rows}),
                              to_array(out.cols, {s.cols}));
      },
      py::arg("g"), py::arg("g_row"), py::arg("g_col"),
      "Readings (pairs (R,C), rows (R,), cols (C,)) of the QZPM readout, eq. C.4-C.7.");

  m.def(
      "jacobian",
      [](const CArray& g, const CArray& g_row, const CArray& g_col) {
        const Shape s = frame_shape(g);
        check_len(g_row, s.rows, "g_row");
        check_len(g_col, s.cols, "g_col");
        const Eigen::VectorXd gv = flat(g);
        Eigen::VectorXd sw(s.nodes());
        sw << flat(g_row), flat(g_col);
        const Index m_ = qzpm::n_readings(s), n = qzpm::n_parameters(s);
        py::array_t<double> J({m_, n});
        bool ok;
        {
          py::gil_scoped_release release;
          qzpm::Network net(s);
          ok = net.compute(gv, sw);
          if (ok) {
            Eigen::Map<RowMatrixXd> Jm(J.mutable_data(), m_, n);
            qzpm::jacobian(net, Jm);
          }
        }
        if (!ok) throw std::invalid_argument("invalid network: cells must be >= 0 and switches > 0, all finite");
        return J;
      },
      py::arg("g"), py::arg("g_row"), py::arg("g_col"),
      "dG/dtheta: rows = readings (pairs row-major, rows, cols), columns = (cells row-major, g_row, g_col).");

  m.def(
      "closed_form",
      [](const CArray& pairs, const CArray& rows, const CArray& cols, double r_switch) {
        Shape s;
        const qzpm::Readings r = readings_of(pairs, rows, cols, s);
        const Eigen::VectorXd g = qzpm::closed_form(s, r, r_switch);
        return to_array(g, {s.rows, s.cols});
      },
      py::arg("pairs"), py::arg("rows"), py::arg("cols"), py::arg("r_switch"),
      "Closed-form cells assuming switch resistance r_switch and unselected lines at 0 V.");

  m.def(
      "solve",
      [](const CArray& pairs, const CArray& rows, const CArray& cols, int switches, int max_iter,
         double rtol, double ftol, double max_log_step, double r_switch0, std::optional<CArray> g0,
         std::optional<CArray> sw0) {
        Shape s;
        const qzpm::Readings r = readings_of(pairs, rows, cols, s);
        const qzpm::SolveOptions o = options(switches, max_iter, rtol, ftol, max_log_step, r_switch0);
        Eigen::VectorXd g0v, sw0v;
        if (g0) {
          if (g0->size() != s.cells()) throw std::invalid_argument("g0 must have shape (R, C)");
          g0v = flat(*g0);
        }
        if (sw0) {
          check_len(*sw0, s.nodes(), "sw0");
          sw0v = flat(*sw0);
        }
        qzpm::Solution sol;
        {
          py::gil_scoped_release release;
          sol = qzpm::solve(s, r, o, g0v, sw0v);
        }
        return py::make_tuple(to_array(sol.g, {s.rows, s.cols}), to_array(sol.g_row, {s.rows}),
                              to_array(sol.g_col, {s.cols}), sol.report);
      },
      py::arg("pairs"), py::arg("rows"), py::arg("cols"), py::arg("switches"), py::arg("max_iter"),
      py::arg("rtol"), py::arg("ftol"), py::arg("max_log_step"), py::arg("r_switch0"),
      py::arg("g0") = py::none(), py::arg("sw0") = py::none(),
      "Inverse (eq. C.8-C.9) of one set of readings: (g, g_row, g_col, SolveReport).");

  m.def(
      "solve_batch",
      [](const CArray& pairs, const CArray& rows, const CArray& cols, int switches, int max_iter,
         double rtol, double ftol, double max_log_step, double r_switch0, int threads) {
        if (pairs.ndim() != 3 || rows.ndim() != 2 || cols.ndim() != 2)
          throw std::invalid_argument("expected pairs (T,R,C), rows (T,R), cols (T,C)");
        const py::ssize_t T = pairs.shape(0);
        const Shape s{pairs.shape(1), pairs.shape(2)};
        if (rows.shape(0) != T || rows.shape(1) != s.rows || cols.shape(0) != T || cols.shape(1) != s.cols)
          throw std::invalid_argument("rows / cols do not match pairs (T, R, C)");
        const Index m_ = qzpm::n_readings(s);
        RowMatrixXd G(T, m_);
        for (py::ssize_t t = 0; t < T; ++t) {
          G.row(t).head(s.cells()) = Eigen::Map<const Eigen::RowVectorXd>(pairs.data() + t * s.cells(), s.cells());
          G.row(t).segment(s.cells(), s.rows) = Eigen::Map<const Eigen::RowVectorXd>(rows.data() + t * s.rows, s.rows);
          G.row(t).tail(s.cols) = Eigen::Map<const Eigen::RowVectorXd>(cols.data() + t * s.cols, s.cols);
        }
        const qzpm::SolveOptions o = options(switches, max_iter, rtol, ftol, max_log_step, r_switch0);
        if (threads <= 0) threads = numerics::hardware_threads();
        std::vector<qzpm::Solution> sols;
        {
          py::gil_scoped_release release;
          sols = qzpm::solve_batch(s, G, o, threads);
        }
        py::array_t<double> g({T, s.rows, s.cols}), gr({T, s.rows}), gc({T, s.cols});
        py::list reports;
        for (py::ssize_t t = 0; t < T; ++t) {
          const auto& so = sols[static_cast<size_t>(t)];
          std::copy(so.g.data(), so.g.data() + s.cells(), g.mutable_data() + t * s.cells());
          std::copy(so.g_row.data(), so.g_row.data() + s.rows, gr.mutable_data() + t * s.rows);
          std::copy(so.g_col.data(), so.g_col.data() + s.cols, gc.mutable_data() + t * s.cols);
          reports.append(so.report);
        }
        return py::make_tuple(g, gr, gc, reports);
      },
      py::arg("pairs"), py::arg("rows"), py::arg("cols"), py::arg("switches"), py::arg("max_iter"),
      py::arg("rtol"), py::arg("ftol"), py::arg("max_log_step"), py::arg("r_switch0"), py::arg("threads") = 0,
      "Independent problems on several threads: (g (T,R,C), g_row (T,R), g_col (T,C), list of T SolveReport).");
}
