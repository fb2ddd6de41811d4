#pragma once

// The query guard: a mutation of a CubeCollisionManager from inside a callback of one of its
// queries (the callback itself, a pair predicate, a callable) is refused with std::logic_error.
// Each query pushes a frame naming the cores it reads, on the thread that runs the user's code;
// frames are per thread, so concurrent const queries from other threads are unaffected. Queries
// that run user code on worker threads (collideConcurrently) push a frame on each worker too.

namespace cube {
namespace detail {

/// One query running on this thread: the cores it reads (`other` may be null).
struct QueryFrame {
  const void* core;
  const void* other;
  const QueryFrame* outer;
};

/// Names `core` (and `other`) as read by a query on this thread while it lives.
class QueryScope {
 public:
  explicit QueryScope(const void* core, const void* other = nullptr);
  ~QueryScope();
  QueryScope(const QueryScope&) = delete;
  QueryScope& operator=(const QueryScope&) = delete;

 private:
  QueryFrame frame_;
};

/// Throws std::logic_error naming `call` if a query on this thread reads `core`.
void refuseInsideQuery(const void* core, const char* call);

}  // namespace detail
}  // namespace cube
