// States that lie close together (an edge's, a planner's batch of neighbours) share one walk of
// the world in the batched checks: their answers against brute force, with every option, link
// kind and world rule, when all of the body's links move little and when some move far.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "core/kernels/pose_boxes.h"
#include "cube_collision/batch.h"
#include "queries/state_checker.h"
#include "support/batch_world.h"

namespace {

using namespace batchworld;

// Bundles of `per` states: a random body pose (centre within `spread` of the origin, links
// within 1.5 of it) drifting by up to `drift` along a random line over the bundle, each link
// also moved and turned by up to `near` from its place, or by up to `far` for the links from
// `far_from` on (those links walk state by state).
std::vector<fcl::Transform3d> bundles(std::size_t count, std::size_t per, std::size_t links,
                                      std::uint32_t seed, double spread, double drift, double near,
                                      double far = 0, std::size_t far_from = ~std::size_t(0)) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<fcl::Transform3d> poses;
  for (std::size_t b = 0; b < count; ++b) {
    const fcl::Vector3d centre = spread * fcl::Vector3d(u(rng), u(rng), u(rng));
    const fcl::Vector3d line = drift * fcl::Vector3d(u(rng), u(rng), u(rng)).normalized();
    std::vector<fcl::Transform3d> base;
    for (std::size_t l = 0; l < links; ++l) {
      fcl::Transform3d tf = randomPose(rng, 1.5);
      tf.translation() += centre;
      base.push_back(tf);
    }
    for (std::size_t k = 0; k < per; ++k)
      for (std::size_t l = 0; l < links; ++l) {
        const double t = double(k) / double(per);
        const double step = (l >= far_from ? far : near) * t;
        fcl::Transform3d tf = base[l];
        tf.translation() += t * line + step * fcl::Vector3d(u(rng), u(rng), u(rng));
        tf.linear() =
            tf.linear() *
            fcl::AngleAxisd(step * u(rng), fcl::Vector3d(u(rng), u(rng), u(rng) + 2).normalized())
                .toRotationMatrix();
        poses.push_back(tf);
      }
  }
  return poses;
}

class SharedWalkWorlds : public ::testing::TestWithParam<std::tuple<std::size_t, bool>> {};

