#include "adapter/query_guard.h"

#include <stdexcept>
#include <string>

namespace cube {
namespace detail {

namespace {
// The frames of this thread, innermost first.
thread_local const QueryFrame* t_queries = nullptr;
}  // namespace

QueryScope::QueryScope(const void* core, const void* other) : frame_{core, other, t_queries} {
  t_queries = &frame_;
}

QueryScope::~QueryScope() {
  t_queries = frame_.outer;
}

void refuseInsideQuery(const void* core, const char* call) {
  for (const QueryFrame* f = t_queries; f != nullptr; f = f->outer)
    if (f->core == core || f->other == core)
      throw std::logic_error(std::string("cube::CubeCollisionManager::") + call +
                             ": called from inside a callback of a query on this manager; the "
                             "manager is unchanged");
}

}  // namespace detail
}  // namespace cube
