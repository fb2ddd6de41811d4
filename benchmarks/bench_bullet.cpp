// bench_bullet: the cube manager against Bullet's broadphases (Debian's libbullet-dev, float) and
// FCL's dynamic AABB tree on the same boxes, in one run.
//
// Names are <case>/<scene>/<n>/<peer>, timed by hand (Google Benchmark's manual time). Cases:
// build (register every box and set up), self (one self-collide of the built scene), update_all,
// update_1pct and update_none (the boxes of all, 1% or none of the objects moved, the peer told,
// then a self-collide), queries (1,000 query boxes, each against the scene). Every peer reports
// each overlapping pair once to the same callback; before a case is timed its pairs (and its
// query hits) are checked against a brute force on the boxes: a mismatch of the cube manager's
// skips the case with an error and makes the binary exit with status 1; a peer's is reported (the
// `agree` and `missing` counters, and a line on stderr) and timed all the same.
//
// The boxes are the AABBs of cube_bench's uniform and clustered scenes with every coordinate on a
// grid of 2^-10, so that the same boxes are exact in float (Bullet) and double (cube, FCL):
// the pair sets are then equal by construction, not up to rounding. FCL's side holds axis-aligned
// fcl::Box objects whose AABBs are those boxes. Bullet's broadphases: btDbvtBroadphase (pairs
// kept in its pair cache between calls; with and without deferred collide), bt32BitAxisSweep3
// (sweep and prune, pairs kept; up to 10,000 objects, as its build is quadratic), and btDbvt trees
// used directly (built bottom-up, only up to 1,000 objects as that build is quadratic, or top-down;
// updated leaf by leaf, self-collided with collideTT). A peer that keeps pairs may report stale
// ones (Bullet removes them a few per call): its callback loop tests each pair's boxes, as a
// Bullet user's narrow phase would, and only overlapping pairs count.
// The cube_keep peer (self and update cases) is the cube manager with Config::keep_pairs, which
// keeps its overlapping pairs between calls as Bullet's pair caches do.
// The floor peer (self and update cases) is what no broadphase used through FCL's interface can
// skip: every object's AABB copied out of its FCL object and the callback called once per pair,
// the pairs found beforehand outside the timed region.

#include <BulletCollision/BroadphaseCollision/btAxisSweep3.h>
#include <BulletCollision/BroadphaseCollision/btDbvt.h>
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/CollisionDispatch/btCollisionDispatcher.h>
#include <BulletCollision/CollisionDispatch/btDefaultCollisionConfiguration.h>
#include <benchmark/benchmark.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Clock = std::chrono::steady_clock;
namespace scenes = cube::scenes;

bool g_failed = false;

// One box, float-exact (every coordinate a multiple of 2^-10).
struct Box {
  float lo[3], hi[3];
};

bool overlap(const Box& a, const Box& b) {
  for (int k = 0; k < 3; ++k)
    if (a.lo[k] > b.hi[k] || b.lo[k] > a.hi[k]) return false;
  return true;
}

constexpr double kGrid = 1024.0;
double onGrid(double x) {
  return std::round(x * kGrid) / kGrid;
}

// What every peer's callback does with a pair: counts it and mixes the two indices into a sum, so
// that the loop cannot be optimised away and two peers' pair sets can be told apart cheaply.
struct Sink {
  std::size_t pairs = 0;
  std::uint64_t sum = 0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>>* record = nullptr;
  /// A pair of the scene's objects, in either order.
  void operator()(std::uint32_t i, std::uint32_t j) {
    if (i > j) std::swap(i, j);
    hit(i, j);
  }
  /// Object j met query qi.
  void hit(std::uint32_t i, std::uint32_t j) {
    ++pairs;
    sum += (std::uint64_t(i) * 2654435761u) ^ (std::uint64_t(j) * 40503u + 1);
    if (record != nullptr) record->emplace_back(i, j);
  }
};

// The scene: its boxes at home, the frames of motion (all and 1% of the objects moved), and the
// query boxes.
struct World {
  std::string name;
  std::size_t n = 0;
  std::vector<Box> home;
  Box bounds;  // every box of every frame inside (bt32BitAxisSweep3's world)
  // A frame: the objects moved and their new boxes (home moved by up to one typical size).
  struct Frame {
    std::vector<std::uint32_t> idx;
    std::vector<Box> box;
  };
  std::vector<Frame> all, some;  // alternating with a return home: frames 2k are moves
  std::vector<Box> queries;
};

