// Memory of a drop-in manager: the heap a manager holds per object after construction,
// registerObjects and setup (the way a user replacing an FCL manager builds it), and the peak of
// the heap during that build, for the cube manager and FCL's dynamic trees, on the uniform scene
// (double; the cube manager and FCL's dynamic tree in float too).
// For the cube manager also where its bytes go (its components' bytes()).
//
//   cube_memory [n ...] [--json out.json]        (default n: 10000 100000 1000000 2000000)
//
// Every allocation of the process is counted: malloc and its kin are replaced here by wrappers
// around glibc's own (__libc_malloc, ...) that add up each block's size as glibc holds it (its
// usable size plus the 8-byte header in front of it, as mallinfo2's uordblks counts), in use
// and at its highest, exactly. Each manager's pairs are
// counted by a self-collide and must agree with FCL's dynamic tree's (the exit status says).
// The build (construction, registerObjects, setup) and the self-collide are timed too (wall
// clock, the best of three builds and self-collides),
// with the counting allocator in place: a few atomic additions per heap block, which FCL's trees
// allocate per node and the cube manager a few times per build.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree_array.h>
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "adapter/manager_access.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

// ---------------------------------------------------------------------------------------------
// The counting allocator

extern "C" {
void* __libc_malloc(std::size_t);
void __libc_free(void*);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
}

namespace {

std::atomic<long long> g_live{0};
std::atomic<long long> g_peak{0};

long long blockBytes(void* p) {
  return static_cast<long long>(malloc_usable_size(p) + sizeof(std::size_t));
}

void counted(void* p) {
  if (p == nullptr) return;
  const long long size = blockBytes(p);
  const long long now = g_live.fetch_add(size, std::memory_order_relaxed) + size;
  long long peak = g_peak.load(std::memory_order_relaxed);
  while (now > peak && !g_peak.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
  }
}

void uncounted(void* p) {
  if (p != nullptr) g_live.fetch_sub(blockBytes(p), std::memory_order_relaxed);
}

bool powerOfTwo(std::size_t a) {
  return a != 0 && (a & (a - 1)) == 0;
}

}  // namespace

