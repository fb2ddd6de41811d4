// The inspection snapshot: one breadth-first walk numbers the cubes, one depth-first walk lists
// the objects so that every subtree's objects are contiguous. Both walks use explicit containers.

#include "cube_collision/inspect.h"

#include <algorithm>
#include <functional>
#include <iomanip>
#include <limits>
#include <ostream>
#include <stdexcept>
#include <string>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "core/walk.h"
#include "cube_collision/cube_collision_manager.h"

namespace cube {

namespace {

double volumeOf(const detail::Node& n) {
  if (n.lo[0] > n.hi[0]) return 0.0;
  return (double(n.hi[0]) - n.lo[0]) * (double(n.hi[1]) - n.lo[1]) * (double(n.hi[2]) - n.lo[2]);
}

template <typename S>
BoundingBox toBox(const detail::Box<S>& b) {
  BoundingBox out;
  for (int k = 0; k < 3; ++k) {
    out.first[k] = double(b.lo[k]);
    out.second[k] = double(b.hi[k]);
  }
  return out;
}

}  // namespace

template <typename S>
HierarchyView<S>::HierarchyView(const CubeCollisionManager<S>& manager) {
  const detail::Broadphase<S>& core = detail::coreOf(manager);
  const detail::CubeTree<S>& h = core.tree();
  const detail::NodeArray& nodes = h.nodes();
  const auto& items = h.items();

  // Breadth-first numbering. `raw[k]` is the storage index of cube k; the queue is `raw` itself.
  std::vector<std::uint32_t> raw;
  if (h.root() != detail::kNone) {
    raw.push_back(h.root());
    cubes_.push_back(CubeData{{}, {}, 0, 0, 0, 0, -1, 0});
  }
  for (std::size_t k = 0; k < raw.size(); ++k) {
    const detail::Node& n = nodes[raw[k]];
    CubeData& c = cubes_[k];
    for (int a = 0; a < 3; ++a) {
      c.min[a] = double(n.lo[a]);
      c.max[a] = double(n.hi[a]);
    }
    if (static_cast<std::size_t>(c.level) == level_begin_.size())
      level_begin_.push_back(static_cast<int>(k));
    if (n.isLeaf()) {
      c.first_child = c.end_child = 0;
      continue;
    }
    const int first = static_cast<int>(raw.size());
    c.first_child = first;
    c.end_child = first + 2;
    const int level = c.level;  // `c` may dangle once cubes_ grows
    for (std::uint32_t child : {n.first, n.first + 1}) {
      raw.push_back(child);
      cubes_.push_back(CubeData{{}, {}, 0, 0, 0, 0, static_cast<int>(k), level + 1});
    }
  }
  level_begin_.push_back(static_cast<int>(cubes_.size()));

  // Depth-first, first child first: the leaves' objects, each subtree contiguous. The state is
  // the cube's breadth-first number.
  if (!cubes_.empty())
    detail::walkPreorder(
        nodes, h.root(), 0,
        [&](std::uint32_t cube, int k) {
          CubeData& c = cubes_[static_cast<std::size_t>(k)];
          if (c.first_child != c.end_child) return detail::Step::open;
          const detail::Node& n = nodes[cube];
          c.first_object = static_cast<int>(objects_.size());
          for (std::uint32_t p = n.first; p < n.first + n.count; ++p) {
            objects_.push_back(items[p].obj);
            object_boxes_.push_back(toBox(items[p].box));
            leaf_of_.emplace_back(items[p].obj, k);
          }
          c.end_object = static_cast<int>(objects_.size());
          return detail::Step::skip;
        },
        [&](int which, int k) { return cubes_[static_cast<std::size_t>(k)].first_child + which; });
  // Children are numbered after their parent: a reverse sweep sees them first.
  for (std::size_t k = cubes_.size(); k-- > 0;) {
    CubeData& c = cubes_[k];
    if (c.first_child == c.end_child) continue;
    c.first_object = cubes_[static_cast<std::size_t>(c.first_child)].first_object;
    c.end_object = cubes_[static_cast<std::size_t>(c.end_child - 1)].end_object;
  }
  std::sort(leaf_of_.begin(), leaf_of_.end(), [](const auto& a, const auto& b) {
    return std::less<const Object*>()(a.first, b.first);
  });
  for (const auto& it : core.unboundedItems()) unbounded_.push_back(it.obj);

  // Statistics.
  HierarchyStats& s = stats_;
  s.objects = objects_.size();
  s.unbounded_objects = unbounded_.size();
  s.cubes = cubes_.size();
  s.depth = depth();
  for (int l = 0; l < levelCount(); ++l)
    s.cubes_per_level.push_back(
        static_cast<std::size_t>(level_begin_[std::size_t(l) + 1] - level_begin_[std::size_t(l)]));
  for (std::size_t k = 0; k < cubes_.size(); ++k) {
    const detail::Node& n = nodes[raw[k]];
    s.surface_area += detail::surfaceArea(n);
    s.volume += volumeOf(n);
    if (h.view().groups != nullptr && h.view().groups[raw[k]] != detail::kMixedGroup)
      ++s.one_group_cubes;
    if (!n.isLeaf()) continue;
    ++s.leaves;
    if (s.leaf_size_histogram.size() <= n.count) s.leaf_size_histogram.resize(n.count + 1, 0);
    ++s.leaf_size_histogram[n.count];
    s.max_leaf_size = std::max<std::size_t>(s.max_leaf_size, n.count);
  }
  s.mean_leaf_size = s.leaves ? double(s.objects) / double(s.leaves) : 0.0;
  s.quality_ratio = h.quality();
  s.rebuild_threshold = core.config().rebuild_threshold;
  s.dead_cubes = nodes.size() - cubes_.size();
  for (const auto& it : items)
    if (it.obj == nullptr) ++s.dead_object_slots;
  s.builds = h.buildCount();
  s.bytes = core.bytes();
  const std::size_t all = s.objects + s.unbounded_objects;
  s.bytes_per_object = all ? double(s.bytes) / double(all) : 0.0;
}

template <typename S>
const CubeData& HierarchyView<S>::getCubeData(int i) const {
  if (i < 0 || i >= getNumberCells())
    throw std::out_of_range("cube::HierarchyView: no cube " + std::to_string(i));
  return cubes_[static_cast<std::size_t>(i)];
}

template <typename S>
bool HierarchyView<S>::isLeaf(int i) const {
  const CubeData& c = getCubeData(i);
  return c.first_child == c.end_child;
}

template <typename S>
std::pair<int, int> HierarchyView<S>::getInternalChildren(int i) const {
  const CubeData& c = getCubeData(i);
  return {c.first_child, c.end_child};
}

template <typename S>
typename HierarchyView<S>::ObjectRange HierarchyView<S>::getExternalChildren(int i) const {
  const CubeData& c = getCubeData(i);
  Object* const* base = objects_.data();
  return ObjectRange{base + c.first_object, base + c.end_object};
}

template <typename S>
int HierarchyView<S>::getLeafIndex(const Object* object) const {
  const auto it = std::lower_bound(
      leaf_of_.begin(), leaf_of_.end(), object,
      [](const auto& e, const Object* o) { return std::less<const Object*>()(e.first, o); });
  return it != leaf_of_.end() && it->first == object ? it->second : -1;
}

template <typename S>
void HierarchyView<S>::getBoundingTree(std::vector<BoundingBox>& out) const {
  out.clear();
  out.reserve(cubes_.size());
  for (const CubeData& c : cubes_) out.emplace_back(c.min, c.max);
}

template <typename S>
std::pair<int, int> HierarchyView<S>::levelCubes(int l) const {
  if (l < 0 || l >= levelCount()) return {0, 0};
  return {level_begin_[static_cast<std::size_t>(l)], level_begin_[static_cast<std::size_t>(l) + 1]};
}

std::ostream& operator<<(std::ostream& os, const HierarchyStats& s) {
  const std::ios_base::fmtflags flags = os.flags();
  const std::streamsize precision = os.precision();
  os << std::setprecision(4);
  os << "objects: " << s.objects << " in cubes, " << s.unbounded_objects << " unbounded\n";
  os << "cubes: " << s.cubes << " (" << s.leaves << " leaves), depth " << s.depth << "\n";
  os << "cubes per level:";
  for (std::size_t n : s.cubes_per_level) os << ' ' << n;
  os << "\nleaf sizes (objects: leaves):";
  for (std::size_t k = 0; k < s.leaf_size_histogram.size(); ++k)
    if (s.leaf_size_histogram[k]) os << ' ' << k << ": " << s.leaf_size_histogram[k];
  os << "\nmean leaf size " << s.mean_leaf_size << ", max " << s.max_leaf_size << "\n";
  os << "total cube surface area " << s.surface_area << ", volume " << s.volume << "\n";
  os << "quality ratio (area / area at last build) " << s.quality_ratio << ", rebuild threshold "
     << s.rebuild_threshold << ", builds " << s.builds << "\n";
  if (s.one_group_cubes > 0) os << "cubes of one filter group: " << s.one_group_cubes << "\n";
  os << "garbage: " << s.dead_cubes << " dead cubes, " << s.dead_object_slots
     << " dead object slots\n";
  os << "memory: " << s.bytes << " bytes, " << s.bytes_per_object << " per object\n";
  os.flags(flags);
  os.precision(precision);
  return os;
}

template class HierarchyView<float>;
template class HierarchyView<double>;

}  // namespace cube
