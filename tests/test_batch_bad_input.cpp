// Bad input to the batched checks throws and changes nothing; a predicate that mutates the world
// is refused.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "cube_collision/batch.h"
#include "support/batch_world.h"

namespace {

using namespace batchworld;

TEST(Batch, BadInputChangesNothing) {
  World w;
  fillWorld(w, 50, 3, false, false);
  cube::BodySet<S> body = randomBody(3, 1, false);
  const auto poses = randomStates(4, 3, 1);
  EXPECT_THROW(body.addLink(nullptr), std::invalid_argument);
  EXPECT_THROW(body.addLink(std::make_shared<fcl::Planed>(fcl::Vector3d(0, 0, 1), 0)),
               std::invalid_argument);
  EXPECT_THROW(body.addLink(std::make_shared<fcl::Halfspaced>(fcl::Vector3d(0, 0, 1), 0)),
               std::invalid_argument);
  EXPECT_THROW(body.addLink(std::make_shared<fcl::Sphered>(1), -1.0), std::invalid_argument);
  EXPECT_THROW(body.addLink(std::make_shared<fcl::Sphered>(1), std::nan("")),
               std::invalid_argument);
  EXPECT_THROW(body.allowPair(0, 3), std::invalid_argument);
  EXPECT_THROW(body.allowPair(1, 1), std::invalid_argument);
  EXPECT_EQ(body.size(), 3u);
  EXPECT_TRUE(body.checked(0, 2));
  EXPECT_FALSE(body.checked(0, 1));
  auto wrong = poses;
  wrong.pop_back();
  EXPECT_THROW(cube::checkStates(w.manager, body, wrong), std::invalid_argument);
  for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
    auto nan = poses;
    nan[5].translation()[1] = bad;
    EXPECT_THROW(cube::checkStates(w.manager, body, nan), std::invalid_argument);
    nan = poses;
    nan[2].linear()(1, 2) = bad;
    EXPECT_THROW(cube::checkMotion(w.manager, body, nan), std::invalid_argument);
  }
  EXPECT_THROW(cube::checkStates(w.manager, cube::BodySet<S>(), poses), std::invalid_argument);
  EXPECT_THROW(cube::checkMotions(w.manager, body, poses, {1, 2}), std::invalid_argument);
  EXPECT_THROW(cube::checkMotions(w.manager, body, poses, {0, 2, 2}), std::invalid_argument);
  EXPECT_THROW(cube::checkMotions(w.manager, body, poses, {0, 4}), std::invalid_argument);
  // Motions: a bad pose throws where the serial scan meets it, before the first collision.
  {
    const auto more = randomStates(300, 3, 9);
    const auto r = cube::checkStates(w.manager, body, more);
    std::size_t hit = cube::kNoIndex, free_state = cube::kNoIndex;
    for (std::size_t k = 0; k < r.size(); ++k) (r[k].colliding ? hit : free_state) = k;
    ASSERT_NE(hit, cube::kNoIndex);
    ASSERT_NE(free_state, cube::kNoIndex);
    auto nan = more;
    nan[0].translation()[0] = std::nan("");
    std::vector<fcl::Transform3d> edge;
    for (const std::size_t k : {hit, std::size_t(0)})  // a collision, then the bad state
      edge.insert(edge.end(), (k == 0 ? nan : more).begin() + k * 3,
                  (k == 0 ? nan : more).begin() + k * 3 + 3);
    EXPECT_EQ(cube::checkMotion(w.manager, body, edge), 0u);
    edge.clear();
    for (const std::size_t k : {free_state, std::size_t(0)})  // free, then the bad state
      edge.insert(edge.end(), (k == 0 ? nan : more).begin() + k * 3,
                  (k == 0 ? nan : more).begin() + k * 3 + 3);
    EXPECT_THROW(cube::checkMotion(w.manager, body, edge), std::invalid_argument);
    EXPECT_THROW(cube::checkMotion(w.manager, body, 3, cube::PoseFunction<S>()),
                 std::invalid_argument);
    EXPECT_THROW(
        cube::checkMotion(w.manager, cube::BodySet<S>(), 3, [](std::size_t, fcl::Transform3d*) {}),
        std::invalid_argument);
  }
  // Poses written on demand: the same refusals; a NaN pose throws as from the array, and an
  // exception from the function is passed on, the lowest state's for checkStates.
  {
    const auto from = [&](const std::vector<fcl::Transform3d>& p) {
      return [&p](std::size_t k, fcl::Transform3d* out) {
        for (std::size_t l = 0; l < 3; ++l) out[l] = p[k * 3 + l];
      };
    };
    EXPECT_THROW(cube::checkStates<S>(w.manager, body, 4, cube::PoseFunction<S>()),
                 std::invalid_argument);
    EXPECT_THROW(cube::checkStates<S>(w.manager, cube::BodySet<S>(), 4, from(poses)),
                 std::invalid_argument);
    EXPECT_THROW(cube::checkMotions<S>(w.manager, body, 4, {0, 2}, cube::PoseFunction<S>()),
                 std::invalid_argument);
    EXPECT_THROW(cube::checkMotions<S>(w.manager, body, 4, {1, 2}, from(poses)),
                 std::invalid_argument);
    EXPECT_THROW(cube::checkMotions<S>(w.manager, body, 4, {}, from(poses)), std::invalid_argument);
    auto nan = poses;
    nan[7].translation()[2] = std::nan("");
    try {
      cube::checkStates<S>(w.manager, body, 4, from(nan));
      ADD_FAILURE() << "a NaN pose was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("pose 7 "), std::string::npos) << e.what();
    }
    const auto more = randomStates(200, 3, 4);
    for (const int t : {1, 2}) {
      cube::BatchOptions o;
      o.threads = t;
      try {
        cube::checkStates<S>(
            w.manager, body, 200,
            [&](std::size_t k, fcl::Transform3d* out) {
              if (k % 50 == 13) throw std::runtime_error("state " + std::to_string(k));
              for (std::size_t l = 0; l < 3; ++l) out[l] = more[k * 3 + l];
            },
            o);
        ADD_FAILURE() << "the function's exception was dropped";
      } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), "state 13");
      }
    }
    EXPECT_TRUE(cube::checkStates<S>(w.manager, body, 0, from(poses)).empty());
    EXPECT_TRUE(cube::checkMotions<S>(w.manager, body, 0, {}, from(poses)).empty());
  }
  // Still usable, same answers as before the errors.
  cube::BatchOptions o;
  o.first_pair = true;
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o);
  EXPECT_TRUE(cube::checkStates(w.manager, body, {}).empty());
  EXPECT_EQ(cube::checkMotion(w.manager, body, {}), cube::kNoIndex);
  // States with no edge belong to none: refused. No states and no edges: nothing to answer.
  EXPECT_THROW(cube::checkMotions(w.manager, body, poses, {}), std::invalid_argument);
  EXPECT_TRUE(cube::checkMotions(w.manager, body, {}, {}).empty());
}

TEST(Batch, APredicateThatMutatesTheWorldIsRefused) {
  World w;
  fillWorld(w, 300, 8, false, false);
  const cube::BodySet<S> body = randomBody(4, 2, false);
  const auto poses = randomStates(40, 4, 3);
  Object extra(std::make_shared<fcl::Sphered>(1));
  extra.computeAABB();
  w.manager.setPairFilter([&](Object*, Object*) {
    w.manager.registerObject(&extra);
    return true;
  });
  for (const int t : {1, 2}) {
    cube::BatchOptions o;
    o.threads = t;
    EXPECT_THROW(cube::checkStates(w.manager, body, poses, o), std::logic_error);
  }
  w.manager.setPairFilter(nullptr);
  EXPECT_EQ(w.manager.size(), 300u);
  std::string why;
  EXPECT_TRUE(w.manager.validate(&why)) << why;
}

}  // namespace
