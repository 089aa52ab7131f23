// psmat._core: the compiled core of psmat. One register_*.cpp per concept.
#include <pybind11/pybind11.h>

namespace py = pybind11;

void register_solve_report(py::module_& m);
void register_iecm(py::module_& m);
void register_sensor(py::module_& m);
void register_firmware(py::module_& m);
void register_qzpm(py::module_& m);

PYBIND11_MODULE(_core, m) {
  m.doc() = "psmat compiled core (private: use the psmat package API)";
  register_solve_report(m);  // Status, SolveReport: shared by the iecm and qzpm submodules
  auto iecm = m.def_submodule("iecm", "IECM crosstalk removal (thesis §2.1.4, §2.3, App. B)");
  register_iecm(iecm);
  auto qzpm = m.def_submodule("qzpm", "IECM adapted to the QZPM readout: cells and switches (thesis App. C)");
  register_qzpm(qzpm);
  auto sensor = m.def_submodule("sensor", "Velostat MPI hysteresis + creep model (thesis §2.5)");
  register_sensor(sensor);
  auto fw = m.def_submodule("firmware", "The portable firmware cores (firmware/core) on host HALs: the digital twin");
  register_firmware(fw);
}
