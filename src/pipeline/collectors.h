#pragma once

// The collectors: what a query keeps of the pairs the pair judge (pair_judge.h) and FCL answer.
// A query is a walk, the judge, and one of these; queries differ by their collector, not by how a
// pair is decided or how answers are kept:
//   AllContacts   every contact, merged into one fcl::CollisionResult as FCL's calls in turn
//                 would merge them, up to the request's budget (full() stops the walk);
//   PairContacts  each pair's own contacts, in the order answered: a thread's share of an
//                 AllContacts, handed to it in order (drainInto);
//   AnyHit        whether any pair is a hit (complete at the first);
//   FirstInOrder  the least hit in a key's order (the walk goes on: a later pair may come first);
//   Closest       the smallest distance, its bound() what the judge's mayBeat reads;
//   WithinMargin  the pairs within their margins, in pair order, found on any thread.
// Per-pair calls are inline and static: drivers take the collector as a type, never through a
// virtual call.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

#include "core/geometry.h"
#include "pipeline/answers.h"
#include "pipeline/fcl_narrow.h"

namespace cube {
namespace detail {

/// A pair's contacts as a collector reads them: the run [first, first + n) of a list (a cached
/// answer's) or of a result (a pair's own, or a PairContacts' for all its pairs; FCL gives no
/// const view of a result's list). Exactly one of list and result is set.
template <typename S>
struct ContactRun {
  const std::vector<fcl::Contact<S>>* list;
  const fcl::CollisionResult<S>* result;
  std::size_t first, n;

  std::size_t size() const { return n; }
  const fcl::Contact<S>& operator[](std::size_t k) const {
    return list ? (*list)[first + k] : result->getContact(first + k);
  }
};

/// Every contact of the pairs given, in one fcl::CollisionResult (the caller's, which it must
/// outlive), exactly as that result passed to fclCollide for each pair in turn would hold them:
/// up to request.num_max_contacts, FCL deciding which of a pair's contacts fit where the budget
/// runs out inside the pair. `colliding` (may be null): cleared, then gets each pair that added
/// contacts, in order.
template <typename S>
class AllContacts {
 public:
  AllContacts(const fcl::CollisionRequest<S>& request, fcl::CollisionResult<S>& result,
              std::vector<ObjectPair<S>>* colliding = nullptr)
      : request_(&request),
        result_(&result),
        colliding_(colliding),
        max_(request.num_max_contacts),
        // full() at this many contacts: at least one, never with costs.
        full_at_(request.enable_cost ? std::numeric_limits<std::size_t>::max()
                                     : std::max<std::size_t>(max_, 1)),
        full_(size() >= full_at_) {
    if (colliding_ != nullptr) colliding_->clear();
  }

  /// True once the result holds the budget's contacts, for a request without costs (with costs
  /// every pair matters): a walk may stop, and further pairs add nothing.
  bool full() const { return full_; }
  /// The contacts held.
  std::size_t size() const { return result_->numContacts(); }
  /// The contacts the budget has room for.
  std::size_t room() const { return max_ - std::min(max_, size()); }
  /// The pair that gave the first contact (nullptrs while none).
  const ObjectPair<S>& firstHit() const { return first_hit_; }

  /// FCL's call for the pair on the result itself (fclCollide): FCL decides what fits.
  void collide(const ObjectPair<S>& pair) {
    const std::size_t before = size();
    fclCollide(pair.first, pair.second, *request_, *result_);
    grew(pair, before);
  }
  /// A pair proved touching (provable requests): the one contact FCL's shape collision adds
  /// (provedContact), if the result has room.
  void addProved(const ObjectPair<S>& pair) {
    const std::size_t before = size();
    if (before < max_) result_->addContact(provedContact(pair));
    grew(pair, before);
  }
  /// A pair's contacts answered apart from the result (a fresh result of the pair's, a cached
  /// answer, a PairContacts' run): appended in order if they fit, else FCL's own call on the
  /// result (a shape pair then keeps its deepest contacts, not its first). Nothing once full()
  /// or for no contacts. True if it called FCL.
  template <class Run>
  bool add(const ObjectPair<S>& pair, const Run& contacts) {
    if (full_ || contacts.size() == 0) return false;
    const std::size_t before = size();
    const bool call = contacts.size() > room();
    if (call)
      fclCollide(pair.first, pair.second, *request_, *result_);
    else
      for (std::size_t k = 0; k < contacts.size(); ++k) result_->addContact(contacts[k]);
    grew(pair, before);
    return call;
  }