Box gridBox(const fcl::AABB<S>& a) {
  Box b;
  for (int k = 0; k < 3; ++k) {
    double lo = onGrid(a.min_[k]), hi = onGrid(a.max_[k]);
    if (hi <= lo) hi = lo + 1.0 / kGrid;
    b.lo[k] = float(lo);
    b.hi[k] = float(hi);
  }
  return b;
}

std::vector<Box> boxesOf(const scenes::SceneOptions& o) {
  const scenes::Scene<S> sc = scenes::makeScene<S>(o);
  std::vector<Box> out;
  out.reserve(sc.objects.size());
  for (const auto& obj : sc.objects) out.push_back(gridBox(obj->getAABB()));
  return out;
}

constexpr int kFrames = 8;

World::Frame frameOf(const std::vector<Box>& home, const std::vector<std::uint32_t>& idx,
                     double step, std::mt19937& rng) {
  std::uniform_real_distribution<double> off(-1, 1);
  World::Frame f;
  f.idx = idx;
  for (std::uint32_t i : idx) {
    Box b = home[i];
    for (int k = 0; k < 3; ++k) {
      const double d = onGrid(off(rng) * step);
      b.lo[k] = float(double(b.lo[k]) + d);
      b.hi[k] = float(double(b.hi[k]) + d);
    }
    f.box.push_back(b);
  }
  return f;
}

World makeWorld(const std::string& layout, std::size_t n) {
  World w;
  w.name = layout;
  w.n = n;
  scenes::SceneOptions o;
  o.n = n;
  o.layout = layout == "clustered" ? scenes::Layout::clustered : scenes::Layout::uniform;
  w.home = boxesOf(o);
  scenes::SceneOptions q = o;
  q.n = 1000;
  q.seed = 2;
  q.size_scale = std::cbrt(1000.0 / double(n));
  w.queries = boxesOf(q);
  const double step = scenes::typicalSize(o);
  std::mt19937 rng(7);
  std::vector<std::uint32_t> every(n);
  for (std::uint32_t i = 0; i < n; ++i) every[i] = i;
  std::vector<std::uint32_t> perm = every;
  std::shuffle(perm.begin(), perm.end(), rng);
  const std::size_t per = std::max<std::size_t>(1, n / 100);
  for (int f = 0; f < kFrames; ++f) {
    w.all.push_back(frameOf(w.home, every, step, rng));
    const std::vector<std::uint32_t> idx(perm.begin() + std::ptrdiff_t((f * per) % n),
                                         perm.begin() + std::ptrdiff_t((f * per) % n + per));
    w.some.push_back(frameOf(w.home, idx, step, rng));
  }
  // Every frame but the first starts from the previous one; each returns its objects home first
  // (the peers are told of both moves, as one update).
  Box bb{{1e30f, 1e30f, 1e30f}, {-1e30f, -1e30f, -1e30f}};
  auto grow = [&](const Box& b) {
    for (int k = 0; k < 3; ++k) {
      bb.lo[k] = std::min(bb.lo[k], b.lo[k]);
      bb.hi[k] = std::max(bb.hi[k], b.hi[k]);
    }
  };
  for (const Box& b : w.home) grow(b);
  for (const auto* frames : {&w.all, &w.some})
    for (const auto& f : *frames)
      for (const Box& b : f.box) grow(b);
  for (const Box& b : w.queries) grow(b);
  for (int k = 0; k < 3; ++k) {
    bb.lo[k] -= 1;
    bb.hi[k] += 1;
  }
  w.bounds = bb;
  return w;
}

// ---------------------------------------------------------------------------------------------
// Peers: one interface over the cube manager, FCL's dynamic tree and Bullet's five.

