#pragma once

// The objects too large for the cubes (a plane, a halfspace, anything beyond
// Config::unbounded_limit): a flat list that every query tests in full, seen by the walks as one
// leaf of infinite extent. The object table records each entry's place as pos | kUnboundedBit.

#include <algorithm>
#include <cstdint>
#include <limits>
#include <sstream>
#include <string>

#include "core/geometry.h"
#include "core/object_table.h"

namespace cube {
namespace detail {

template <typename S>
class UnboundedList {
 public:
  UnboundedList() {
    for (int k = 0; k < 3; ++k) {
      node_.lo[k] = -std::numeric_limits<float>::infinity();
      node_.hi[k] = std::numeric_limits<float>::infinity();
    }
    node_.first = 0;
    node_.count = 0;
  }
  UnboundedList(const UnboundedList&) = delete;
  UnboundedList& operator=(const UnboundedList&) = delete;

  bool empty() const { return items_.empty(); }
  std::uint32_t size() const { return std::uint32_t(items_.size()); }
  /// The list as a walk sees it: one leaf (root kNone when empty).
  View<S> view() const {
    return View<S>{&node_, items_.data(), items_.empty() ? kNone : 0u, size()};
  }
  Item<S>* data() { return items_.data(); }
  const ItemArray<S>& items() const { return items_; }
  /// The entry at a place the table recorded (location & ~kUnboundedBit).
  Item<S>& at(std::uint32_t pos) { return items_[pos]; }

  /// Appends an entry and records its place in the table.
  void add(const Item<S>& item, ObjectTable<S>& table) {
    table.setLocation(item.id, size() | kUnboundedBit);
    items_.push_back(item);
    node_.count = size();
  }
  /// Takes out the entry at `pos`: the last one fills the gap (its place recorded anew), and the
  /// removed id's place becomes kNone.
  void remove(std::uint32_t pos, ObjectTable<S>& table) {
    const ObjectId id = items_[pos].id;
    if (pos + 1 != size()) {
      items_[pos] = items_.back();
      table.setLocation(items_[pos].id, pos | kUnboundedBit);
    }
    items_.pop_back();
    node_.count = size();
    table.setLocation(id, kNone);
  }
  /// Puts the entries in registration order (removals swap entries about), so that the order of
  /// callbacks depends on the live registrations alone.
  void orderBySeq(ObjectTable<S>& table) {
    std::sort(items_.begin(), items_.end(), [&](const Item<S>& a, const Item<S>& b) {
      return table.seq(a.id) < table.seq(b.id);
    });
    for (std::uint32_t p = 0; p < size(); ++p) table.setLocation(items_[p].id, p | kUnboundedBit);
  }
  void clear() {
    items_ = {};
    node_.count = 0;
  }
  std::size_t bytes() const { return items_.capacity() * sizeof(Item<S>); }

  /// Every entry names a registered id that records this place, holds its object and a box that
  /// is unbounded by `limit`; the leaf's count matches. On failure says why.
  bool validate(const ObjectTable<S>& table, double limit, std::string* why) const {
    std::ostringstream msg;
    const auto fail = [&]() {
      if (why) *why = msg.str();
      return false;
    };
    if (node_.count != size()) return msg << "unbounded count wrong", fail();
    for (std::uint32_t p = 0; p < size(); ++p) {
      const Item<S>& it = items_[p];
      if (it.id >= table.idBound() || !table.live(it.id) || table.object(it.id) != it.obj)
        return msg << "an entry of the unbounded list names the wrong id", fail();
      if (classify(it.box, limit) != BoxKind::unbounded)
        return msg << "bounded object in the unbounded list", fail();
      if (table.location(it.id) != (p | kUnboundedBit))
        return msg << "location wrong for unbounded object " << p, fail();
    }
    return true;
  }

 private:
  ItemArray<S> items_;
  Node node_{};  // the list seen as one leaf of infinite extent
};

}  // namespace detail
}  // namespace cube