TEST_P(SharedWalkWorlds, StatesCloseTogetherEqualBruteForce) {
  const auto [n, meshes] = GetParam();
  World w;
  fillWorld(w, n, 40 + std::uint32_t(n), meshes, n < 100);
  const cube::BodySet<S> body = randomBody(9, 6, meshes);
  // All links close together, then the links of the body's later leaves far apart.
  for (const double far : {0.0, 4.0}) {
    const auto poses = bundles(8, 16, body.size(), meshes ? 4 : 3, n < 100 ? 2 : 10, 1.5, 0.1, far,
                               far > 0 ? 4 : ~std::size_t(0));
    // (self-collision, first pair; clearance without it), on one thread and on three.
    for (const auto& [self, first, threads] :
         {std::tuple{false, false, 1}, std::tuple{true, true, 3}, std::tuple{true, false, 3}}) {
      cube::BatchOptions o;
      o.self_collision = self;
      o.first_pair = first;
      o.clearance = !first;
      o.threads = threads;
      std::size_t hits = 0;
      expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
      // The scene must exercise both answers.
      EXPECT_GT(hits, 2u);
      EXPECT_LT(hits, poses.size() / body.size() - 2);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(SharedWalk, SharedWalkWorlds,
                         ::testing::Combine(::testing::Values(std::size_t(60), std::size_t(400)),
                                            ::testing::Bool()));

TEST(SharedWalk, MarginsFilterBitsAndThePredicate) {
  World w;
  fillWorld(w, 300, 23, false, true);
  w.manager.setMargin(0.05);
  for (std::size_t i = 0; i < w.objects.size(); i += 3)
    w.manager.setMargin(w.objects[i].get(), 0.2);
  for (std::size_t i = 0; i < w.objects.size(); i += 4)
    w.manager.setFilter(w.objects[i].get(), 2, ~0ull);
  std::mt19937 rng(8);
  cube::BodySet<S> body;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> bits;
  for (std::size_t l = 0; l < 7; ++l) {
    const std::uint64_t mask = l % 2 ? ~std::uint64_t(2) : ~std::uint64_t(0);
    body.addLink(randomShape(rng, 1.0, false), l % 3 == 0 ? 0.3 : 0.0, 1, mask);
    bits.emplace_back(1, mask);
  }
  body.excludePair(0, 1);
  body.excludePair(2, 5);
  const auto poses = bundles(6, 30, body.size(), 9, 8, 1.5, 0.1);
  cube::BatchOptions o;
  o.self_collision = true;
  o.threads = 1;
  for (const bool first : {false, true}) {
    o.first_pair = first;
    o.clearance = !first;
    std::size_t hits = 0;
    expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits, nullptr,
               bits);
    EXPECT_GT(hits, 10u);
  }
  // With a pair predicate every state walks on its own: the same answers.
  const std::function<bool(Object*, Object*)> keep = [](Object* a, Object*) {
    return a->getTranslation()[0] >= 0;
  };
  w.manager.setPairFilter(keep);
  o.first_pair = true;
  o.clearance = false;
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, nullptr, keep, bits);
}

// Edges of small steps (a planner's resolution) in both orders: the serial scan's answer of
// brute force, for every thread count, from the array and from poses written on demand.
TEST(SharedWalk, EdgesOfSmallStepsGiveTheSerialScansAnswer) {
  World w;
  fillWorld(w, 100, 17, true, true);
  const cube::BodySet<S> body = randomBody(8, 12, true);
  const std::size_t per = 45;
  const auto poses = bundles(12, per, body.size(), 21, 12, 3, 0.3);
  std::vector<std::size_t> starts;
  for (std::size_t e = 0; e < 12; ++e) starts.push_back(e * per);
  cube::BatchOptions o;  // without self-collision: links placed at random overlap
  std::vector<bool> colliding;
  for (std::size_t k = 0; k < poses.size() / body.size(); ++k)
    colliding.push_back(brute(w, body, poses.data() + k * body.size(), false).colliding);
  std::size_t free_edges = 0;
  for (const auto order : {cube::MotionOrder::path, cube::MotionOrder::bisection})
    for (const int t : {1, 2, 8}) {
      o.threads = t;
      const auto first = cube::checkMotions(w.manager, body, poses, starts, order, o);
      free_edges = 0;
      for (std::size_t e = 0; e < starts.size(); ++e) {
        std::size_t want = cube::kNoIndex;
        for (const std::size_t i : visitOrder(per, order))
          if (colliding[starts[e] + i]) {
            want = i;
            break;
          }
        EXPECT_EQ(first[e], want) << "edge " << e;
        free_edges += want == cube::kNoIndex;
        const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
          std::copy_n(poses.begin() + long((starts[e] + k) * body.size()), body.size(), out);
        };
        EXPECT_EQ(cube::checkMotion(w.manager, body, per, pose_of, order, o), want);
      }
    }
  EXPECT_GT(free_edges, 1u);
  EXPECT_LT(free_edges, 11u);
}

