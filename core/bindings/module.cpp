// module.cpp: the private extension module argand.core._core.
// Bindings are thin and split by topic; all logic lives in the C++ library.
#include <pybind11/pybind11.h>

namespace py = pybind11;

void init_roots(py::module_& m);
void init_render(py::module_& m);

PYBIND11_MODULE(_core, m) {
    m.doc() = "Argand's compiled core (private; use argand.core).";
    init_roots(m);
    init_render(m);
}
