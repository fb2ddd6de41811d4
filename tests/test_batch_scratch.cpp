// BatchScratch (cube_collision/batch.h): the set-up a batched check keeps between calls. Calls
// with a kept scratch answer as brute force (FCL's narrow phase on every pair) and as calls
// without one, whatever changed in between (the world's objects, poses, rules and volumes, the
// body, which world or body, the scalar type, the thread count, a call that threw); a scratch
// serves one call at a time.

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/sphere.h>
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>

#include "cube_collision/batch.h"
#include "support/batch_world.h"

namespace {

using namespace batchworld;

// One state of `poses` (state k of body.size() links).
std::vector<fcl::Transform3d> stateOf(const std::vector<fcl::Transform3d>& poses, std::size_t k,
                                      std::size_t links) {
  return std::vector<fcl::Transform3d>(poses.begin() + long(k * links),
                                       poses.begin() + long((k + 1) * links));
}

// Each state alone through `scratch`, against brute force; the number colliding.
std::size_t statesOneByOne(const World& w, const cube::BodySet<S>& body,
                           const std::vector<fcl::Transform3d>& poses, cube::BatchOptions o,
                           cube::BatchScratch& scratch) {
  o.scratch = &scratch;
  std::size_t hits = 0;
  for (std::size_t k = 0; k < poses.size() / body.size(); ++k) {
    const auto one = stateOf(poses, k, body.size());
    std::size_t hit = 0;
    expectSame(cube::checkStates(w.manager, body, one, o), w, body, one, o, &hit);
    hits += hit;
  }
  return hits;
}

// Edges: the robot's rigid shape swept along straight lines across the world, 2 to 30 states
// (all of `states` states if given), each over a random length of up to 4.
struct Edges {
  std::vector<fcl::Transform3d> poses;
  std::vector<std::size_t> starts;
};
Edges sweptEdges(std::size_t links, std::size_t count, std::uint32_t seed, std::size_t states = 0) {
  std::mt19937 rng(seed);
  std::vector<fcl::Transform3d> shape;
  for (std::size_t l = 0; l < links; ++l) shape.push_back(randomPose(rng, 1.5));
  Edges out;
  for (std::size_t e = 0; e < count; ++e) {
    out.starts.push_back(out.poses.size() / links);
    const fcl::Vector3d from = randomPose(rng, 9).translation();
    const fcl::Vector3d to = from + randomPose(rng, 2).translation();
    const std::size_t n = states != 0 ? states : 2 + e * 7 % 29;
    for (std::size_t k = 0; k < n; ++k) {
      const double t = double(k) / double(n - 1);
      for (const auto& s : shape) {
        fcl::Transform3d tf = s;
        tf.translation() += from + t * (to - from);
        out.poses.push_back(tf);
      }
    }
  }
  return out;
}

TEST(BatchScratch, StatesCheckedOneByOneWithAKeptScratchEqualBruteForce) {
  for (const bool meshes : {false, true}) {
    World w;
    fillWorld(w, 400, 41, meshes, true);
    const cube::BodySet<S> body = randomBody(8, 43, meshes);
    const auto poses = randomStates(40, body.size(), 47);
    cube::BatchScratch scratch;
    for (const bool self : {false, true})
      for (const bool first : {false, true}) {
        cube::BatchOptions o;
        o.self_collision = self;
        o.first_pair = first;
        o.clearance = !first;
        o.threads = 1;
        const std::size_t hits = statesOneByOne(w, body, poses, o, scratch);
        EXPECT_GT(hits, 3u);
        EXPECT_LT(hits, 37u);
      }
  }
}

// A check for any contact walks first the groups of links that touched most often before
// (counted by the kept checker); a check for the first pair walks in link order whatever came
// before. A chain of 12 links (three groups of four): first its far links alone sit on world
// objects, state after state, then its near links alone, then none, then both; the other links
// lie beyond the world. Each state alone through one scratch, as brute force, for any contact
// and for the first pair.
TEST(BatchScratch, ChecksAfterContactsOfOtherLinksAnswerAsBruteForce) {
  World w;
  fillWorld(w, 300, 71, false, false);
  const cube::BodySet<S> body = randomBody(12, 72, false);
  const std::size_t n = body.size();
  std::mt19937 rng(73);
  std::uniform_int_distribution<std::size_t> pick(0, w.objects.size() - 1);
  std::vector<fcl::Transform3d> poses;
  const auto state = [&](bool near, bool far) {
    for (std::size_t l = 0; l < n; ++l) {
      fcl::Transform3d tf = randomPose(rng, 1);
      const bool on = (l < 4 && near) || (l >= 8 && far);
      // A shape holds its own centre: on an object's centre, a link meets that object.
      tf.translation() =
          on ? w.objects[pick(rng)]->getTranslation() : fcl::Vector3d(40.0 + 4.0 * double(l), 0, 0);
      poses.push_back(tf);
    }
  };
  for (int k = 0; k < 40; ++k) state(false, true);
  for (int k = 0; k < 20; ++k) state(true, false);
  for (int k = 0; k < 20; ++k) state(false, false);
  for (int k = 0; k < 20; ++k) state(true, true);
  cube::BatchScratch scratch;
  for (const bool first : {false, true, false}) {
    cube::BatchOptions o;
    o.first_pair = first;
    o.threads = 1;
    EXPECT_EQ(statesOneByOne(w, body, poses, o, scratch), 80u) << "first_pair " << first;
  }
}

// One scratch across two worlds, a world whose objects move, join, change rules and get a
// predicate, a body that grows and excludes a pair, and a world and a body made anew where the
// old ones were.
TEST(BatchScratch, AKeptScratchFollowsEveryChangeOfWorldAndBody) {
  cube::BatchScratch scratch;
  cube::BatchOptions o;
  o.self_collision = true;
  o.first_pair = true;
  o.threads = 1;
  auto a = std::make_unique<World>();
  auto b = std::make_unique<World>();
  fillWorld(*a, 300, 51, false, true);
  fillWorld(*b, 300, 52, true, false);
  auto body = std::make_unique<cube::BodySet<S>>(randomBody(6, 53, false));
  const auto poses = randomStates(12, 6, 54);
  for (int round = 0; round < 2; ++round) {
    statesOneByOne(*a, *body, poses, o, scratch);
    statesOneByOne(*b, *body, poses, o, scratch);
  }
  // Objects of a onto their neighbours' poses, then new objects, then a margin and filter bits.
  for (std::size_t i = 0; i + 1 < a->objects.size(); i += 4) {
    a->objects[i]->setTransform(a->objects[i + 1]->getTransform());
    a->objects[i]->computeAABB();
  }
  a->manager.update();
  SCOPED_TRACE("moved");
  statesOneByOne(*a, *body, poses, o, scratch);
  std::mt19937 rng(55);
  std::vector<Object*> added;
  for (int i = 0; i < 200; ++i) {
    a->objects.push_back(
        std::make_unique<Object>(randomShape(rng, 1.2, true), randomPose(rng, 10)));
    a->objects.back()->computeAABB();
    added.push_back(a->objects.back().get());
  }
  a->manager.registerObjects(added);
  SCOPED_TRACE("added");
  statesOneByOne(*a, *body, poses, o, scratch);
  a->manager.setMargin(a->objects[3].get(), 0.5);
  a->manager.setFilter(a->objects[5].get(), 2, ~std::uint64_t(0));
  // Links with category 1 and mask 1: object 5 (category 2) never meets them.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> bits(body->size(), {1, 1});
  cube::BodySet<S> masked;
  for (std::size_t l = 0; l < body->size(); ++l) masked.addLink(body->geometry(l), 0, 1, 1);
  for (std::size_t l = 0; l + 1 < body->size(); ++l) masked.excludePair(l, l + 1);
  o.scratch = &scratch;
  SCOPED_TRACE("bits");
  for (std::size_t k = 0; k < 12; ++k) {
    const auto one = stateOf(poses, k, 6);
    expectSame(cube::checkStates(a->manager, masked, one, o), *a, masked, one, o, nullptr, nullptr,
               bits);
  }
  // A predicate set, then cleared: every third world object meets no link.
  std::set<const Object*> dropped;
  for (std::size_t i = 0; i < a->objects.size(); i += 3) dropped.insert(a->objects[i].get());
  const std::function<bool(Object*, Object*)> keep = [&](Object* x, Object* y) {
    return dropped.count(x) == 0 && dropped.count(y) == 0;
  };
  a->manager.setPairFilter(keep);
  SCOPED_TRACE("predicate");
  for (std::size_t k = 0; k < 12; ++k) {
    const auto one = stateOf(poses, k, 6);
    expectSame(cube::checkStates(a->manager, *body, one, o), *a, *body, one, o, nullptr, keep);
  }
  a->manager.setPairFilter(nullptr);
  statesOneByOne(*a, *body, poses, o, scratch);
  // The body grows a link, then excludes a pair.
  std::mt19937 shapes(56);
  body->addLink(randomShape(shapes, 1.0, false));
  SCOPED_TRACE("grown");
  const auto seven = randomStates(12, 7, 57);
  statesOneByOne(*a, *body, seven, o, scratch);
  body->excludePair(0, 6);
  SCOPED_TRACE("excluded");
  statesOneByOne(*a, *body, seven, o, scratch);
  // A world and a body destroyed, new ones made (perhaps where they were).
  b.reset();
  body.reset();
  b = std::make_unique<World>();
  fillWorld(*b, 250, 58, false, false);
  body = std::make_unique<cube::BodySet<S>>(randomBody(5, 59, true));
  SCOPED_TRACE("new");
  statesOneByOne(*b, *body, randomStates(12, 5, 60), o, scratch);
  scratch.release();
  statesOneByOne(*b, *body, randomStates(12, 5, 61), o, scratch);
}

// Edges one per call, orders and forms in turn, so that a call meets what the last one left: an
// edge checked continuously in path order can stop with its runs' bounds kept for the interval
// before its last state, which a bisection of another edge of as many states reads first.
TEST(BatchScratch, EdgesCheckedOneByOneWithAKeptScratchAnswerAsWithout) {
  World w;
  fillWorld(w, 120, 61, false, false);
  const cube::BodySet<S> body = randomBody(5, 62, false);
  const std::size_t n = body.size();
  cube::BatchScratch scratch;
  std::size_t hit = 0, calls = 0;
  for (const std::size_t states : {std::size_t(0), std::size_t(14), std::size_t(22)}) {
    const Edges edges = sweptEdges(n, 60, 63 + std::uint32_t(states), states);
    for (std::size_t e = 0; e < edges.starts.size(); ++e) {
      const std::size_t from = edges.starts[e];
      const std::size_t to =
          e + 1 < edges.starts.size() ? edges.starts[e + 1] : edges.poses.size() / n;
      const std::vector<fcl::Transform3d> edge(edges.poses.begin() + long(from * n),
                                               edges.poses.begin() + long(to * n));
      const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
        std::copy(edge.begin() + long(k * n), edge.begin() + long((k + 1) * n), out);
      };
      cube::BatchOptions plain;  // the links of the swept shape overlap: no self pairs
      plain.threads = 1;
      plain.continuous = e % 4 != 3;
      cube::BatchOptions kept = plain;
      kept.scratch = &scratch;
      const auto order = e % 2 == 0 ? cube::MotionOrder::path : cube::MotionOrder::bisection;
      const std::size_t want = cube::checkMotion(w.manager, body, edge, order, plain);
      EXPECT_EQ(cube::checkMotion(w.manager, body, edge, order, kept), want) << "edge " << e;
      EXPECT_EQ(cube::checkMotion(w.manager, body, to - from, pose_of, order, kept), want)
          << "edge " << e;
      hit += want != cube::kNoIndex;
      ++calls;
    }
  }
  // Both answers occur.
  EXPECT_GT(hit, calls / 10);
  EXPECT_LT(hit, calls - calls / 10);
}