// Long links that turn about their origin without moving it (their positions stay put, their
// ends sweep arcs), with margins: the states of a run checked on one shared walk, and edges of
// such turns, against brute force. Pairs apart in one state of a run meet in others.
TEST(SharedWalk, LinksTurningInPlaceGiveTheSerialScansAnswer) {
  World w;
  fillWorld(w, 120, 31, true, false);
  std::mt19937 rng(14);
  cube::BodySet<S> body;
  for (std::size_t l = 0; l < 6; ++l)
    body.addLink(
        l == 2 ? meshBox(5.0, 0.25, 0.25) : Geometry(std::make_shared<fcl::Boxd>(5.0, 0.2, 0.3)),
        l % 2 ? 0.05 : 0.0);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t per = 24, edges = 16;
  std::vector<fcl::Transform3d> poses;
  std::vector<std::size_t> starts;
  for (std::size_t e = 0; e < edges; ++e) {
    starts.push_back(e * per);
    std::vector<fcl::Transform3d> base;
    std::vector<fcl::Vector3d> axis;
    for (std::size_t l = 0; l < body.size(); ++l) {
      base.push_back(randomPose(rng, 8));
      const double x = u(rng), y = u(rng), z = u(rng);  // in this order on every compiler
      axis.push_back(fcl::Vector3d(x, y, z).normalized());
    }
    for (std::size_t k = 0; k < per; ++k)
      for (std::size_t l = 0; l < body.size(); ++l) {
        fcl::Transform3d tf = base[l];
        tf.linear() = tf.linear() * fcl::AngleAxisd(0.035 * double(k), axis[l]).toRotationMatrix();
        poses.push_back(tf);
      }
  }
  for (const bool self : {false, true}) {
    cube::BatchOptions o;
    o.self_collision = self;
    o.first_pair = self;
    o.threads = 1;
    std::size_t hits = 0;
    expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
    EXPECT_GT(hits, per);
    EXPECT_LT(hits, poses.size() / body.size() - per);
  }
  std::vector<bool> colliding;
  for (std::size_t k = 0; k < poses.size() / body.size(); ++k)
    colliding.push_back(brute(w, body, poses.data() + k * body.size(), false).colliding);
  cube::BatchOptions o;
  o.threads = 1;
  std::size_t free_edges = 0, late = 0;
  const auto first = cube::checkMotions(w.manager, body, poses, starts, cube::MotionOrder::path, o);
  for (std::size_t e = 0; e < edges; ++e) {
    std::size_t want = cube::kNoIndex;
    for (std::size_t i = 0; i < per && want == cube::kNoIndex; ++i)
      if (colliding[starts[e] + i]) want = i;
    EXPECT_EQ(first[e], want) << "edge " << e;
    free_edges += want == cube::kNoIndex;
    late += want != cube::kNoIndex && want > 5;
  }
  EXPECT_GT(free_edges, 1u) << late;
  EXPECT_GT(late, 0u) << free_edges;  // contacts that a run's later states meet
}

// The box a run's walk takes for a link holds the link's walked box in every state of the run:
// local AABBs off their origin, rotations that turn their diagonals onto the axes (the widest
// they reach), positions anywhere in the run's box, far from the origin too.
TEST(SharedWalk, SweptBoxHoldsTheWalkedBoxAtEveryPose) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1), size(0.01, 2);
  const double rate = 5e-6;
  std::size_t tight = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const double scale = trial % 4 == 3 ? 1e4 : 1;
    const fcl::Vector3d half(size(rng), size(rng), size(rng));
    // Half of the boxes lie off their origin along their diagonal: their farthest corner is
    // then as far as the bound allows.
    const fcl::Vector3d mid =
        trial % 2 ? fcl::Vector3d(u(rng), u(rng), u(rng)) : 0.5 * (u(rng) + 1) * half;
    const double margin = trial % 3 == 0 ? 0.1 : 0.0;
    const double reach = mid.norm() + half.norm();
    fcl::Vector3d lo = scale * fcl::Vector3d(u(rng), u(rng), u(rng)), hi = lo;
    hi += fcl::Vector3d(size(rng), size(rng), size(rng));
    const double far = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff());
    const cube::detail::Box<double> swept =
        cube::detail::sweptBox(lo, hi, far, reach, rate, margin);
    for (int k = 0; k < 20; ++k) {
      fcl::Transform3d pose = fcl::Transform3d::Identity();
      for (int d = 0; d < 3; ++d)
        pose.translation()[d] = lo[d] + 0.5 * (u(rng) + 1) * (hi[d] - lo[d]);
      if (k % 2 == 0) {
        // The farthest corner turned onto an axis, the origin on that side of the run's box.
        const int d = k / 2 % 3;
        const double sign = k % 4 ? 1 : -1;
        pose.linear() = fcl::Quaterniond::FromTwoVectors((mid + half).normalized(),
                                                         sign * fcl::Vector3d::Unit(d))
                            .toRotationMatrix();
        pose.translation()[d] = sign > 0 ? hi[d] : lo[d];
      } else {
        pose.linear() =
            fcl::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
      }
      double c[3][1], h[3][1], g[1], wl[3][1], wh[3][1];
      const double mids[3] = {mid[0], mid[1], mid[2]}, halves[3] = {half[0], half[1], half[2]};
      cube::detail::poseBoxes(pose.data(), 1,
                              cube::detail::PoseBoxes<double>{{&mids[0], &mids[1], &mids[2]},
                                                              {&halves[0], &halves[1], &halves[2]},
                                                              {c[0], c[1], c[2]},
                                                              {h[0], h[1], h[2]}});
      ASSERT_TRUE(
          cube::detail::walkBoxes(1, cube::detail::WalkBoxes<double>{{c[0], c[1], c[2]},
                                                                     {h[0], h[1], h[2]},
                                                                     &margin,
                                                                     rate,
                                                                     g,
                                                                     {wl[0], wl[1], wl[2]},
                                                                     {wh[0], wh[1], wh[2]}}));
      for (int d = 0; d < 3; ++d) {
        ASSERT_LE(swept.lo[d], wl[d][0]) << "trial " << trial << " pose " << k;
        ASSERT_GE(swept.hi[d], wh[d][0]) << "trial " << trial << " pose " << k;
        // Within a hundredth of the reach of the bound.
        tight += wh[d][0] > swept.hi[d] - 0.01 * reach || wl[d][0] < swept.lo[d] + 0.01 * reach;
      }
    }
  }
  // The turned poses of the boxes off their origin reach the bound.
  EXPECT_GT(tight, 1000u);
}

