// The object table: ids, the pointer map (open addressing with backward-shift deletion), and
// the registration numbers.

#include "core/object_table.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numeric>
#include <sstream>

namespace cube {
namespace detail {

namespace {

// Room for `more` elements past v's size, at least doubling the capacity when it must grow:
// batches of one object each (registerObjects of one object, as Python's add_object) would
// otherwise copy the whole array at every registration.
template <class V>
void reserveMore(V& v, std::size_t more) {
  const std::size_t want = v.size() + more;
  if (want > v.capacity()) v.reserve(std::max(want, 2 * v.capacity()));
}

}  // namespace

template <typename S>
ObjectId ObjectTable<S>::find(const Object* obj) const {
  if (index_.empty()) return kNone;
  for (std::size_t i = homeOf(obj);; i = nextOf(i)) {
    const std::uint32_t e = index_[i];
    if (e == 0) return kNone;
    if (object(e - 1) == obj) return e - 1;
  }
}

template <typename S>
void ObjectTable<S>::put(ObjectId id, const Object* obj) {
  std::size_t i = homeOf(obj);
  while (index_[i] != 0) i = nextOf(i);
  index_[i] = id + 1;
}

template <typename S>
void ObjectTable<S>::grow(std::size_t objects) {
  // Load factor up to 3/4: linear probing stays short, 5.3 bytes per object.
  const std::size_t cap = std::max<std::size_t>(16, (4 * (objects + 1) + 2) / 3);
  if (cap <= index_.size()) return;
  index_.assign(cap, 0);
  for (ObjectId id = 0; id < seq_.size(); ++id)
    if (live(id)) put(id, object(id));
}

template <typename S>
void ObjectTable<S>::renumber() {
  // Registration order kept, numbers from 0: happens once every four billion registrations.
  std::vector<ObjectId> live;
  for (ObjectId id = 0; id < seq_.size(); ++id)
    if (this->live(id)) live.push_back(id);
  std::sort(live.begin(), live.end(), [&](ObjectId a, ObjectId b) { return seq_[a] < seq_[b]; });
  for (std::size_t i = 0; i < live.size(); ++i) seq_[live[i]] = static_cast<std::uint32_t>(i);
  next_seq_ = static_cast<std::uint32_t>(live.size());
}

template <typename S>
void ObjectTable<S>::startKeeping() {
  // Room for what the ids already have room for (a batch reserved it): growing by doubling
  // from here left the arrays up to twice their size.
  sphere_.reserve(seq_.capacity());
  shape_.reserve(seq_.capacity());
  source_.reserve(seq_.capacity());
  sphere_.assign(seq_.size(), kNoVolume);
  shape_.assign(seq_.size(), VolumeShape{});
  source_.assign(seq_.size(), VolumeSource{});
  for (ObjectId id = 0; id < seq_.size(); ++id)
    if (live(id)) detail::rebuildVolume(*object(id), source_[id], sphere_[id], shape_[id]);
  stale_ = 0;
  keeping_.store(true, std::memory_order_release);
}

template <typename S>
void ObjectTable<S>::rebuildStale(ObjectId id, const Object& obj) {
  --stale_;
  detail::rebuildVolume(obj, source_[id], sphere_[id], shape_[id]);
}

template <typename S>
void ObjectTable<S>::moveKept(ObjectId id, const Object& obj) {
  if (!rebuildsOnMotion())
    markStale(id);
  else if (stale_ != 0 && isStale(sphere_[id]))
    rebuildStale(id, obj);  // a stale record's geometry part may be out of date too
  else
    detail::moveVolume(obj, source_[id], sphere_[id], shape_[id]);
}

template <typename S>
void ObjectTable<S>::wantVolumes() const {
  if (!volumes_ || keeping_.load(std::memory_order_acquire)) return;
  const std::lock_guard<std::mutex> lock(volume_build_);
  // The table itself is not const (the manager owns it); only this build writes from a query.
  if (!keeping_.load(std::memory_order_relaxed)) const_cast<ObjectTable*>(this)->startKeeping();
}

template <typename S>
void ObjectTable<S>::dropVolumes() {
  keeping_.store(false, std::memory_order_relaxed);
  stale_ = 0;
  // Swapped out: assigning {} would keep the capacity.
  std::vector<VolumeSphere>().swap(sphere_);
  std::vector<VolumeShape>().swap(shape_);
  std::vector<VolumeSource>().swap(source_);
}

template <typename S>
ObjectId ObjectTable<S>::add(Object* obj) {
  assert(obj != nullptr && find(obj) == kNone);
  // Grown before the id is taken: the map's growth reads placed ids' objects only. Doubles, as
  // one at a time comes the next.
  if ((live_ + 1) * 4 > index_.size() * 3) grow(2 * (live_ + 1));
  const ObjectId id = take(obj);
  put(id, obj);
  return id;
}

template <typename S>
void ObjectTable<S>::reserve(std::size_t n) {
  // Only ever grows, and then at least doubles, as add() does: sized for exactly one more
  // object, a batch of one would put every live id again.
  const std::size_t objects = live_ + n;
  if (objects * 4 > index_.size() * 3) grow(std::max(objects, 2 * live_));
  // A batch's registration numbers are consecutive (addBatch tells its ids by them).
  if (n > std::size_t(kNone - next_seq_)) renumber();
  const std::size_t fresh = n > free_.size() ? n - free_.size() : 0;
  reserveMore(seq_, fresh);
  reserveMore(loc_, fresh);
  if (keeping_.load(std::memory_order_relaxed)) {
    reserveMore(sphere_, fresh);
    reserveMore(shape_, fresh);
    reserveMore(source_, fresh);
  }
  if (!filter_.empty()) {
    reserveMore(filter_, fresh);
    reserveMore(group_, fresh);
  }
  if (!margin_.empty()) reserveMore(margin_, fresh);
}

template <typename S>
void ObjectTable<S>::remove(ObjectId id, const Object* obj) {
  assert(id < seq_.size() && live(id));  // its slot is gone already: obj comes from the caller
  unmap(id, obj, [this](ObjectId other) { return object(other); });
  release(id);
}

template <typename S>
void ObjectTable<S>::release(ObjectId id) {
  leaveGroup(id);
  if (id < excluded_count_.size() && excluded_count_[id] != 0) dropExcluded(id);
  if (stale_ != 0 && keeping_.load(std::memory_order_relaxed) && isStale(sphere_[id])) {
    --stale_;
    sphere_[id] = kNoVolume;  // a free id's record counts as no one's
  }
  seq_[id] = kNone;
  loc_[id] = kNone;
  free_.push_back(id);
  --live_;
  if (live_ == 0) clear();  // ids start again from 0
}

template <typename S>
void ObjectTable<S>::leaveGroup(ObjectId id) {
  if (group_.empty()) return;
  if (group_[id] == kMixedGroup)
    --mixed_users_;
  else
    --group_users_[group_[id]];
}

template <typename S>
Group ObjectTable<S>::joinGroup(const Filter& f) {
  Group free = kMixedGroup;
  for (std::size_t g = 0; g < group_filter_.size(); ++g) {
    if ((group_users_[g] > 0 || g == 0) && group_filter_[g] == f) {
      ++group_users_[g];
      return Group(g);
    }
    if (group_users_[g] == 0 && g != 0 && free == kMixedGroup) free = Group(g);
  }
  if (free == kMixedGroup && group_filter_.size() < kMixedGroup) {
    free = Group(group_filter_.size());
    group_filter_.emplace_back();
    group_users_.push_back(0);
  }
  if (free == kMixedGroup) {
    ++mixed_users_;
    return kMixedGroup;
  }
  group_filter_[free] = f;
  ++group_users_[free];
  return free;
}

template <typename S>
bool ObjectTable<S>::setFilter(ObjectId id, const Filter& f) {
  if (filter(id) == f) return false;
  if (filter_.empty()) {  // the first bits other than the default: everyone else in group 0
    filter_.assign(seq_.size(), Filter{});
    group_.assign(seq_.size(), 0);
    group_filter_.assign(1, Filter{});
    group_users_.assign(1, std::uint32_t(live_));
  }
  filter_[id] = f;
  const Group before = group_[id];
  leaveGroup(id);
  group_[id] = joinGroup(f);
  return group_[id] != before;
}

template <typename S>
void ObjectTable<S>::setOwnMargin(ObjectId id, S margin) {
  if (margin_.empty()) {
    if (margin < S(0)) return;  // what every id has already
    margin_.assign(seq_.size(), S(-1));
  }
  margin_[id] = margin;
}

template <typename S>
void ObjectTable<S>::viewExcluded() {
  excluded_set_ = ExcludedSet{excluded_count_.data(), excluded_count_.size(), excluded_keys_.data(),
                              excluded_keys_.size() - 1};
}

template <typename S>
void ObjectTable<S>::placeExcluded(std::uint64_t key) {
  const std::size_t mask = excluded_keys_.size() - 1;
  std::size_t i = hashKey(key) & mask;
  while (excluded_keys_[i] != kNoPair) i = (i + 1) & mask;
  excluded_keys_[i] = key;
}

template <typename S>
void ObjectTable<S>::eraseExcluded(std::uint64_t key) {
  // Backward-shift deletion, as the pointer map's.
  const std::size_t mask = excluded_keys_.size() - 1;
  std::size_t hole = hashKey(key) & mask;
  while (excluded_keys_[hole] != key) hole = (hole + 1) & mask;
  for (std::size_t j = (hole + 1) & mask; excluded_keys_[j] != kNoPair; j = (j + 1) & mask) {
    const std::size_t home = hashKey(excluded_keys_[j]) & mask;
    const bool stays = hole <= j ? (home > hole && home <= j) : (home > hole || home <= j);
    if (!stays) {
      excluded_keys_[hole] = excluded_keys_[j];
      hole = j;
    }
  }
  excluded_keys_[hole] = kNoPair;
  for (const ObjectId id : {ObjectId(key >> 32), ObjectId(key)}) --excluded_count_[id];
  if (--excluded_ == 0) {  // the last one: the memory goes with it (assigning {} keeps it)
    std::vector<std::uint32_t>().swap(excluded_count_);
    std::vector<std::uint64_t>().swap(excluded_keys_);
    excluded_set_ = ExcludedSet{};
  }
}

template <typename S>
bool ObjectTable<S>::exclude(ObjectId a, ObjectId b, bool on) {
  assert(a != b && a < seq_.size() && b < seq_.size() && live(a) && live(b));
  const std::uint64_t key = pairKey(a, b);
  if (excluded(a, b) == on) return false;
  if (!on) {
    eraseExcluded(key);
    return true;
  }
  // Room first, so that a failed allocation changes nothing.
  const std::size_t need = std::size_t(std::max(a, b)) + 1;
  std::vector<std::uint32_t> count;
  if (need > excluded_count_.size()) {  // up to every id there is: one growth per id bound
    count.assign(seq_.size(), 0);
    std::copy(excluded_count_.begin(), excluded_count_.end(), count.begin());
  }
  std::vector<std::uint64_t> keys;
  if (2 * (excluded_ + 1) > excluded_keys_.size())
    keys.assign(std::max<std::size_t>(16, 2 * excluded_keys_.size()), kNoPair);
  if (!count.empty()) excluded_count_.swap(count);
  if (!keys.empty()) {
    excluded_keys_.swap(keys);
    for (const std::uint64_t k : keys)
      if (k != kNoPair) placeExcluded(k);
  }
  placeExcluded(key);
  ++excluded_count_[a];
  ++excluded_count_[b];
  ++excluded_;
  viewExcluded();
  return true;
}

template <typename S>
void ObjectTable<S>::dropExcluded(ObjectId id) {
  std::vector<std::uint64_t> mine;
  mine.reserve(excluded_count_[id]);
  for (const std::uint64_t k : excluded_keys_)
    if (k != kNoPair && (ObjectId(k >> 32) == id || ObjectId(k) == id)) mine.push_back(k);
  for (const std::uint64_t k : mine) eraseExcluded(k);
}

template <typename S>
bool ObjectTable<S>::validateExcluded(std::string* why) const {
  std::ostringstream msg;
  auto fail = [&]() {
    if (why) *why = msg.str();
    return false;
  };
  if (excluded_ == 0) {
    if (!excluded_count_.empty() || !excluded_keys_.empty() || excluded_set_.n != 0)
      return msg << "object table: excluded-pair arrays kept without a pair", fail();
    return true;
  }
  const std::size_t cap = excluded_keys_.size();
  if (cap < 16 || (cap & (cap - 1)) != 0 || 2 * excluded_ > cap ||
      excluded_count_.size() > seq_.size() || excluded_set_.count != excluded_count_.data() ||
      excluded_set_.n != excluded_count_.size() || excluded_set_.keys != excluded_keys_.data() ||
      excluded_set_.mask != cap - 1)
    return msg << "object table: the excluded-pair set is misshapen", fail();
  std::vector<std::uint32_t> count(excluded_count_.size(), 0);
  std::size_t pairs = 0;
  for (const std::uint64_t k : excluded_keys_) {
    if (k == kNoPair) continue;
    ++pairs;
    const ObjectId x = ObjectId(k >> 32), y = ObjectId(k);
    if (!(x < y) || y >= count.size() || !live(x) || !live(y))
      return msg << "object table: excluded pair (" << x << ", " << y << ") is not of two live ids",
             fail();
    if (!excluded_set_.has(x, y))
      return msg << "object table: excluded pair (" << x << ", " << y << ") cannot be found",
             fail();
    ++count[x];
    ++count[y];
  }
  if (pairs != excluded_ || count != excluded_count_)
    return msg << "object table: excluded-pair counts wrong", fail();
  return true;
}

template <typename S>
void ObjectTable<S>::excludedPairs(std::vector<std::pair<ObjectId, ObjectId>>& out) const {
  out.clear();
  out.reserve(excluded_);
  for (const std::uint64_t k : excluded_keys_) {
    if (k == kNoPair) continue;
    ObjectId x = ObjectId(k >> 32), y = ObjectId(k);
    if (seq_[y] < seq_[x]) std::swap(x, y);
    out.emplace_back(x, y);
  }
  std::sort(out.begin(), out.end(), [&](const auto& p, const auto& q) {
    return seq_[p.first] != seq_[q.first] ? seq_[p.first] < seq_[q.first]
                                          : seq_[p.second] < seq_[q.second];
  });
}

template <typename S>
bool ObjectTable<S>::separable(int limit) const {
  if (filter_.empty() || mixed_users_ > 0 || limit <= 0) return false;
  Group used[kMixedGroup];
  int n = 0;
  for (std::size_t g = 0; g < group_filter_.size(); ++g) {
    if (group_users_[g] == 0) continue;
    if (n == limit) return false;
    used[n++] = Group(g);
  }
  for (int i = 0; i < n; ++i)
    for (int j = i; j < n; ++j)
      if (!filtersPass(group_filter_[used[i]], group_filter_[used[j]])) return true;
  return false;
}

template <typename S>
void ObjectTable<S>::clear() {
  seq_ = {};
  loc_ = {};
  keeping_.store(false, std::memory_order_relaxed);
  stale_ = 0;
  sphere_ = {};
  shape_ = {};
  source_ = {};
  filter_ = {};
  group_ = {};
  group_filter_ = {};
  group_users_ = {};
  mixed_users_ = 0;
  margin_ = {};
  std::vector<std::uint32_t>().swap(excluded_count_);
  std::vector<std::uint64_t>().swap(excluded_keys_);
  excluded_ = 0;
  excluded_set_ = ExcludedSet{};
  free_ = {};
  index_ = {};
  live_ = 0;
  next_seq_ = 0;
}

template <typename S>
void ObjectTable<S>::objects(std::vector<Object*>& out) const {
  std::vector<ObjectId> live;
  live.reserve(live_);
  for (ObjectId id = 0; id < seq_.size(); ++id)
    if (this->live(id)) live.push_back(id);
  std::sort(live.begin(), live.end(), [&](ObjectId a, ObjectId b) { return seq_[a] < seq_[b]; });
  out.resize(live.size());
  for (std::size_t i = 0; i < live.size(); ++i) out[i] = object(live[i]);
}

template <typename S>
std::size_t ObjectTable<S>::bytes() const {
  return (seq_.capacity() + loc_.capacity() + free_.capacity() + index_.capacity()) *
             sizeof(std::uint32_t) +
         (filter_.capacity() + group_filter_.capacity()) * sizeof(Filter) +
         group_.capacity() * sizeof(Group) + group_users_.capacity() * sizeof(std::uint32_t) +
         margin_.capacity() * sizeof(S) + excluded_count_.capacity() * sizeof(std::uint32_t) +
         excluded_keys_.capacity() * sizeof(std::uint64_t) +
         sphere_.capacity() * sizeof(VolumeSphere) + shape_.capacity() * sizeof(VolumeShape) +
         source_.capacity() * sizeof(VolumeSource);
}

template <typename S>
bool ObjectTable<S>::validate(std::string* why) const {
  std::ostringstream msg;
  auto fail = [&]() {
    if (why) *why = msg.str();
    return false;
  };
  const bool filters = !filter_.empty(), margins = !margin_.empty();
  const std::size_t ids = seq_.size();
  if (loc_.size() != ids ||
      (keeping_ &&
       (!volumes_ || sphere_.size() != ids || shape_.size() != ids || source_.size() != ids)) ||
      (!keeping_ && !(sphere_.empty() && shape_.empty() && source_.empty())) ||
      (filters && (filter_.size() != ids || group_.size() != ids)) ||
      (!filters && (!group_.empty() || !group_filter_.empty())) ||
      (margins && margin_.size() != ids) || group_users_.size() != group_filter_.size() ||
      group_filter_.size() > kMixedGroup || (filters && group_filter_.empty()))
    return msg << "object table: per-id arrays differ in length", fail();
  std::size_t live = 0;
  std::vector<char> is_free(ids, 0);
  for (ObjectId id : free_) {
    if (id >= ids || this->live(id) || loc_[id] != kNone || is_free[id])
      return msg << "object table: bad free id " << id, fail();
    is_free[id] = 1;
  }
  std::vector<std::uint32_t> seqs;
  std::vector<std::uint32_t> users(group_filter_.size(), 0);
  std::size_t mixed = 0, stale = 0;
  for (ObjectId id = 0; id < ids; ++id) {
    if (!this->live(id)) {
      if (!is_free[id]) return msg << "object table: id " << id << " lost", fail();
      continue;
    }
    ++live;
    stale += keeping_ && isStale(sphere_[id]) ? 1 : 0;
    // Its slot names it back (the core checks the slot's place in the cubes or the list).
    const std::uint32_t loc = loc_[id];
    if (loc == kNone ||
        ((loc & kUnboundedBit) ? (loc & ~kUnboundedBit) >= unbounded_->size()
                               : loc >= cubes_->size()) ||
        slotOf(loc).id != id || slotOf(loc).obj == nullptr)
      return msg << "object table: id " << id << " has no slot naming it", fail();
    if (find(object(id)) != id) return msg << "object table: map misses id " << id, fail();
    if (seq_[id] >= next_seq_) return msg << "object table: id " << id << " seq ahead", fail();
    seqs.push_back(seq_[id]);
    if (margins && !std::isfinite(margin_[id]))
      return msg << "object table: id " << id << " has a bad margin", fail();
    if (!filters) continue;
    const Group g = group_[id];
    if (g == kMixedGroup) {
      ++mixed;
    } else if (g >= group_filter_.size() || !(group_filter_[g] == filter_[id])) {
      return msg << "object table: id " << id << " in a group of other bits", fail();
    } else {
      ++users[g];
    }
  }
  if (users != group_users_ || mixed != mixed_users_)
    return msg << "object table: group user counts wrong", fail();
  if (!group_filter_.empty() && !group_filter_[0].isDefault())
    return msg << "object table: group 0 is not the default bits", fail();
  for (std::size_t g = 0; g < group_filter_.size(); ++g)
    for (std::size_t h = g + 1; h < group_filter_.size(); ++h)
      if (users[g] > 0 && users[h] > 0 && group_filter_[g] == group_filter_[h])
        return msg << "object table: groups " << g << " and " << h << " have equal bits", fail();
  std::sort(seqs.begin(), seqs.end());
  if (std::adjacent_find(seqs.begin(), seqs.end()) != seqs.end())
    return msg << "object table: two objects share a registration number", fail();
  if (live != live_) return msg << "object table: live count " << live_ << " != " << live, fail();
  if (stale != stale_)
    return msg << "object table: " << stale_ << " stale records counted, " << stale << " found",
           fail();
  std::size_t entries = 0;
  for (std::uint32_t e : index_) entries += e != 0;
  if (entries != live_) return msg << "object table: map holds " << entries << " entries", fail();
  if (!index_.empty() && (index_.size() < 16 || live_ * 4 > index_.size() * 3))
    return msg << "object table: map of " << index_.size() << " places holds " << live_
               << " ids, over its load limit",
           fail();
  return validateExcluded(why);
}

template class ObjectTable<float>;
template class ObjectTable<double>;

}  // namespace detail
}  // namespace cube