// The case the random edges above may miss: an edge checked continuously in path order stops in
// its second run, whose bounds it computed up to the interval before its last state; the next
// call, a bisection of another edge of as many states, reads that interval first. A sphere's
// edge A barely moves and meets a box at state 8; edge B stands still, then jumps 2 at its last
// state, whose raise (1) reaches a box 0.6 beyond it: only B's own bound finds that contact.
TEST(BatchScratch, AContinuousCallReadsNoBoundOfTheCallBefore) {
  fcl::CollisionObjectd box_a(std::make_shared<fcl::Boxd>(1, 1, 1), fcl::Transform3d::Identity());
  fcl::CollisionObjectd box_b(std::make_shared<fcl::Boxd>(1, 1, 1), fcl::Transform3d::Identity());
  box_a.setTranslation(fcl::Vector3d(0.5 + 0.0825 + 0.5, 0, 0));
  box_b.setTranslation(fcl::Vector3d(3.1 + 0.5, 100, 0));
  box_a.computeAABB();
  box_b.computeAABB();
  cube::CubeCollisionManagerd world;
  world.registerObjects({&box_a, &box_b});
  world.setup();
  cube::BodySet<S> body;
  body.addLink(std::make_shared<fcl::Sphered>(0.5));
  std::vector<fcl::Transform3d> a(14, fcl::Transform3d::Identity());
  std::vector<fcl::Transform3d> b(14, fcl::Transform3d::Identity());
  for (std::size_t k = 0; k < 14; ++k) {
    a[k].translation() = fcl::Vector3d(0.01 * double(k), 0, 0);
    b[k].translation() = fcl::Vector3d(k == 13 ? 2.0 : 0.0, 100, 0);
  }
  cube::BatchOptions o;
  o.threads = 1;
  o.continuous = true;
  const std::size_t want_a = cube::checkMotion(world, body, a, cube::MotionOrder::path, o);
  const std::size_t want_b = cube::checkMotion(world, body, b, cube::MotionOrder::bisection, o);
  ASSERT_EQ(want_a, 8u);
  ASSERT_EQ(want_b, 13u);
  cube::BatchScratch scratch;
  o.scratch = &scratch;
  for (int round = 0; round < 2; ++round) {
    EXPECT_EQ(cube::checkMotion(world, body, a, cube::MotionOrder::path, o), want_a);
    EXPECT_EQ(cube::checkMotion(world, body, b, cube::MotionOrder::bisection, o), want_b);
  }
}