// The pose check: a NaN or an infinity anywhere in a state's poses (any length, any place) is
// seen by every version; finite poses pass.
TEST(SharedWalk, PoseSumCheckSeesEveryNonFiniteEntry) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1e3, 1e3);
  for (const std::size_t n : {1, 7, 16, 17, 33, 480, 481}) {
    std::vector<double> x(n);
    for (double& v : x) v = u(rng);
    EXPECT_TRUE(cube::detail::sumIsFinite(x.data(), n));
    EXPECT_TRUE(cube::detail::sumIsFinitePortable(x.data(), n));
    for (std::size_t at = 0; at < n; at += std::max<std::size_t>(1, n / 7))
      for (const double bad : {std::nan(""), HUGE_VAL, -HUGE_VAL}) {
        const double keep = x[at];
        x[at] = bad;
        EXPECT_FALSE(cube::detail::sumIsFinite(x.data(), n)) << n << " " << at;
        EXPECT_FALSE(cube::detail::sumIsFinitePortable(x.data(), n)) << n << " " << at;
        x[at] = keep;
      }
  }
}

// Each link's positions' box over a run: the kernels against the least and largest coordinate
// read one by one, and any non-finite translation seen (the rest of a pose is not read).
TEST(SharedWalk, PositionBoxesKernelsAgreeWithTheCoordinates) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-40, 40);
  for (const std::size_t count : {1, 2, 5, 32})
    for (const std::size_t n : {1, 4, 7}) {
      std::vector<std::vector<double>> states(count, std::vector<double>(16 * n));
      for (auto& s : states)
        for (double& x : s) x = u(rng);
      std::vector<const double*> at;
      for (const auto& s : states) at.push_back(s.data());
      for (const int bad : {0, 1, 2}) {  // none, a translation, another entry of a pose
        const double keep = states[count - 1][16 * (n - 1) + (bad == 1 ? 13 : 15)];
        if (bad != 0) states[count - 1][16 * (n - 1) + (bad == 1 ? 13 : 15)] = std::nan("");
        // The kernel on all objects, the portable version, the kernel on the last n - 1 and then
        // the first.
        std::vector<double> lo[3][3], hi[3][3];
        bool finite[3];
        for (int v = 0; v < 3; ++v) {
          double* l[3];
          double* h[3];
          for (int d = 0; d < 3; ++d) {
            lo[v][d].assign(n, 0);
            hi[v][d].assign(n, 0);
            l[d] = lo[v][d].data();
            h[d] = hi[v][d].data();
          }
          if (v == 0)
            finite[v] = cube::detail::positionBoxes(at.data(), count, 0, n, l, h);
          else if (v == 1)
            finite[v] = cube::detail::positionBoxesPortable(at.data(), count, 0, n, l, h);
          else
            finite[v] = cube::detail::positionBoxes(at.data(), count, 1, n - 1, l, h) &&
                        cube::detail::positionBoxes(at.data(), count, 0, 1, l, h);
        }
        for (int v = 0; v < 3; ++v) EXPECT_EQ(finite[v], bad != 1) << v;
        for (std::size_t k = 0; bad != 1 && k < n; ++k)
          for (int d = 0; d < 3; ++d) {
            double want_lo = states[0][16 * k + 12 + d], want_hi = want_lo;
            for (const auto& s : states) {
              want_lo = std::min(want_lo, s[16 * k + 12 + d]);
              want_hi = std::max(want_hi, s[16 * k + 12 + d]);
            }
            for (int v = 0; v < 3; ++v) {
              EXPECT_EQ(lo[v][d][k], want_lo);
              EXPECT_EQ(hi[v][d][k], want_hi);
            }
          }
        states[count - 1][16 * (n - 1) + (bad == 1 ? 13 : 15)] = keep;
      }
    }
}

