// The extension module cube_collision._core; the package (cube_collision/__init__.py) re-exports
// it. One file per role: geometry.cpp, manager.cpp (mutations, pickling), queries.cpp, batch.cpp.

#include "common.h"

PYBIND11_MODULE(_core, m) {
  m.doc() = "cube-collision's Python binding (see the package cube_collision).";
  cubepy::bindGeometry(m);
  cubepy::bindBatch(m);  // Body before the manager's check_states names it
  cubepy::bindManager(m);
  cubepy::bindQueries(m);
  m.attr("ALL_BITS") = ~std::uint64_t(0);
}
