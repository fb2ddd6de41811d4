// The collectors (src/pipeline/collectors.h), each against its brute-force meaning: AllContacts
// and PairContacts keep what one result passed to fcl::collide for each pair in turn keeps,
// whichever way each pair's contacts reach them; Closest keeps the minimum of fcl::distance over
// the pairs; AnyHit any hit, FirstInOrder the least; WithinMargin the pairs added, in candidate
// order, from any thread.

#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <thread>
#include <vector>

#include "pipeline/collectors.h"
#include "scenes.h"
#include "support/fcl_contacts.h"

namespace {

template <typename S>
class Collectors : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(Collectors, Scalars);

using cube::ObjectPair;
using cube::scenes::Layout;
using namespace fclcontacts;

// Every pair i < j whose AABBs overlap, in (i, j) order: the pairs a walk could hand over.
template <typename S>
std::vector<ObjectPair<S>> overlapping(const cube::scenes::Scene<S>& s) {
  std::vector<ObjectPair<S>> out;
  const auto p = s.pointers();
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j)
      if (p[i]->getAABB().overlap(p[j]->getAABB())) out.emplace_back(p[i], p[j]);
  return out;
}

// Every pair i < j, in (i, j) order.
template <typename S>
std::vector<ObjectPair<S>> allPairs(const cube::scenes::Scene<S>& s) {
  std::vector<ObjectPair<S>> out;
  const auto p = s.pointers();
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) out.emplace_back(p[i], p[j]);
  return out;
}

// The brute force: fcl::collide on each pair in turn into one result, stopping once it holds the
// budget (FCL's DefaultCollisionFunction). `fed`: the pairs called; `colliding`: those that
// added contacts.
template <typename S>
struct Sequential {
  fcl::CollisionResult<S> result;
  std::vector<ObjectPair<S>> colliding;
  std::size_t fed = 0;
  bool stopped = false;

  Sequential(const std::vector<ObjectPair<S>>& pairs, const fcl::CollisionRequest<S>& request) {
    for (const ObjectPair<S>& p : pairs) {
      if (stopped) break;
      ++fed;
      const std::size_t before = result.numContacts();
      fcl::collide(p.first, p.second, request, result);
      if (result.numContacts() > before) colliding.push_back(p);
      stopped = result.isCollision() && result.numContacts() >= request.num_max_contacts;
    }
  }
};

// Whether a pair touches and the request lets the judge prove it (no contact geometry asked,
// shapes: FCL adds the one contact provedContact makes).
template <typename S>
bool provable(const ObjectPair<S>& p, const fcl::CollisionRequest<S>& request) {
  if (request.enable_contact || p.first->getObjectType() != fcl::OT_GEOM ||
      p.second->getObjectType() != fcl::OT_GEOM)
    return false;
  fcl::CollisionResult<S> r;
  return fcl::collide(p.first, p.second, request, r) > 0;
}

// A pair's contacts reach AllContacts in one of four ways: FCL on its result, a fresh result of
// the pair's own, a list (as a cached answer), or proved touching.
enum Way { kCollide, kFresh, kList, kProved };

template <typename S>
void feed(cube::detail::AllContacts<S>& all, const ObjectPair<S>& p,
          const fcl::CollisionRequest<S>& request, Way way) {
  using cube::detail::ContactRun;
  if (way == kProved && provable(p, request)) return all.addProved(p);
  if (way == kCollide || way == kProved) return all.collide(p);
  fcl::CollisionResult<S> fresh;
  fcl::collide(p.first, p.second, request, fresh);
  if (way == kFresh) {
    all.add(p, ContactRun<S>{nullptr, &fresh, 0, fresh.numContacts()});
    return;
  }
  std::vector<fcl::Contact<S>> list;
  fresh.getContacts(list);
  all.add(p, ContactRun<S>{&list, nullptr, 0, list.size()});
}