 private:
  void grew(const ObjectPair<S>& pair, std::size_t before) {
    const std::size_t after = size();
    if (after > before) {
      if (before == 0) first_hit_ = pair;
      if (colliding_ != nullptr) colliding_->push_back(pair);
    }
    full_ = after >= full_at_;
  }

  const fcl::CollisionRequest<S>* request_;
  fcl::CollisionResult<S>* result_;
  std::vector<ObjectPair<S>>* colliding_;
  std::size_t max_;      // request.num_max_contacts
  std::size_t full_at_;  // the contacts that make it full
  bool full_;
  ObjectPair<S> first_hit_{nullptr, nullptr};
};

/// Each pair's own contacts, in the order the pairs were answered, in one list: a pair's are
/// those a fresh result of its own would get (room for the whole budget after what the list
/// holds), so that drainInto gives an AllContacts what the pairs' own results would, in order.
/// Filled on one thread; begin() before the first pair.
template <typename S>
class PairContacts {
 public:
  /// Starts over for a query's request (its budget per pair).
  void begin(const fcl::CollisionRequest<S>& request) {
    request_ = request;
    budget_ = request.num_max_contacts;
    hits_.clear();
    result_.clear();
  }
  /// The contacts held, over all pairs.
  std::size_t size() const { return result_.numContacts(); }
  /// FCL's call for the pair, into the list with a budget of its own.
  void collide(const ObjectPair<S>& pair) {
    const std::size_t before = size();
    constexpr std::size_t kMost = std::numeric_limits<std::size_t>::max() - 1;
    request_.num_max_contacts = before + std::min(budget_, kMost - before);
    fclCollide(pair.first, pair.second, request_, result_);
    kept(pair, before);
  }
  /// A pair proved touching: the one contact FCL's shape collision adds.
  void addProved(const ObjectPair<S>& pair) {
    const std::size_t before = size();
    result_.addContact(provedContact(pair));
    kept(pair, before);
  }
  /// Hands each pair's run to `all` (AllContacts::add), in order; returns FCL's calls it made.
  std::size_t drainInto(AllContacts<S>& all) const {
    std::size_t calls = 0;
    for (const Hit& h : hits_)
      calls += all.add(h.pair, ContactRun<S>{nullptr, &result_, h.first, h.count}) ? 1 : 0;
    return calls;
  }

 private:
  struct Hit {
    ObjectPair<S> pair;
    std::size_t first, count;  // in result_
  };
  void kept(const ObjectPair<S>& pair, std::size_t before) {
    const std::size_t added = size() - before;
    if (added > 0) hits_.push_back({pair, before, added});
  }

  fcl::CollisionRequest<S> request_;
  std::size_t budget_ = 1;
  std::vector<Hit> hits_;
  fcl::CollisionResult<S> result_;
};

/// Whether any pair is a hit, and one that is (Key: what names a pair to the query). Complete at
/// the first hit: the walk may stop, no later pair can change the answer.
template <class Key>
class AnyHit {
 public:
  /// Pairs need not be tried in any order.
  static constexpr bool kOrdered = false;
  void reset() { found_ = false; }
  bool found() const { return found_; }
  /// The hit kept; only when found().
  const Key& hit() const { return hit_; }
  /// Whether a pair named k could change the answer: only while none is found.
  bool mayBeat(const Key&) const { return !found_; }
  /// Keeps k as the hit if none is; true: complete (the walk may stop).
  bool add(const Key& k) {
    if (!found_) hit_ = k, found_ = true;
    return true;
  }
  /// Whether the answer is final.
  bool complete() const { return found_; }