class Peer {
 public:
  virtual ~Peer() = default;
  /// Registers every box at `boxes` and sets up.
  virtual void build(const std::vector<Box>& boxes) = 0;
  /// Tells the peer that the objects `idx` are now at `boxes` (`all`: every object moved).
  virtual void update(const std::vector<std::uint32_t>& idx, const std::vector<Box>& boxes,
                      bool all) = 0;
  /// Every overlapping pair once, to the sink.
  virtual void self(Sink& sink) = 0;
  /// Every object overlapping `q` (query number qi), to the sink as (qi, object).
  virtual void query(const Box& q, std::uint32_t qi, Sink& sink) = 0;
  /// Whether update() needs the FCL objects moved first (outside the timed region).
  virtual bool movesFclObjects() const { return false; }
  /// Told the boxes as they are now, outside the timed region, before each update or self.
  virtual void prepare(const std::vector<Box>&) {}
};

// The FCL side: axis-aligned fcl::Box objects whose AABBs are the boxes.
struct FclObjects {
  std::vector<std::unique_ptr<Object>> objs;
  std::vector<Object*> ptrs;
  void make(const std::vector<Box>& boxes) {
    objs.clear();
    ptrs.clear();
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const Box& b = boxes[i];
      auto geom = std::make_shared<fcl::Box<S>>(
          double(b.hi[0]) - b.lo[0], double(b.hi[1]) - b.lo[1], double(b.hi[2]) - b.lo[2]);
      objs.push_back(std::make_unique<Object>(geom));
      ptrs.push_back(objs.back().get());
      place(i, b);
    }
  }
  void place(std::size_t i, const Box& b) {
    Object* o = ptrs[i];
    o->setTranslation(fcl::Vector3<S>((double(b.lo[0]) + b.hi[0]) / 2,
                                      (double(b.lo[1]) + b.hi[1]) / 2,
                                      (double(b.lo[2]) + b.hi[2]) / 2));
    o->computeAABB();
  }
  std::uint32_t indexOf(const Object* o) const {
    return std::uint32_t(reinterpret_cast<std::uintptr_t>(o->getUserData()));
  }
};

template <class Manager>
class FclPeer final : public Peer {
 public:
  explicit FclPeer(FclObjects& fcl, std::function<std::unique_ptr<Manager>()> make = nullptr)
      : fcl_(fcl), make_(std::move(make)) {}
  void build(const std::vector<Box>&) override {
    mgr_ = make_ ? make_() : std::make_unique<Manager>();
    mgr_->registerObjects(fcl_.ptrs);
    mgr_->setup();
  }
  // Told as FCL's interface tells a manager: update() when every object moved, else
  // update(the moved objects), an empty list when none did (as Bullet's peers are told nothing).
  void update(const std::vector<std::uint32_t>& idx, const std::vector<Box>&, bool all) override {
    if (all) {
      mgr_->update();
      return;
    }
    moved_.clear();
    for (std::uint32_t i : idx) moved_.push_back(fcl_.ptrs[i]);
    mgr_->update(moved_);
  }
  void self(Sink& sink) override { mgr_->collide(&sink, &FclPeer::pair); }
  void query(const Box&, std::uint32_t qi, Sink& sink) override {
    QuerySink q{&sink, qi};
    mgr_->collide(query_objs_->ptrs[qi], &q, &FclPeer::hit);
  }
  bool movesFclObjects() const override { return true; }
  void useQueries(FclObjects* q) { query_objs_ = q; }

 private:
  struct QuerySink {
    Sink* sink;
    std::uint32_t qi;
  };
  static bool pair(Object* a, Object* b, void* d) {
    Sink& s = *static_cast<Sink*>(d);
    s(std::uint32_t(reinterpret_cast<std::uintptr_t>(a->getUserData())),
      std::uint32_t(reinterpret_cast<std::uintptr_t>(b->getUserData())));
    return false;
  }
  static bool hit(Object* a, Object* b, void* d) {
    auto& q = *static_cast<QuerySink*>(d);
    // The query object is not registered: the other one is the scene's.
    const Object* scene_obj =
        a->getUserData() == reinterpret_cast<void*>(~std::uintptr_t(0)) ? b : a;
    q.sink->hit(q.qi, std::uint32_t(reinterpret_cast<std::uintptr_t>(scene_obj->getUserData())));
    return false;
  }
  FclObjects& fcl_;
  std::function<std::unique_ptr<Manager>()> make_;  // null: default-constructed
  FclObjects* query_objs_ = nullptr;
  std::unique_ptr<Manager> mgr_;
  std::vector<Object*> moved_;
};