TEST(BatchScratch, ThreadCountsWithAKeptScratchGiveTheSameAnswers) {
  World w;
  fillWorld(w, 400, 71, true, false);
  const cube::BodySet<S> body = randomBody(6, 72, true);
  const auto poses = randomStates(100, body.size(), 73);
  const Edges edges = sweptEdges(body.size(), 12, 74);
  cube::BatchOptions o;
  o.self_collision = true;
  o.first_pair = true;
  o.threads = 1;
  const auto states = cube::checkStates(w.manager, body, poses, o);
  const auto motions =
      cube::checkMotions(w.manager, body, edges.poses, edges.starts, cube::MotionOrder::path, o);
  cube::BatchScratch scratch;
  o.scratch = &scratch;
  for (const int t : {1, 2, 3, 8, 2, 1}) {
    o.threads = t;
    expectSameAnswers(cube::checkStates(w.manager, body, poses, o), states);
    EXPECT_EQ(
        cube::checkMotions(w.manager, body, edges.poses, edges.starts, cube::MotionOrder::path, o),
        motions);
  }
}

// A world of `objects` shapes (planes too with `planes`), a body of `links` links, `states`
// random states of it, and one-thread options that use one kept scratch.
struct KeptScene {
  World w;
  cube::BodySet<S> body;
  std::vector<fcl::Transform3d> poses;
  cube::BatchScratch scratch;
  cube::BatchOptions o;
  KeptScene(std::size_t objects, std::size_t links, std::size_t states, std::uint32_t seed,
            bool planes)
      : body(randomBody(links, seed + 1, false)), poses(randomStates(states, links, seed + 2)) {
    fillWorld(w, objects, seed, false, planes);
    o.threads = 1;
    o.scratch = &scratch;
  }
};

