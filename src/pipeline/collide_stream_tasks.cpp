// The collide stream's blocks and a split walk's tasks (collide_stream.h): the judge and the
// memory FCL reads first for a block of pairs at once (cullBlock), and the tasks of a split walk
// answered on the threads that walked them, then merged in walk order (TaskSink).

#include <algorithm>
#include <array>
#include <atomic>
#include <limits>
#include <memory>

#include "pipeline/collide_stream.h"
#include "pipeline/collide_stream_parts.h"
#include "pipeline/fcl_narrow.h"
#include "pipeline/pair_judge.h"

namespace cube {
namespace detail {

// A block of pairs (pairs[index[k]], k < n): the cull, then the memory FCL reads first for the
// pairs it leaves. Each step first asks for the memory it reads for the whole block (the records;
// then the objects, then their geometries), so that the cache misses of a block overlap instead
// of each pair waiting on its own: the first touch of an object and of its geometry was a third of
// FCL's time in a large self-collide of shapes (10,000 objects, whose records and objects lie in
// registration order, not in the walk's).
template <typename S>
void CollideStream<S>::cullBlock(const std::size_t* index, std::size_t n,
                                 const ObjectPair<S>* pairs, Slot* slots) const {
  const auto fetch = [](const void* p, std::size_t lines) {
    for (std::size_t l = 0; l < lines; ++l)
      __builtin_prefetch(static_cast<const char*>(p) + 64 * l);
  };
  for (std::size_t k = 0; k < n; ++k) {
    const Slot& s = slots[index[k]];
    if (!s.deferred) continue;
    fetch(s.va.sphere, 1);
    fetch(s.va.shape, 1);
    fetch(s.vb.sphere, 1);
    fetch(s.vb.shape, 1);
  }
  for (std::size_t k = 0; k < n; ++k) {
    Slot& s = slots[index[k]];
    const ObjectPair<S>& pair = pairs[index[k]];
    if (s.deferred)
      s.kind = judge_.collide(s.va, s.vb);
    else if (!s.judged)
      s.kind = judge_.collide(*pair.first, *pair.second);
    if (s.kind == Answer::kComputed) {
      fetch(pair.first, kObjectLines);
      fetch(pair.second, kObjectLines);
    }
  }
  for (std::size_t k = 0; k < n; ++k)
    if (slots[index[k]].kind == Answer::kComputed) {
      const ObjectPair<S>& pair = pairs[index[k]];
      fetch(pair.first->collisionGeometry().get(), kGeometryLines);
      fetch(pair.second->collisionGeometry().get(), kGeometryLines);
    }
}

template <typename S>
bool CollideStream<S>::takesTasks() const {
  return judge_.culls() && cache_ == nullptr && threads_ > 1 && request_.num_max_contacts > 1 &&
         stats_.candidate_pairs == 0;
}

namespace {
constexpr std::size_t kRunning = std::numeric_limits<std::size_t>::max();
}  // namespace

template <typename S>
void CollideStream<S>::begin(std::size_t tasks, int workers) {
  tasks_.clear();
  tasks_.resize(tasks);
  if (workers_.size() < std::size_t(workers)) workers_.resize(std::size_t(workers));
  task_contacts_ = std::make_unique<std::atomic<std::size_t>[]>(tasks);
  for (std::size_t i = 0; i < tasks; ++i) task_contacts_[i].store(kRunning);
  task_found_.store(0);
  task_budget_ = all_.room();
}

template <typename S>
void CollideStream<S>::take(int worker, std::size_t task, const typename TaskSink<S>::Pair* pairs,
                            std::size_t n) {
  // Full before this task? Only once the tasks run so far hold the budget at all (a sum over
  // every task, one load), then over those before this one: the merge adds contacts in order
  // until the budget, so those before it fill the result whatever the others hold.
  const std::size_t budget = task_budget_;
  if (task_found_.load(std::memory_order_relaxed) >= budget) {
    std::size_t before = 0;
    for (std::size_t j = 0; j < task; ++j) {
      const std::size_t c = task_contacts_[j].load(std::memory_order_acquire);
      if (c != kRunning && (before += c) >= budget) return;
    }
  }
  TaskAnswers& out = tasks_[task];
  out.stats.candidate_pairs += n;
  out.contacts.begin(request_);
  std::array<ObjectPair<S>, kBlock>& block = workers_[std::size_t(worker)].block;
  std::array<Slot, kBlock>& slots = workers_[std::size_t(worker)].slots;
  for (std::size_t first = 0; first < n; first += kBlock) {
    const std::size_t m = std::min(kBlock, n - first);
    for (std::size_t k = 0; k < m; ++k) {
      const typename TaskSink<S>::Pair& p = pairs[first + k];
      block[k] = ObjectPair<S>(p.a, p.b);
      Slot& s = slots[k];
      s.kind = Answer::kComputed;
      s.judged = false;
      s.refined = false;
      s.deferred = volumes_.ofTables(p.ia, p.ib, s.va.sphere, s.va.shape, s.vb.sphere, s.vb.shape);
    }
    cullBlock(kInPlace.data(), m, block.data(), slots.data());
    for (std::size_t k = 0; k < m; ++k) {
      const Slot& s = slots[k];
      const ObjectPair<S>& pair = block[k];
      count(out.stats, s.kind);
      // Into the task's list, each pair with its whole budget, as a fresh result of its own
      // would have: the same contacts, copied once less.
      if (s.kind == Answer::kProved)
        out.contacts.addProved(pair);
      else if (s.kind == Answer::kComputed)
        out.contacts.collide(pair);
    }
  }
  task_contacts_[task].store(out.contacts.size(), std::memory_order_release);
  task_found_.fetch_add(out.contacts.size(), std::memory_order_relaxed);
}

template <typename S>
bool CollideStream<S>::drain(std::size_t task) {
  TaskAnswers& t = tasks_[task];
  addStats(&stats_, t.stats);
  stats_.narrow_calls += t.contacts.drainInto(all_);
  t = TaskAnswers{};
  return all_.full();
}

#define CUBE_COLLIDE_STREAM_TASKS(S)                                                               \
  template void CollideStream<S>::cullBlock(const std::size_t*, std::size_t, const ObjectPair<S>*, \
                                            Slot*) const;                                          \
  template bool CollideStream<S>::takesTasks() const;                                              \
  template void CollideStream<S>::begin(std::size_t, int);                                         \
  template void CollideStream<S>::take(int, std::size_t, const typename TaskSink<S>::Pair*,        \
                                       std::size_t);                                               \
  template bool CollideStream<S>::drain(std::size_t);
CUBE_COLLIDE_STREAM_TASKS(double)
CUBE_COLLIDE_STREAM_TASKS(float)
#undef CUBE_COLLIDE_STREAM_TASKS

}  // namespace detail
}  // namespace cube
