// Registration from Python, and a user's own method in the basin and the matching experiment
// (docs/python.md, "Your own method").
#include "python/bindings.hpp"

namespace ambler::python {

void bindRegistration(py::module_& /*m*/) {}

}  // namespace ambler::python