// However each pair's contacts reach it, and whatever the budget, AllContacts holds what FCL's
// calls in turn on one result hold, says full() where they would stop, and lists the pairs that
// added contacts, the first of them as firstHit().
TYPED_TEST(Collectors, AllContactsFedAnyWayEqualsFclCollideInTurn) {
  using S = TypeParam;
  for (bool meshes : {false, true}) {
    const auto sc = scene<S>(Layout::clustered, meshes, meshes ? 40 : 80, 11);
    const auto pairs = overlapping(sc);
    for (const auto& request : requests<S>()) {
      const Sequential<S> want(pairs, request);
      if (request.num_max_contacts > 100) {
        ASSERT_GT(want.colliding.size(), 10u) << "the scene must collide";
      }
      std::mt19937 rng(5);
      for (int mix = 0; mix < 6; ++mix) {
        fcl::CollisionResult<S> got;
        std::vector<ObjectPair<S>> colliding(3);  // stale: the collector replaces it
        cube::detail::AllContacts<S> all(request, got, &colliding);
        std::size_t fed = 0;
        for (const ObjectPair<S>& p : pairs) {
          if (all.full()) break;
          ++fed;
          feed(all, p, request, mix < 4 ? Way(mix) : Way(rng() % 4));
        }
        const auto what = ::testing::Message()
                          << "meshes " << meshes << " max " << request.num_max_contacts
                          << " contact " << request.enable_contact << " mix " << mix;
        EXPECT_TRUE(sameContacts(got, want.result, request.enable_contact)) << what;
        EXPECT_EQ(colliding, want.colliding) << what;
        EXPECT_EQ(fed, want.fed) << what;
        EXPECT_EQ(all.full(), want.stopped) << what;
        EXPECT_EQ(all.size(), want.result.numContacts()) << what;
        const ObjectPair<S> first =
            want.colliding.empty() ? ObjectPair<S>(nullptr, nullptr) : want.colliding[0];
        EXPECT_EQ(all.firstHit(), first) << what;
      }
    }
  }
}

// Pairs answered in runs apart (a split walk's tasks: PairContacts), each run drained in order,
// give AllContacts what FCL's calls in turn on one result give; a pair whose contacts overflow
// the budget is the only one that costs AllContacts an FCL call.
TYPED_TEST(Collectors, PairContactsDrainedInOrderEqualFclCollideInTurn) {
  using S = TypeParam;
  for (bool meshes : {false, true}) {
    const auto sc = scene<S>(Layout::clustered, meshes, meshes ? 40 : 80, 12);
    const auto pairs = overlapping(sc);
    for (const auto& request : requests<S>()) {
      const Sequential<S> want(pairs, request);
      std::mt19937 rng(9);
      fcl::CollisionResult<S> got;
      std::vector<ObjectPair<S>> colliding;
      cube::detail::AllContacts<S> all(request, got, &colliding);
      std::size_t calls = 0;
      for (std::size_t first = 0; first < pairs.size();) {
        const std::size_t n = std::min<std::size_t>(1 + rng() % 40, pairs.size() - first);
        cube::detail::PairContacts<S> run;
        run.begin(request);
        std::size_t held = 0;
        for (std::size_t k = first; k < first + n; ++k) {
          if (rng() % 2 == 0 && provable(pairs[k], request))
            run.addProved(pairs[k]);
          else
            run.collide(pairs[k]);
          fcl::CollisionResult<S> own;  // each pair keeps its whole budget
          fcl::collide(pairs[k].first, pairs[k].second, request, own);
          held += own.numContacts();
        }
        EXPECT_EQ(run.size(), held);
        calls += run.drainInto(all);
        first += n;
      }
      const auto what = ::testing::Message()
                        << "meshes " << meshes << " max " << request.num_max_contacts << " contact "
                        << request.enable_contact;
      EXPECT_TRUE(sameContacts(got, want.result, request.enable_contact)) << what;
      EXPECT_EQ(colliding, want.colliding) << what;
      EXPECT_EQ(all.full(), want.stopped) << what;
      EXPECT_LE(calls, 1u) << what;
    }
  }
}

