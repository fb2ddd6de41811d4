#pragma once

// What the collide stream's two files (collide_stream.cpp: pairs pushed; collide_stream_tasks.cpp:
// blocks and a split walk's tasks) share: the blocks' size, and the stream's slots and scratch.

#include <fcl/narrowphase/collision_result.h>

#include <array>
#include <cstddef>
#include <vector>

#include "pipeline/cache.h"
#include "pipeline/collide_stream.h"

namespace cube {
namespace detail {

// A chunk's pairs are answered in blocks of kBlock (CollideStream::cullBlock), reading the first
// kObjectLines cache lines of an object (its geometry pointer and pose: the first 160 of 224 bytes
// for double) and kGeometryLines of a geometry (120 bytes of base, then the shape's fields).
inline constexpr std::size_t kBlock = 16;
inline constexpr std::size_t kObjectLines = 3;
inline constexpr std::size_t kGeometryLines = 3;

// 0, 1, ..., kBlock - 1: the index of a block answered in place.
inline constexpr std::array<std::size_t, kBlock> kInPlace = [] {
  std::array<std::size_t, kBlock> a{};
  for (std::size_t k = 0; k < kBlock; ++k) a[k] = k;
  return a;
}();

// A split walk's task, answered on its thread: its counts, and each pair's contacts in walk
// order (PairContacts: FCL writes each pair's into one list directly), for the stream's
// collector.
template <typename S>
struct CollideStream<S>::TaskAnswers {
  NarrowPhaseStats stats;
  PairContacts<S> contacts;
};

template <typename S>
struct CollideStream<S>::Slot {
  Answer kind = Answer::kApart;
  bool judged = false;    // kind is the cull's already (pairs with volumes)
  bool refined = false;   // and from its tight part, after the cache missed: stored like FCL's
  bool deferred = false;  // the cull on va, vb runs in the block (a split walk's task)
  CollideEntry<S>* cached = nullptr;
  Volumes va, vb;
  fcl::CollisionResult<S> fresh;
};

// A worker's block of a task: its pairs and their slots, kept from task to task (a slot's result
// keeps its list's memory).
template <typename S>
struct CollideStream<S>::TaskScratch {
  std::array<ObjectPair<S>, kBlock> block;
  std::array<Slot, kBlock> slots;
};

}  // namespace detail
}  // namespace cube
