// psmat._core: the compiled core of psmat. One register_*.cpp per concept.
#include <pybind11/pybind11.h>

namespace py = pybind11;

void register_iecm(py::module_& m);

PYBIND11_MODULE(_core, m) {
  m.doc() = "psmat compiled core (private: use the psmat package API)";
  auto iecm = m.def_submodule("iecm", "IECM crosstalk removal (thesis §2.1.4, §2.3, App. B)");
  register_iecm(iecm);
}