// Closest's bound is the minimum of fcl::distance over the pairs, whichever way each reaches it
// (FCL on its result, a fresh result, a distance alone), done() once it is 0 or less; with
// results, the nearest points are those of the first pair that reached the minimum.
TYPED_TEST(Collectors, ClosestEqualsMinimumOfFclDistance) {
  using S = TypeParam;
  for (double size : {0.05, 1.0}) {  // apart; touching
    const auto sc = scene<S>(Layout::clustered, false, 80, 13, size);
    const auto pairs = allPairs(sc);
    fcl::DistanceRequest<S> request(true);
    std::vector<fcl::DistanceResult<S>> own(pairs.size());
    std::size_t best = 0;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      fcl::distance(pairs[i].first, pairs[i].second, request, own[i]);
      if (own[i].min_distance < own[best].min_distance) best = i;
    }
    const S want = own[best].min_distance;
    if (size < 1)
      ASSERT_GT(want, S(0)) << "a scene apart";
    else
      ASSERT_LE(want, S(0)) << "a scene that touches";
    std::mt19937 rng(3);
    for (int mix = 0; mix < 4; ++mix) {
      fcl::DistanceResult<S> result;
      cube::detail::Closest<S> closest(result);
      EXPECT_EQ(closest.bound(), std::numeric_limits<S>::max());
      EXPECT_FALSE(closest.done());
      bool points = true;  // every pair came with its result
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        const int way = mix < 3 ? mix : int(rng() % 2);
        if (way == 0) closest.collide(pairs[i].first, pairs[i].second, request);
        if (way == 1) closest.add(own[i]);
        if (way == 2) closest.add(own[i].min_distance), points = false;
      }
      const auto what = ::testing::Message() << "size " << size << " mix " << mix;
      EXPECT_EQ(closest.bound(), want) << what;
      EXPECT_EQ(closest.done(), want <= S(0)) << what;
      if (points) {
        EXPECT_EQ(result.o1, own[best].o1) << what;
        EXPECT_EQ(result.o2, own[best].o2) << what;
        EXPECT_TRUE(sameBits(result.nearest_points[0], own[best].nearest_points[0])) << what;
        EXPECT_TRUE(sameBits(result.nearest_points[1], own[best].nearest_points[1])) << what;
      }
    }
  }
}

// AnyHit: found() is any-of over the pairs added, the first added is kept, and the answer is
// complete (the walk may stop) from that hit on; FirstInOrder keeps the least key whatever the
// order the hits come in, says which keys could still beat it, and is never complete.
TEST(Collectors, AnyHitIsAnyOfAndFirstInOrderIsTheLeastHit) {
  std::mt19937 rng(17);
  for (int round = 0; round < 200; ++round) {
    std::vector<int> keys(rng() % 20);
    for (int& k : keys) k = int(rng() % 50);
    std::vector<bool> hit(keys.size());
    for (std::size_t i = 0; i < keys.size(); ++i) hit[i] = rng() % 4 == 0;
    cube::detail::AnyHit<int> any;
    cube::detail::FirstInOrder<int> first;
    any.reset();
    first.reset();
    bool stop = false;
    int any_first = -1, least = -1;
    for (std::size_t i = 0; i < keys.size(); ++i) {
      EXPECT_EQ(any.mayBeat(keys[i]), any_first < 0);
      EXPECT_EQ(first.mayBeat(keys[i]), least < 0 || keys[i] < least);
      if (!hit[i]) continue;
      if (any_first < 0) any_first = keys[i];
      if (least < 0 || keys[i] < least) least = keys[i];
      stop = any.add(keys[i]);
      EXPECT_TRUE(stop);
      EXPECT_FALSE(first.add(keys[i]));
      EXPECT_TRUE(any.complete());
      EXPECT_FALSE(first.complete());
    }
    const bool any_of = std::any_of(hit.begin(), hit.end(), [](bool h) { return h; });
    EXPECT_EQ(any.found(), any_of);
    EXPECT_EQ(first.found(), any_of);
    EXPECT_EQ(stop, any_of);
    if (any_of) {
      EXPECT_EQ(any.hit(), any_first);
      EXPECT_EQ(first.hit(), least);
    }
  }
  EXPECT_FALSE(cube::detail::AnyHit<int>::kOrdered);
  EXPECT_TRUE(cube::detail::FirstInOrder<int>::kOrdered);
}

// WithinMargin gives the pairs added (or filled in place and kept), in candidate order, whichever
// threads added them and in whatever order.
TEST(Collectors, WithinMarginKeepsCandidateOrderFromAnyThread) {
  const std::size_t n = 5000;
  std::mt19937 rng(23);
  std::vector<bool> near(n);
  for (std::size_t i = 0; i < n; ++i) near[i] = rng() % 3 == 0;
  cube::detail::WithinMargin<std::size_t> kept(n);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (std::size_t i = n - 1 - t; i < n; i -= 4)  // backwards, interleaved
        if (near[i] && i % 2 == 0)
          kept.add(i, i * 7);
        else if (near[i])
          kept.at(i) = i * 7, kept.keep(i);  // filled in place
    });
  for (std::thread& t : threads) t.join();
  std::vector<std::size_t> want;
  for (std::size_t i = 0; i < n; ++i)
    if (near[i]) want.push_back(i * 7);
  EXPECT_EQ(kept.take(), want);
}

}  // namespace