btVector3 lo3(const Box& b) {
  return btVector3(b.lo[0], b.lo[1], b.lo[2]);
}
btVector3 hi3(const Box& b) {
  return btVector3(b.hi[0], b.hi[1], b.hi[2]);
}

Box boxOf(const btVector3& lo, const btVector3& hi) {
  return Box{{lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()}};
}

// A Bullet broadphase interface (btDbvtBroadphase, bt32BitAxisSweep3): proxies per object, the
// pair cache read after calculateOverlappingPairs.
class BulletBroadphasePeer final : public Peer {
 public:
  enum class Kind { dbvt, dbvt_deferred, sap32 };
  BulletBroadphasePeer(Kind kind, const Box& bounds) : kind_(kind), bounds_(bounds) {}
  ~BulletBroadphasePeer() override { release(); }
  BulletBroadphasePeer(const BulletBroadphasePeer&) = delete;
  BulletBroadphasePeer& operator=(const BulletBroadphasePeer&) = delete;
  void build(const std::vector<Box>& boxes) override {
    release();
    if (kind_ == Kind::sap32) {
      bp_ = std::make_unique<bt32BitAxisSweep3>(lo3(bounds_), hi3(bounds_),
                                                unsigned(boxes.size() + 16));
    } else {
      auto dbvt = std::make_unique<btDbvtBroadphase>();
      dbvt->m_deferedcollide = kind_ == Kind::dbvt_deferred;
      bp_ = std::move(dbvt);
    }
    proxies_.reserve(boxes.size());
    for (std::size_t i = 0; i < boxes.size(); ++i)
      proxies_.push_back(bp_->createProxy(lo3(boxes[i]), hi3(boxes[i]), 0,
                                          reinterpret_cast<void*>(std::uintptr_t(i)), 1, -1,
                                          &dispatcher_));
    bp_->calculateOverlappingPairs(&dispatcher_);
  }
  void update(const std::vector<std::uint32_t>& idx, const std::vector<Box>& boxes, bool) override {
    for (std::size_t k = 0; k < idx.size(); ++k)
      bp_->setAabb(proxies_[idx[k]], lo3(boxes[k]), hi3(boxes[k]), &dispatcher_);
  }
  void self(Sink& sink) override {
    bp_->calculateOverlappingPairs(&dispatcher_);
    btOverlappingPairCache* cache = bp_->getOverlappingPairCache();
    const int n = cache->getNumOverlappingPairs();
    btBroadphasePair* pairs = cache->getOverlappingPairArrayPtr();
    for (int k = 0; k < n; ++k) {
      const btBroadphaseProxy* a = pairs[k].m_pProxy0;
      const btBroadphaseProxy* b = pairs[k].m_pProxy1;
      // Bullet keeps pairs whose boxes no longer meet for a few calls: the exact test.
      if (!overlap(boxOf(a->m_aabbMin, a->m_aabbMax), boxOf(b->m_aabbMin, b->m_aabbMax))) continue;
      sink(std::uint32_t(reinterpret_cast<std::uintptr_t>(a->m_clientObject)),
           std::uint32_t(reinterpret_cast<std::uintptr_t>(b->m_clientObject)));
    }
  }
  void query(const Box& q, std::uint32_t qi, Sink& sink) override {
    struct Hits final : btBroadphaseAabbCallback {
      Box q;
      std::uint32_t qi;
      Sink* sink;
      bool process(const btBroadphaseProxy* p) override {
        if (overlap(q, boxOf(p->m_aabbMin, p->m_aabbMax)))
          sink->hit(qi, std::uint32_t(reinterpret_cast<std::uintptr_t>(p->m_clientObject)));
        return true;
      }
    } hits;
    hits.q = q;
    hits.qi = qi;
    hits.sink = &sink;
    bp_->aabbTest(lo3(q), hi3(q), hits);
  }

 private:
  // Frees the broadphase and its proxies. Bullet's destroyProxy removes a proxy's pairs by a scan
  // of the whole pair cache (quadratic over a scene); the broadphase's destructor frees its trees
  // and pair cache but not the proxies it allocated (for the sweep: its ray accelerator's), which
  // are freed here after it.
  void release() {
    std::vector<void*> memory;
    for (btBroadphaseProxy* p : proxies_)
      memory.push_back(
          kind_ == Kind::sap32
              ? static_cast<void*>(static_cast<bt32BitAxisSweep3::Handle*>(p)->m_dbvtProxy)
              : static_cast<void*>(p));
    bp_.reset();
    for (void* m : memory)
      if (m != nullptr) btAlignedFree(m);
    proxies_.clear();
  }

