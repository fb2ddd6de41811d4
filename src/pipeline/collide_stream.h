#pragma once

// The collide stream: the narrow-phase pipeline fed by a manager's walk, one pair per callback:
// pairs are gathered in chunks, each chunk runs on the threads, and the answers merge in pair
// order. The stream tells the walk to stop as soon as the merged answer is complete, so a request
// for one contact still stops near the first colliding pair.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>

#include <atomic>
#include <cstddef>
#include <memory>
#include <vector>

#include "core/geometry.h"
#include "core/task_sink.h"
#include "cube_collision/narrow_phase.h"
#include "pipeline/answers.h"
#include "pipeline/collectors.h"
#include "pipeline/pair_judge.h"
#include "pipeline/pair_volumes.h"

namespace cube {
namespace detail {

/// Accumulates fcl::collide answers exactly as one result passed to fcl::collide for each pair
/// in turn would (not for requests with costs or a cached GJK guess: callers keep those serial),
/// in its collector (AllContacts, collectors.h).
/// Pairs are answered at once on the calling thread at first (and always for a request of one
/// contact, and on one thread); once the query proves large, they are gathered into chunks (the
/// cache looked up on the calling thread) whose cull and FCL calls run on the threads when there
/// is enough work to pay for a parallel region. A large self-collide of a cube manager may instead
/// hand the stream its split walk's tasks (TaskSink, takesTasks): each task's pairs are culled and
/// answered on the thread that walked them, and merged here in walk order.
template <typename S>
class CollideStream final : public TaskSink<S> {
 public:
  CollideStream(const fcl::CollisionRequest<S>& request, const NarrowPhaseOptions<S>& options);
  ~CollideStream();
  CollideStream(const CollideStream&) = delete;
  CollideStream& operator=(const CollideStream&) = delete;

  /// Adds one candidate pair. True once the result is complete: the walk may stop.
  bool push(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b);
  /// Where push(a, ia, b, ib) finds the pair's volumes.
  PairVolumes<S>& volumes() { return volumes_; }
  /// push, with the objects' ids (kNone: an object of no table): the cull reads the tables'
  /// volumes instead of the objects, on this thread (about 20 ns a pair).
  bool push(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b, ObjectId ib);
  /// The pair that gave the first contact of the last collide with contacts that used `cache`
  /// (nullptrs if none, or forgotten since).
  static ObjectPair<S> lastHit(NarrowPhaseCache<S>& cache);
  /// push, answering this pair before any other is pushed (what is pending goes first).
  bool pushAlone(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b);
  /// Runs what is pending and returns the merged result. Call once, at the end.
  fcl::CollisionResult<S> finish();

  /// Whether the stream takes a split walk's tasks (TaskSink) instead of pairs pushed one by one:
  /// for a request that does not stop at its first contact, without a cache, on more threads
  /// than one, before any pair was pushed.
  bool takesTasks() const;
  /// The threads the stream answers on (NarrowPhaseOptions::threads resolved).
  int threads() const { return threads_; }
  void begin(std::size_t tasks, int workers) override;
  /// Skips the work of a task whose predecessors that have run hold the budget's contacts
  /// (num_max_contacts): the result is full before it, nothing of it would be merged.
  void take(int worker, std::size_t task, const typename TaskSink<S>::Pair* pairs,
            std::size_t n) override;
  bool drain(std::size_t task) override;

  /// An fcl::CollisionCallBack feeding the CollideStream passed as cdata.
  static bool callback(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* stream);
  /// The same for walks that give ids (manager_walks.h).
  static bool callbackWithIds(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                              ObjectId ib, void* stream);

 private:
  struct Slot;
  struct TaskAnswers;
  struct TaskScratch;
  // The records of a pair, for pushJudged (null: the judge reads the objects).
  using Volumes = Records;
  // kept: va and vb are records of the tables (valid for the whole query), which may wait in a
  // block of pairs answered together (answerSerialBlock).
  // fly: a pair without records (ids ia, ib) culled on its objects' kept levels
  // (PairVolumes::fly) where the pair is answered at once.
  bool pushJudged(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, const Volumes* va,
                  const Volumes* vb, bool kept, ObjectId ia = kNone, ObjectId ib = kNone,
                  bool fly = false);
  // The cull of the pairs pairs[index[k]] into slots[index[k]], k < n (at most kBlock), where
  // the slot says, then a prefetch of what FCL reads first for those it leaves. Any thread.
  void cullBlock(const std::size_t* index, std::size_t n, const ObjectPair<S>* pairs,
                 Slot* slots) const;
  static bool cacheable(const Slot& s);
  void answerSerialBlock();
  // Whether the work answered at once shows a query the threads can share (thread_policy.h's
  // kSerialWork and kMinCallShare).
  bool provedLarge() const;
  // Sizes the team and leaves the serial mode if it has more than one thread.
  void leaveSerial();
  void answerNow(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, Answer kind);
  void answerNow(const ObjectPair<S>& pair, Slot& slot);
  // A slot's contacts (its fresh result or its cached answer) to the collector.
  void merge(const ObjectPair<S>& pair, const Slot& slot);
  void flush();

  const fcl::CollisionRequest<S>& request_;
  NarrowPhaseStats stats_;
  NarrowPhaseStats* stats_out_;
  typename NarrowPhaseCache<S>::Impl* cache_;
  int threads_;
  bool serial_ = true;           // answer each pair as it comes
  std::size_t serial_work_ = 0;  // work answered at once (collide_stream.cpp, kSerialWork)
  std::size_t chunk_work_ = 0;   // flush once the pending work reaches this
  std::size_t pending_work_ = 0;
  std::vector<ObjectPair<S>> chunk_;
  std::vector<std::size_t> pending_;  // the chunk's pairs not in the cache
  std::vector<Slot> slots_;           // one per pair of the chunk
  std::unique_ptr<Slot> scratch_;     // a pair answered at once, with a cache
  // Pairs with records answered on this thread without a cache, in blocks: the first serial_n_.
  std::unique_ptr<TaskScratch> serial_block_;
  std::size_t serial_n_ = 0;
  std::vector<TaskAnswers> tasks_;    // a split walk's tasks, each answered on its thread
  std::vector<TaskScratch> workers_;  // per worker of the walk: a block's pairs and slots
  // Per task, its contacts once it has run (kRunning before), and their sum over the tasks run:
  // what take() reads to skip a task the collector is full before.
  std::unique_ptr<std::atomic<std::size_t>[]> task_contacts_;
  std::atomic<std::size_t> task_found_{0};
  std::size_t task_budget_ = 0;  // the contacts the collector has room for as the walk begins
  fcl::CollisionResult<S> empty_;
  // The answer, kept by its collector (every pair's contacts in walk order, up to the budget).
  fcl::CollisionResult<S> result_;
  AllContacts<S> all_;
  // The records: the tables, the memo of objects without an id; the judge of the request.
  PairVolumes<S> volumes_;
  PairJudge<S> judge_;
};

extern template class CollideStream<double>;
extern template class CollideStream<float>;

}  // namespace detail
}  // namespace cube