extern "C" {
void* malloc(std::size_t n) {
  void* p = __libc_malloc(n);
  counted(p);
  return p;
}
void free(void* p) {
  uncounted(p);
  __libc_free(p);
}
void* calloc(std::size_t n, std::size_t size) {
  void* p = __libc_calloc(n, size);
  counted(p);
  return p;
}
void* realloc(void* p, std::size_t n) {
  uncounted(p);
  void* q = __libc_realloc(p, n);
  if (q == nullptr && n != 0) {
    counted(p);  // the old block stays
    return nullptr;
  }
  counted(q);
  return q;
}
void* memalign(std::size_t align, std::size_t n) {
  void* p = __libc_memalign(align, n);
  counted(p);
  return p;
}
void* aligned_alloc(std::size_t align, std::size_t n) {
  return memalign(align, n);
}
int posix_memalign(void** out, std::size_t align, std::size_t n) {
  if (!powerOfTwo(align) || align % sizeof(void*) != 0) return EINVAL;
  void* p = memalign(align, n);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
void* valloc(std::size_t n) {
  return memalign(4096, n);
}
void* pvalloc(std::size_t n) {
  return memalign(4096, (n + 4095) & ~std::size_t(4095));
}
}

// ---------------------------------------------------------------------------------------------

namespace {

struct Counter {
  std::size_t calls = 0;
  template <typename S>
  static bool fn(fcl::CollisionObject<S>*, fcl::CollisionObject<S>*, void* data) {
    ++static_cast<Counter*>(data)->calls;
    return false;
  }
};

struct Result {
  std::string manager;
  std::size_t n = 0;
  double after = 0;  // bytes per object held after the build
  double peak = 0;   // bytes per object at the build's peak, over the heap before it
  std::size_t pairs = 0;
  double build_s = 0;                                 // construction, registerObjects and setup
  double self_s = 0;                                  // one self-collide with a counting callback
  std::vector<std::pair<std::string, double>> parts;  // cube only: bytes per object by component
};

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <typename S, class Make>
Result measure(const char* name, const std::vector<fcl::CollisionObject<S>*>& objs, Make&& make) {
  Result r;
  r.manager = name;
  r.n = objs.size();
  const double n = double(objs.size());
  const long long before = g_live.load();
  g_peak.store(before);
  auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<fcl::BroadPhaseCollisionManager<S>> mgr = make();
  mgr->registerObjects(objs);
  mgr->setup();
  r.build_s = since(t0);
  r.after = double(g_live.load() - before) / n;
  r.peak = double(g_peak.load() - before) / n;
  if (auto* cube = dynamic_cast<cube::CubeCollisionManager<S>*>(mgr.get())) {
    const auto& core = cube::detail::coreOf(*cube);
    const auto& tree = core.tree();
    r.parts = {
        {"bytes()", double(cube->bytes()) / n},
        {"table", double(core.table().bytes()) / n},
        {"pointer map", double(core.table().mapBytes()) / n},
        {"slots", double(tree.items().capacity() * sizeof(tree.items()[0])) / n},
        {"cubes", double(tree.nodes().capacity() * sizeof(cube::detail::Node)) / n},
        {"tree other", double(tree.bytes() - tree.items().capacity() * sizeof(tree.items()[0]) -
                              tree.nodes().capacity() * sizeof(cube::detail::Node)) /
                           n},
        {"slots per object", double(tree.items().capacity()) / n},
        {"cubes per object", double(tree.nodes().capacity()) / n}};
  }
  Counter c;
  t0 = std::chrono::steady_clock::now();
  mgr->collide(&c, &Counter::fn<S>);
  r.self_s = since(t0);
  r.pairs = c.calls;
  for (int rep = 1; rep < 3; ++rep) {
    mgr.reset();
    t0 = std::chrono::steady_clock::now();
    mgr = make();
    mgr->registerObjects(objs);
    mgr->setup();
    r.build_s = std::min(r.build_s, since(t0));
    Counter again;
    t0 = std::chrono::steady_clock::now();
    mgr->collide(&again, &Counter::fn<S>);
    r.self_s = std::min(r.self_s, since(t0));
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::size_t> sizes;
  std::string json;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--json") == 0 && i + 1 < argc)
      json = argv[++i];
    else
      sizes.push_back(std::strtoull(argv[i], nullptr, 10));
  }
  if (sizes.empty()) sizes = {10000, 100000, 1000000, 2000000};
  std::vector<Result> results;
  bool agree = true;
  for (const std::size_t n : sizes) {
    const std::size_t first = results.size();
    cube::scenes::SceneOptions o;
    o.n = n;
    {
      const auto scene = cube::scenes::makeScene<double>(o);
      const auto objs = scene.pointers();
      using S = double;
      results.push_back(measure<S>(
          "cube", objs, [] { return std::make_unique<cube::CubeCollisionManager<S>>(); }));
      results.push_back(measure<S>("DynamicAABBTree", objs, [] {
        return std::make_unique<fcl::DynamicAABBTreeCollisionManager<S>>();
      }));
      results.push_back(measure<S>("DynamicAABBTree_Array", objs, [] {
        return std::make_unique<fcl::DynamicAABBTreeCollisionManager_Array<S>>();
      }));
    }
    {
      // The same in float: what slots of float boxes (40 bytes) would make of a manager.
      const auto scene = cube::scenes::makeScene<float>(o);
      const auto objs = scene.pointers();
      using S = float;
      results.push_back(measure<S>(
          "cube_float", objs, [] { return std::make_unique<cube::CubeCollisionManager<S>>(); }));
      results.push_back(measure<S>("DynamicAABBTree_float", objs, [] {
        return std::make_unique<fcl::DynamicAABBTreeCollisionManager<S>>();
      }));
    }
    for (std::size_t i = first; i < results.size(); ++i) {
      const Result& r = results[i];
      // Each against FCL's dynamic tree of its scalar type.
      const bool same = r.pairs == results[i < first + 3 ? first + 1 : first + 4].pairs;
      agree = agree && same;
      std::printf(
          "%-22s n=%-8zu after %7.1f B/object  build peak %7.1f B/object  build %.4f s  "
          "self-collide %.4f s  pairs %zu%s\n",
          r.manager.c_str(), r.n, r.after, r.peak, r.build_s, r.self_s, r.pairs,
          same ? "" : "  (differs from DynamicAABBTree)");
      for (const auto& [part, v] : r.parts) std::printf("    %-18s %7.2f\n", part.c_str(), v);
    }
    std::fflush(stdout);
  }
  if (!json.empty()) {
    FILE* f = std::fopen(json.c_str(), "w");
    if (f == nullptr) {
      std::perror(json.c_str());
      return 2;
    }
    std::fprintf(f, "{\"scene\": \"uniform\", \"results\": [\n");
    for (std::size_t i = 0; i < results.size(); ++i) {
      const Result& r = results[i];
      std::fprintf(f,
                   "  {\"manager\": \"%s\", \"n\": %zu, \"bytes_per_object\": %.2f, "
                   "\"build_peak_per_object\": %.2f, \"build_s\": %.6f, \"self_s\": %.6f, "
                   "\"pairs\": %zu",
                   r.manager.c_str(), r.n, r.after, r.peak, r.build_s, r.self_s, r.pairs);
      if (!r.parts.empty()) {
        std::fprintf(f, ", \"parts\": {");
        for (std::size_t k = 0; k < r.parts.size(); ++k)
          std::fprintf(f, "%s\"%s\": %.3f", k ? ", " : "", r.parts[k].first.c_str(),
                       r.parts[k].second);
        std::fprintf(f, "}");
      }
      std::fprintf(f, "}%s\n", i + 1 < results.size() ? "," : "");
    }
    std::fprintf(f, "]}\n");
    std::fclose(f);
  }
  return agree ? 0 : 1;
}