  Kind kind_;
  Box bounds_;
  btDefaultCollisionConfiguration config_;
  btCollisionDispatcher dispatcher_{&config_};
  std::unique_ptr<btBroadphaseInterface> bp_;
  std::vector<btBroadphaseProxy*> proxies_;
};

// A btDbvt used directly: leaves of exact boxes, built bottom-up or top-down, updated leaf by
// leaf, self-collided with collideTT.
class BulletTreePeer final : public Peer {
 public:
  explicit BulletTreePeer(bool bottom_up) : bottom_up_(bottom_up) {}
  void build(const std::vector<Box>& boxes) override {
    tree_ = std::make_unique<btDbvt>();
    leaves_.clear();
    leaves_.reserve(boxes.size());
    for (std::size_t i = 0; i < boxes.size(); ++i)
      leaves_.push_back(tree_->insert(btDbvtVolume::FromMM(lo3(boxes[i]), hi3(boxes[i])),
                                      reinterpret_cast<void*>(std::uintptr_t(i))));
    if (bottom_up_)
      tree_->optimizeBottomUp();
    else
      tree_->optimizeTopDown();
  }
  void update(const std::vector<std::uint32_t>& idx, const std::vector<Box>& boxes, bool) override {
    for (std::size_t k = 0; k < idx.size(); ++k) {
      btDbvtVolume v = btDbvtVolume::FromMM(lo3(boxes[k]), hi3(boxes[k]));
      tree_->update(leaves_[idx[k]], v);
    }
  }
  void self(Sink& sink) override {
    struct Pairs final : btDbvt::ICollide {
      Sink* sink;
      void Process(const btDbvtNode* a, const btDbvtNode* b) override {
        (*sink)(std::uint32_t(reinterpret_cast<std::uintptr_t>(a->data)),
                std::uint32_t(reinterpret_cast<std::uintptr_t>(b->data)));
      }
    } pairs;
    pairs.sink = &sink;
    tree_->collideTT(tree_->m_root, tree_->m_root, pairs);
  }
  void query(const Box& q, std::uint32_t qi, Sink& sink) override {
    struct Hits final : btDbvt::ICollide {
      Sink* sink;
      std::uint32_t qi;
      void Process(const btDbvtNode* n) override {
        sink->hit(qi, std::uint32_t(reinterpret_cast<std::uintptr_t>(n->data)));
      }
    } hits;
    hits.sink = &sink;
    hits.qi = qi;
    tree_->collideTV(tree_->m_root, btDbvtVolume::FromMM(lo3(q), hi3(q)), hits);
  }

 private:
  bool bottom_up_;
  std::unique_ptr<btDbvt> tree_;
  std::vector<btDbvtNode*> leaves_;
};

// The floor: what no broadphase used through FCL's interface can skip, with the pairs known in
// advance (found outside the timed region, in prepare): each object's AABB read out of its FCL
// object once (copied), and the user's callback called once per overlapping pair, through a
// function pointer as FCL's interface calls it. Self-collide and the update cases only.
std::vector<std::pair<std::uint32_t, std::uint32_t>> selfPairsOf(const std::vector<Box>& b);

class FloorPeer final : public Peer {
 public:
  explicit FloorPeer(FclObjects& fcl) : fcl_(fcl) {}
  void build(const std::vector<Box>& boxes) override { prepare(boxes); }
  void prepare(const std::vector<Box>& boxes) override { pairs_ = selfPairsOf(boxes); }
  void update(const std::vector<std::uint32_t>&, const std::vector<Box>&, bool) override {}
  void self(Sink& sink) override {
    const std::size_t n = fcl_.ptrs.size();
    copies_.resize(n);
    for (std::size_t i = 0; i < n; ++i) copies_[i] = fcl_.ptrs[i]->getAABB();
    benchmark::DoNotOptimize(copies_.data());
    benchmark::ClobberMemory();
    bool (*volatile call)(Object*, Object*, void*) = &FloorPeer::pair;
    for (const auto& [i, j] : pairs_)
      if (call(fcl_.ptrs[i], fcl_.ptrs[j], &sink)) return;
  }
  void query(const Box&, std::uint32_t, Sink&) override {}
  bool movesFclObjects() const override { return true; }