 private:
  Key hit_{};
  bool found_ = false;
};

/// The least hit in Key's order (operator<), whatever order the pairs come in. Never complete
/// before the walk ends: a later pair may come first.
template <class Key>
class FirstInOrder {
 public:
  /// Pairs are worth trying in Key's order: the first hit confirmed then ends the search.
  static constexpr bool kOrdered = true;
  void reset() { found_ = false; }
  bool found() const { return found_; }
  /// The least hit; only when found().
  const Key& hit() const { return hit_; }
  /// Whether a pair named k would come before the hit kept (always, while none is).
  bool mayBeat(const Key& k) const { return !found_ || k < hit_; }
  /// Keeps k if it comes first; false: the walk goes on.
  bool add(const Key& k) {
    if (mayBeat(k)) hit_ = k, found_ = true;
    return false;
  }
  /// Whether the answer is final: only once the walk is over.
  bool complete() const { return false; }

 private:
  Key hit_{};
  bool found_ = false;
};

/// The smallest distance over the pairs given, in an fcl::DistanceResult (the caller's, which it
/// must outlive), as that result passed to fclDistance for each pair in turn would hold it where
/// pairs go through collide(); add() merges an answer found apart (the nearest points of the
/// first pair, in the order given, that reached the minimum).
template <typename S>
class Closest {
 public:
  explicit Closest(fcl::DistanceResult<S>& result) : result_(&result) {}

  /// The smallest distance so far (the largest S before any): what the judge's mayBeat reads,
  /// and what a distance walk takes as its bound.
  S bound() const { return result_->min_distance; }
  /// Whether the objects of some pair touch: no pair can beat it, the walk may stop.
  bool done() const { return bound() <= S(0); }

  /// FCL's call for the pair on the result itself (fclDistance): FCL prunes a mesh's search by
  /// the distance it holds.
  void collide(const fcl::CollisionObject<S>* a, const fcl::CollisionObject<S>* b,
               const fcl::DistanceRequest<S>& request) {
    fclDistance(a, b, request, *result_);
  }
  /// A pair's answer found apart (a fresh result, a cached one): kept if smaller.
  void add(const fcl::DistanceResult<S>& answer) { result_->update(answer); }
  /// A distance alone (no nearest points): the bound lowered to it if smaller.
  void add(S distance) {
    if (distance < result_->min_distance) result_->min_distance = distance;
  }

 private:
  fcl::DistanceResult<S>* result_;
};

/// The pairs found within their margins, kept in pair order however the pairs were answered:
/// one place per candidate pair, each filled by at most one thread. Contact: what is kept of a
/// pair (MarginContact, margins.h).
template <class Contact>
class WithinMargin {
 public:
  /// Room for n candidate pairs (indices 0..n-1), each a default Contact.
  explicit WithinMargin(std::size_t n) : found_(n), near_(n, 0) {}
  /// Candidate i's place, to fill in place by the one thread that answers it.
  Contact& at(std::size_t i) { return found_[i]; }
  /// Candidate i is within its margins, as its place says. Any thread; each i at most once.
  void keep(std::size_t i) { near_[i] = 1; }
  /// at(i) = c, then keep(i).
  void add(std::size_t i, const Contact& c) {
    found_[i] = c;
    keep(i);
  }
  /// The pairs within their margins, in candidate order.
  std::vector<Contact> take() const {
    std::vector<Contact> out;
    for (std::size_t i = 0; i < found_.size(); ++i)
      if (near_[i] != 0) out.push_back(found_[i]);
    return out;
  }

 private:
  std::vector<Contact> found_;
  std::vector<unsigned char> near_;
};

}  // namespace detail
}  // namespace cube