// A check from inside a call's pair predicate with the same scratch, and its release there,
// throw std::logic_error; the outer call goes on, and the scratch serves later calls.
TEST(BatchScratch, AScratchServesOneCallAtATime) {
  KeptScene k(200, 5, 10, 81, false);
  World& w = k.w;
  const cube::BodySet<S>& body = k.body;
  const auto& poses = k.poses;
  cube::BatchScratch& scratch = k.scratch;
  const cube::BatchOptions& o = k.o;
  int refused = 0, released = 0, other = 0, depth = 0;
  w.manager.setPairFilter([&](Object*, Object*) {
    if (depth > 0) return true;  // the inner calls' own pairs
    ++depth;
    try {
      cube::checkStates(w.manager, body, stateOf(poses, 0, body.size()), o);
    } catch (const std::logic_error& e) {
      refused += std::string(e.what()).find("BatchScratch") != std::string::npos;
    }
    try {
      scratch.release();
    } catch (const std::logic_error&) {
      ++released;
    }
    // Another scratch is free to serve a call from here.
    cube::BatchScratch mine;
    cube::BatchOptions inner = o;
    inner.scratch = &mine;
    other += int(cube::checkStates(w.manager, body, stateOf(poses, 1, body.size()), inner).size());
    --depth;
    return true;
  });
  for (std::size_t i = 0; i < 10; ++i)
    cube::checkStates(w.manager, body, stateOf(poses, i, body.size()), o);
  EXPECT_GT(refused, 0);
  EXPECT_EQ(released, refused);
  EXPECT_EQ(other, refused);
  w.manager.setPairFilter(nullptr);
  statesOneByOne(w, body, poses, o, scratch);
}