 private:
  static bool pair(Object* a, Object* b, void* d) {
    Sink& s = *static_cast<Sink*>(d);
    s(std::uint32_t(reinterpret_cast<std::uintptr_t>(a->getUserData())),
      std::uint32_t(reinterpret_cast<std::uintptr_t>(b->getUserData())));
    return false;
  }
  FclObjects& fcl_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs_;
  std::vector<fcl::AABB<S>> copies_;
};

// ---------------------------------------------------------------------------------------------
// The harness

const char* const kPeers[] = {
    "cube",         "fcl_dyntree",      "bt_dbvt_bp",      "bt_dbvt_bp_deferred",
    "bt_32bit_sap", "bt_dbvt_bottomup", "bt_dbvt_topdown", "cube_keep",
    "floor"};
constexpr int kNumPeers = 9;
constexpr int kCubeKeep = 7;
constexpr int kFloor = 8;

// The scene in use and its FCL objects, one at a time (cases are registered scene by scene).
struct Current {
  std::string key;
  World world;
  FclObjects fcl, queries;
  std::vector<Box> boxes;  // where each object is now
};
std::unique_ptr<Current> g_cur;

Current& current(const std::string& layout, std::size_t n) {
  const std::string key = layout + "/" + std::to_string(n);
  if (!g_cur || g_cur->key != key) {
    g_cur.reset();
    auto c = std::make_unique<Current>();
    c->key = key;
    c->world = makeWorld(layout, n);
    c->fcl.make(c->world.home);
    for (std::size_t i = 0; i < n; ++i)
      c->fcl.ptrs[i]->setUserData(reinterpret_cast<void*>(std::uintptr_t(i)));
    c->queries.make(c->world.queries);
    for (Object* o : c->queries.ptrs) o->setUserData(reinterpret_cast<void*>(~std::uintptr_t(0)));
    c->boxes = c->world.home;
    g_cur = std::move(c);
  }
  return *g_cur;
}

// Puts every object home (boxes and FCL objects).
void goHome(Current& c) {
  for (std::size_t i = 0; i < c.world.n; ++i) c.fcl.place(i, c.world.home[i]);
  c.boxes = c.world.home;
}

std::unique_ptr<Peer> makePeer(int p, Current& c) {
  switch (p) {
    case 0: {
      auto peer = std::make_unique<FclPeer<cube::CubeCollisionManager<S>>>(c.fcl);
      peer->useQueries(&c.queries);
      return peer;
    }
    case 1: {
      auto peer = std::make_unique<FclPeer<fcl::DynamicAABBTreeCollisionManager<S>>>(c.fcl);
      peer->useQueries(&c.queries);
      return peer;
    }
    case 2:
      return std::make_unique<BulletBroadphasePeer>(BulletBroadphasePeer::Kind::dbvt,
                                                    c.world.bounds);
    case 3:
      return std::make_unique<BulletBroadphasePeer>(BulletBroadphasePeer::Kind::dbvt_deferred,
                                                    c.world.bounds);
    case 4:
      return std::make_unique<BulletBroadphasePeer>(BulletBroadphasePeer::Kind::sap32,
                                                    c.world.bounds);
    case 5:
      return std::make_unique<BulletTreePeer>(true);
    case 6:
      return std::make_unique<BulletTreePeer>(false);
    case kCubeKeep:
      // The cube manager for "move a few, collide again" loops: the pairs kept between calls.
      return std::make_unique<FclPeer<cube::CubeCollisionManager<S>>>(c.fcl, [] {
        cube::Config config;
        config.keep_pairs = true;
        return std::make_unique<cube::CubeCollisionManager<S>>(config);
      });
    default:
      return std::make_unique<FloorPeer>(c.fcl);
  }
}

enum class Case { build, self, update_all, update_1pct, update_none, queries };
const char* const kCases[] = {"build",       "self",        "update_all",
                              "update_1pct", "update_none", "queries"};

