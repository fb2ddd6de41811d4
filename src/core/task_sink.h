#pragma once

// The split self walk's hand-over to the narrow-phase pipeline: each task's pairs go to a sink on
// the thread that walked the task (Broadphase::collideSelfTasks).

#include <cstddef>

#include "core/geometry.h"

namespace cube {
namespace detail {

/// Where a split self walk (Broadphase::collideSelfTasks) hands each task's pairs, to be answered
/// on the thread that walked the task: the narrow-phase pipeline's collide stream. The tasks of
/// one walk are numbered in walk order and all run in one parallel region, taken in that order
/// (a sink that may stop early can skip the work of a task whose predecessors already decided
/// the answer); then drain() runs on the calling thread for each task in order, so the answers
/// merge in the serial walk's order.
template <typename S>
class TaskSink {
 public:
  /// A pair as a task hands it over: the objects and their ids in the one object table.
  struct Pair {
    fcl::CollisionObject<S>* a;
    fcl::CollisionObject<S>* b;
    ObjectId ia, ib;
  };
  /// A walk of `tasks` tasks starts (the cubes with themselves, then with the unbounded list, then
  /// the list with itself: three walks at most), numbered from 0 again, on `workers` threads
  /// numbered from 0 (scratch per worker needs no lock). Calling thread.
  virtual void begin(std::size_t tasks, int workers) = 0;
  /// Task `task`'s pairs in walk order, on the thread that walked it. An exception is rethrown
  /// on the calling thread once every task has run (nothing is drained then).
  virtual void take(int worker, std::size_t task, const Pair* pairs, std::size_t n) = 0;
  /// Calling thread, each task in order once every task's take() has returned: true stops the
  /// query (the tasks after it are not drained).
  virtual bool drain(std::size_t task) = 0;

 protected:
  ~TaskSink() = default;
};

}  // namespace detail
}  // namespace cube