TEST(SharedWalk, WalkBoxesKernelsAgreeBitForBit) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-50, 50), pos(0, 3), m(0, 0.5);
  for (const std::size_t n : {1, 3, 4, 5, 30, 33}) {
    std::vector<double> c[3], h[3], margin, grow[2], lo[2][3], hi[2][3];
    for (std::size_t k = 0; k < n; ++k) {
      for (int d = 0; d < 3; ++d) {
        c[d].push_back(u(rng));
        h[d].push_back(pos(rng));
      }
      margin.push_back(k % 2 ? m(rng) : 0.0);
    }
    for (int v = 0; v < 2; ++v) {
      grow[v].assign(n, 0);
      for (int d = 0; d < 3; ++d) {
        lo[v][d].assign(n, 0);
        hi[v][d].assign(n, 0);
      }
    }
    const auto io = [&](int v) {
      return cube::detail::WalkBoxes<double>{{c[0].data(), c[1].data(), c[2].data()},
                                             {h[0].data(), h[1].data(), h[2].data()},
                                             margin.data(),
                                             1e-6,
                                             grow[v].data(),
                                             {lo[v][0].data(), lo[v][1].data(), lo[v][2].data()},
                                             {hi[v][0].data(), hi[v][1].data(), hi[v][2].data()}};
    };
    EXPECT_TRUE(cube::detail::walkBoxes(n, io(0)));
    EXPECT_TRUE(cube::detail::walkBoxesPortable(n, io(1)));
    for (std::size_t k = 0; k < n; ++k) {
      const double reach = std::max({std::abs(c[0][k]), std::abs(c[1][k]), std::abs(c[2][k])}) +
                           std::max({h[0][k], h[1][k], h[2][k]});
      EXPECT_EQ(grow[0][k], grow[1][k]);
      EXPECT_EQ(grow[0][k], 1e-6 * (1 + reach));
      for (int d = 0; d < 3; ++d) {
        EXPECT_EQ(lo[0][d][k], lo[1][d][k]);
        EXPECT_EQ(hi[0][d][k], hi[1][d][k]);
        EXPECT_EQ(lo[0][d][k], c[d][k] - h[d][k] - (grow[0][k] + margin[k]));
        EXPECT_EQ(hi[0][d][k], c[d][k] + h[d][k] + (grow[0][k] + margin[k]));
      }
    }
    // A NaN or infinite entry anywhere is reported by every version.
    for (const double bad : {std::nan(""), HUGE_VAL}) {
      c[1][n / 2] = bad;
      EXPECT_FALSE(cube::detail::walkBoxes(n, io(0)));
      EXPECT_FALSE(cube::detail::walkBoxesPortable(n, io(1)));
      c[1][n / 2] = 0;
      h[2][n - 1] = bad;
      EXPECT_FALSE(cube::detail::walkBoxes(n, io(0)));
      EXPECT_FALSE(cube::detail::walkBoxesPortable(n, io(1)));
      h[2][n - 1] = 1;
    }
  }
}

}  // namespace