double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

// Frame f of the case's motion as one update: the objects of frame f-1 go home and those of
// frame f move (the same object in both: its frame-f box).
struct Step {
  std::vector<std::uint32_t> idx;
  std::vector<Box> box;
};

Step stepOf(const World& w, Case c, int f) {
  Step s;
  if (c == Case::update_none) return s;
  const auto& frames = c == Case::update_all ? w.all : w.some;
  const World::Frame& now = frames[std::size_t(f) % frames.size()];
  if (c == Case::update_all) {
    s.idx = now.idx;
    s.box = now.box;
    return s;
  }
  const World::Frame& before = frames[std::size_t(f + kFrames - 1) % frames.size()];
  std::vector<int> where(w.n, -1);
  for (std::size_t k = 0; k < now.idx.size(); ++k) where[now.idx[k]] = int(k);
  for (std::size_t k = 0; k < before.idx.size(); ++k)
    if (where[before.idx[k]] < 0) {
      s.idx.push_back(before.idx[k]);
      s.box.push_back(w.home[before.idx[k]]);
    }
  s.idx.insert(s.idx.end(), now.idx.begin(), now.idx.end());
  s.box.insert(s.box.end(), now.box.begin(), now.box.end());
  return s;
}

// Moves the boxes (and, for peers on FCL objects, the objects) of a step.
void apply(Current& c, const Step& s, bool fcl_objects) {
  for (std::size_t k = 0; k < s.idx.size(); ++k) {
    c.boxes[s.idx[k]] = s.box[k];
    if (fcl_objects) c.fcl.place(s.idx[k], s.box[k]);
  }
}

using PairSet = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

PairSet sorted(PairSet v) {
  std::sort(v.begin(), v.end());
  return v;
}

// The reference, by brute force on the boxes: a sweep along x (boxes sorted by their lower x,
// each tested against the following ones until their lower x passes its upper x), every pair
// tested on all three axes. Query hits: each query against every box.
PairSet selfPairsOf(const std::vector<Box>& b);

PairSet reference(const Current& c, Case cs) {
  PairSet out;
  const std::vector<Box>& b = c.boxes;
  if (cs == Case::queries) {
    for (std::uint32_t q = 0; q < c.world.queries.size(); ++q)
      for (std::uint32_t i = 0; i < b.size(); ++i)
        if (overlap(c.world.queries[q], b[i])) out.emplace_back(q, i);
    return sorted(out);
  }
  return selfPairsOf(b);
}

PairSet selfPairsOf(const std::vector<Box>& b) {
  PairSet out;
  std::vector<std::uint32_t> order(b.size());
  for (std::uint32_t i = 0; i < b.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t x, std::uint32_t y) { return b[x].lo[0] < b[y].lo[0]; });
  for (std::size_t k = 0; k < order.size(); ++k)
    for (std::size_t m = k + 1; m < order.size() && b[order[m]].lo[0] <= b[order[k]].hi[0]; ++m)
      if (overlap(b[order[k]], b[order[m]]))
        out.emplace_back(std::min(order[k], order[m]), std::max(order[k], order[m]));
  return sorted(out);
}

