// The extension module cube_collision._core; the package (cube_collision/__init__.py) re-exports
// it. One file per role: geometry.cpp; manager.cpp (the manager) and manager_binding.cpp (its
// mutations and pickling); collide.cpp, distance.cpp, spatial.cpp (queries); fcl_hooks.cpp (the
// python-fcl layer); batch.cpp; fcl_backend.cpp (backend="fcl").

#include "manager.h"

PYBIND11_MODULE(_core, m) {
  m.doc() = "cube-collision's Python binding (see the package cube_collision).";
  cubepy::bindGeometry(m);
  cubepy::bindBatch(m);  // Body before the manager's check_states names it
  cubepy::bindManager(m);
  cubepy::bindPairCalls(m);
  m.attr("ALL_BITS") = ~std::uint64_t(0);
}
