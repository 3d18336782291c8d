// The stages one by one from Python (docs/python.md, "Stage by stage").
#include "python/bindings.hpp"

namespace ambler::python {

void bindStages(py::module_& /*m*/) {}

}  // namespace ambler::python