void run(benchmark::State& state, Case cs, const std::string& layout, std::size_t n, int p) {
  Current& c = current(layout, n);
  goHome(c);
  std::unique_ptr<Peer> peer = makePeer(p, c);
  const bool moves_fcl = peer->movesFclObjects();
  // Correctness, outside the timing: the peer's pairs after its build, and after two steps of
  // the case's motion, equal the brute force on the same boxes.
  {
    peer->build(c.boxes);
    PairSet got;
    Sink s;
    s.record = &got;
    if (cs == Case::queries) {
      for (std::uint32_t q = 0; q < c.world.queries.size(); ++q)
        peer->query(c.world.queries[q], q, s);
    } else {
      for (int f = 0; f < 2 && cs != Case::build && cs != Case::self; ++f) {
        const Step st = stepOf(c.world, cs, f);
        apply(c, st, true);
        peer->prepare(c.boxes);
        peer->update(st.idx, st.box, cs == Case::update_all);
      }
      peer->self(s);
    }
    const PairSet want = reference(c, cs);
    got = sorted(got);
    PairSet missing, extra;
    std::set_difference(want.begin(), want.end(), got.begin(), got.end(),
                        std::back_inserter(missing));
    std::set_difference(got.begin(), got.end(), want.begin(), want.end(),
                        std::back_inserter(extra));
    // The cube manager must agree; a peer's disagreement is reported, not ours to fail on.
    state.counters["agree"] = missing.empty() && extra.empty() ? 1 : 0;
    if (!missing.empty() || !extra.empty()) {
      std::fprintf(stderr, "%s/%s/%zu/%s: %zu pairs missing, %zu extra (of %zu)\n", kCases[int(cs)],
                   layout.c_str(), n, kPeers[p], missing.size(), extra.size(), want.size());
      state.counters["missing"] = double(missing.size());
      if (p == 0) {
        state.SkipWithError("the cube manager's pairs differ from the brute force's");
        g_failed = true;
        goHome(c);
        return;
      }
    }
    goHome(c);
  }
  std::size_t pairs = 0;
  int f = 0;
  switch (cs) {
    case Case::build:
      for (auto _ : state) {
        auto fresh = makePeer(p, c);
        const auto t0 = Clock::now();
        fresh->build(c.boxes);
        state.SetIterationTime(seconds(Clock::now() - t0));
      }
      break;
    case Case::self:
      peer = makePeer(p, c);
      peer->build(c.boxes);
      for (auto _ : state) {
        Sink s;
        const auto t0 = Clock::now();
        peer->self(s);
        state.SetIterationTime(seconds(Clock::now() - t0));
        pairs = s.pairs;
        benchmark::DoNotOptimize(s.sum);
      }
      break;
    case Case::queries:
      peer = makePeer(p, c);
      peer->build(c.boxes);
      for (auto _ : state) {
        Sink s;
        const auto t0 = Clock::now();
        for (std::uint32_t q = 0; q < c.world.queries.size(); ++q)
          peer->query(c.world.queries[q], q, s);
        state.SetIterationTime(seconds(Clock::now() - t0));
        pairs = s.pairs;
        benchmark::DoNotOptimize(s.sum);
      }
      break;
    default:
      peer = makePeer(p, c);
      peer->build(c.boxes);
      for (auto _ : state) {
        const Step st = stepOf(c.world, cs, f++);
        apply(c, st, moves_fcl);
        peer->prepare(c.boxes);
        Sink s;
        const auto t0 = Clock::now();
        peer->update(st.idx, st.box, cs == Case::update_all);
        peer->self(s);
        state.SetIterationTime(seconds(Clock::now() - t0));
        pairs = s.pairs;
        benchmark::DoNotOptimize(s.sum);
      }
      goHome(c);
      break;
  }
  state.counters["pairs"] = double(pairs);
}

}  // namespace

int main(int argc, char** argv) {
  const char* const layouts[] = {"uniform", "clustered"};
  const std::size_t sizes[] = {1000, 10000, 100000};
  for (const char* layout : layouts)
    for (std::size_t n : sizes)
      for (int ci = 0; ci < 6; ++ci)
        for (int p = 0; p < kNumPeers; ++p) {
          // btDbvt's bottom-up build is quadratic in the leaves (1,000 take about a second):
          // beyond that Bullet itself builds top-down.
          if (p == 5 && n > 1000) continue;
          // The sweep's proxies are inserted one by one into sorted edge lists, each insertion a
          // walk along them: quadratic too, minutes at 100,000 objects.
          if (p == 4 && n > 10000) continue;
          // The floor has no build or queries of its own to time; the cube manager keeping its
          // pairs builds and answers queries as the plain one does.
          if ((p == kFloor || p == kCubeKeep) &&
              (Case(ci) == Case::build || Case(ci) == Case::queries))
            continue;
          const std::string name =
              std::string(kCases[ci]) + "/" + layout + "/" + std::to_string(n) + "/" + kPeers[p];
          benchmark::RegisterBenchmark(
              name.c_str(), [=](benchmark::State& st) { run(st, Case(ci), layout, n, p); })
              ->UseManualTime()
              ->Unit(benchmark::kMicrosecond);
        }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (g_failed)
    std::fprintf(stderr, "bench_bullet: the cube manager's pairs differ from the brute force's\n");
  return g_failed ? 1 : 0;
}