// A call that throws (a NaN pose) leaves the scratch as usable as a new one.
TEST(BatchScratch, ACallThatThrowsLeavesTheScratchUsable) {
  KeptScene k(300, 6, 20, 91, true);
  statesOneByOne(k.w, k.body, k.poses, k.o, k.scratch);
  auto bad = stateOf(k.poses, 3, k.body.size());
  bad[2].translation()[1] = std::nan("");
  EXPECT_THROW(cube::checkStates(k.w.manager, k.body, bad, k.o), std::invalid_argument);
  statesOneByOne(k.w, k.body, k.poses, k.o, k.scratch);
}

// One scratch for float and double calls in turn: each answers as a call without it.
TEST(BatchScratch, FloatAndDoubleCallsShareAScratch) {
  World w;
  fillWorld(w, 200, 101, false, false);
  const cube::BodySet<S> body = randomBody(4, 102, false);
  const auto poses = randomStates(20, body.size(), 103);
  // The float world: boxes where the double world's objects' AABBs are.
  std::vector<std::unique_ptr<fcl::CollisionObjectf>> boxes;
  for (const auto& obj : w.objects) {
    const fcl::AABBd& b = obj->getAABB();
    if (!b.min_.allFinite() || !b.max_.allFinite()) continue;
    const fcl::Vector3d side = b.max_ - b.min_;
    fcl::Transform3f tf = fcl::Transform3f::Identity();
    tf.translation() = b.center().cast<float>();
    boxes.push_back(std::make_unique<fcl::CollisionObjectf>(
        std::make_shared<fcl::Boxf>(side.cast<float>()), tf));
    boxes.back()->computeAABB();
  }
  cube::CubeCollisionManager<float> fworld;
  for (const auto& b : boxes) fworld.registerObject(b.get());
  fworld.setup();
  cube::BodySet<float> fbody;
  for (std::size_t l = 0; l < body.size(); ++l)
    fbody.addLink(std::make_shared<fcl::Boxf>(1.0f, 0.5f, 0.8f));
  std::vector<fcl::Transform3f> fposes;
  for (const auto& p : poses) fposes.push_back(p.cast<float>());
  cube::BatchOptions plain;
  plain.threads = 1;
  plain.first_pair = true;
  cube::BatchOptions kept = plain;
  cube::BatchScratch scratch;
  kept.scratch = &scratch;
  std::size_t fhits = 0;
  for (std::size_t k = 0; k < 20; ++k) {
    const auto one = stateOf(poses, k, body.size());
    expectSame(cube::checkStates(w.manager, body, one, kept), w, body, one, kept);
    const std::vector<fcl::Transform3f> fone(fposes.begin() + long(k * 4),
                                             fposes.begin() + long(k * 4 + 4));
    const auto want = cube::checkStates(fworld, fbody, fone, plain);
    expectSameAnswers(cube::checkStates(fworld, fbody, fone, kept), want);
    fhits += want[0].colliding;
  }
  EXPECT_GT(fhits, 0u);
  EXPECT_LT(fhits, 20u);
}

}  // namespace
