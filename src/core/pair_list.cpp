// The pair list that update() keeps for the next self-collide: listed by one self walk, then
// brought up to date by querying only the objects that moved.

#include "core/pair_list.h"

#include <algorithm>

namespace cube {
namespace detail {

namespace {

// All pairs of `scene` into `out` (appended), in the order of a self-collide's callbacks.
template <typename S>
void listAll(const Scene<S>& scene, std::vector<std::uint64_t>& out) {
  forSelfViews(scene, [&](const View<S>& a, const View<S>& b, bool self) {
    collectPairs(a, b, self, scene.all_pairs_limit, out);
    return false;
  });
}

// A pair with the smaller id first: the form in which pairs are compared.
inline std::uint64_t ordered(std::uint64_t p) {
  const std::uint64_t a = p >> 32, b = p & 0xffffffffu;
  return a < b ? p : (b << 32 | a);
}

void orderAll(std::vector<std::uint64_t>& v) {
  for (std::uint64_t& p : v) p = ordered(p);
  std::sort(v.begin(), v.end());
}

}  // namespace

template <typename S>
void PairList<S>::release() {
  valid_ = false;
  for (auto* v : {&pairs_, &marks_, &found_}) {
    v->clear();
    v->shrink_to_fit();
  }
  objs_ = {};
}

template <typename S>
void PairList<S>::list(const Scene<S>& scene, const ObjectTable<S>& table) {
  valid_ = false;
  pairs_.clear();
  listAll(scene, pairs_);
  objs_.resize(table.idBound());
  for (ObjectId id = 0; id < objs_.size(); ++id)
    objs_[id] = table.live(id) ? table.object(id) : nullptr;
  valid_ = true;
}

template <typename S>
void PairList<S>::refresh(const Scene<S>& scene, const std::vector<ObjectId>& moved,
                          std::size_t id_bound) {
  if (moved.empty()) {  // an update that moved nothing: the list stands as it was
    valid_ = true;
    return;
  }
  valid_ = false;
  marks_.assign((id_bound + 63) / 64, 0);
  found_.clear();
  for (const ObjectId id : moved) {
    marks_[id / 64] |= std::uint64_t(1) << (id % 64);
    const Item<S>& it = scene.item(id);
    const SingleView<S> query(it.obj, it.box, id);
    forObjectViews(scene, query.view(), [&](const View<S>& a, const View<S>& b, bool) {
      collectPairs(a, b, false, 0, found_);
      return false;
    });
  }
  // A pair of two moved objects was found from both ends.
  orderAll(found_);
  found_.erase(std::unique(found_.begin(), found_.end()), found_.end());
  const auto marked = [&](std::uint32_t id) { return (marks_[id / 64] >> (id % 64)) & 1; };
  // Drop the moved objects' old pairs in one pass, without a branch per pair.
  std::size_t kept = 0;
  for (const std::uint64_t p : pairs_) {
    pairs_[kept] = p;
    kept += !(marked(static_cast<std::uint32_t>(p >> 32)) | marked(static_cast<std::uint32_t>(p)));
  }
  pairs_.resize(kept);
  pairs_.insert(pairs_.end(), found_.begin(), found_.end());
  valid_ = true;
}

template <typename S>
bool PairList<S>::collide(void* data, CollideFn<S> fn, QueryStats* stats) const {
  for (const std::uint64_t p : pairs_) {
    if (stats) ++stats->callbacks;
    const auto a = static_cast<ObjectId>(p >> 32), b = static_cast<ObjectId>(p);
    if (fn(objs_[a], a, objs_[b], b, data)) return true;
  }
  return false;
}

template <typename S>
template <class Then>
bool PairList<S>::forPassing(const PairGate<S>& gate, Then&& then) const {
  const auto id = [](ObjectId i) { return i; };
  const auto obj = [&](ObjectId i) { return objs_[i]; };
  // Blocks of 64 pairs: the bits first, without a branch per pair, then the rest of the rules
  // and the calls for the pairs left. Only ids and the per-id arrays are read, never a record.
  for (std::size_t base = 0; base < pairs_.size(); base += 64) {
    const std::uint64_t* block = pairs_.data() + base;
    const std::size_t n = std::min<std::size_t>(64, pairs_.size() - base);
    std::uint64_t pass = n == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << n) - 1;
    if (gate.hasBits())
      pass = gate.passing(pass, [&](unsigned b) {
        return gate.bitsOf(static_cast<ObjectId>(block[b] >> 32), static_cast<ObjectId>(block[b]));
      });
    for (; pass != 0; pass &= pass - 1) {
      const std::uint64_t p = block[__builtin_ctzll(pass)];
      if (gate.finish(static_cast<ObjectId>(p >> 32), static_cast<ObjectId>(p), id, obj, then))
        return true;
    }
  }
  return false;
}

template <typename S>
bool PairList<S>::collide(const PairGate<S>& gate, void* data, CollideFn<S> fn,
                          QueryStats* stats) const {
  return forPassing(gate, [&](ObjectId a, ObjectId b) {
    if (stats) ++stats->callbacks;
    return fn(objs_[a], a, objs_[b], b, data);
  });
}

template <typename S>
void PairList<S>::collect(const PairGate<S>& gate, std::vector<std::uint64_t>& out) const {
  forPassing(gate, [&](ObjectId a, ObjectId b) {
    out.push_back(std::uint64_t(a) << 32 | b);
    return false;
  });
}

template <typename S>
std::size_t PairList<S>::bytes() const {
  return (pairs_.capacity() + marks_.capacity() + found_.capacity()) * sizeof(std::uint64_t) +
         objs_.capacity() * sizeof(objs_[0]);
}

template <typename S>
bool PairList<S>::validate(const Scene<S>& scene, const ObjectTable<S>& table,
                           std::string* why) const {
  if (!valid_) return true;
  // Ids past the listed ones may exist (a refused batch leaves its fresh ids free), none live.
  for (ObjectId id = 0; id < table.idBound(); ++id)
    if (table.live(id) && (id >= objs_.size() || objs_[id] != table.object(id))) {
      if (why) *why = "the pair list names the wrong object of an id";
      return false;
    }
  std::vector<std::uint64_t> want, got(pairs_);
  listAll(scene, want);
  orderAll(want);
  orderAll(got);
  const char* problem = nullptr;
  if (std::adjacent_find(got.begin(), got.end()) != got.end())
    problem = "the pair list holds a pair twice";
  else if (got != want)
    problem = "the pair list differs from the overlapping pairs of the current boxes";
  if (problem == nullptr) return true;
  if (why) *why = problem;
  return false;
}

template class PairList<float>;
template class PairList<double>;

}  // namespace detail
}  // namespace cube
