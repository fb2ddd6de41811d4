#include "scenes.h"

#include <cmath>
#include <random>

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/geometric_shape_to_BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/math/bv/OBBRSS.h>

namespace cube {
namespace scenes {

double typicalSize(const SceneOptions& o) {
  // n AABBs of side a in a volume V overlap each other about n * (2a)^3 / V times... per object
  // the expected count is (n - 1) * a^3 / V for equal sides; solve for a.
  const double volume = std::pow(2 * o.half_extent, 3);
  const double n = std::max<double>(1, double(o.n));
  return o.size_scale * std::cbrt(o.overlaps_per_object * volume / n);
}

template <typename S>
std::vector<fcl::CollisionObject<S>*> Scene<S>::pointers() const {
  std::vector<fcl::CollisionObject<S>*> out;
  out.reserve(objects.size());
  for (const auto& o : objects) out.push_back(o.get());
  return out;
}

namespace {

template <typename S>
fcl::Matrix3<S> randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  fcl::Quaternion<S> q(S(g(rng)), S(g(rng)), S(g(rng)), S(g(rng)));
  q.normalize();
  return q.toRotationMatrix();
}

template <typename S>
std::shared_ptr<fcl::CollisionGeometry<S>> shape(int kind, double a, bool thin, bool mesh) {
  // Dimensions so that the AABB side is about `a` once rotated.
  const S s = S(a * 0.6);
  std::shared_ptr<fcl::CollisionGeometry<S>> g;
  if (thin) {
    const fcl::Box<S> box(s * 0.05, s * 0.05, S(a));
    if (!mesh) return std::make_shared<fcl::Box<S>>(box);
    auto m = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
    fcl::generateBVHModel(*m, box, fcl::Transform3<S>::Identity());
    return m;
  }
  switch (kind) {
    case 0: {
      const fcl::Box<S> box(s, s * 0.8, s * 0.6);
      if (!mesh) return std::make_shared<fcl::Box<S>>(box);
      auto m = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
      fcl::generateBVHModel(*m, box, fcl::Transform3<S>::Identity());
      return m;
    }
    case 1: {
      const fcl::Sphere<S> sphere(s * 0.5);
      if (!mesh) return std::make_shared<fcl::Sphere<S>>(sphere);
      auto m = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
      fcl::generateBVHModel(*m, sphere, fcl::Transform3<S>::Identity(), 8u, 8u);
      return m;
    }
    default: {
      const fcl::Cylinder<S> cyl(s * 0.4, s * 0.9);
      if (!mesh) return std::make_shared<fcl::Cylinder<S>>(cyl);
      auto m = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
      fcl::generateBVHModel(*m, cyl, fcl::Transform3<S>::Identity(), 8u, 2u);
      return m;
    }
  }
}

}  // namespace

template <typename S>
Scene<S> makeScene(const SceneOptions& o) {
  Scene<S> scene;
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> unit(-1, 1), size(0.5, 1.0);
  const double a = typicalSize(o);
  const bool thin = o.layout == Layout::thin;
  // Clusters: a few blob centres with a spread of a tenth of the world.
  std::vector<fcl::Vector3<S>> centres;
  for (int c = 0; c < 5; ++c)
    centres.emplace_back(S(unit(rng) * o.half_extent * 0.7), S(unit(rng) * o.half_extent * 0.7),
                         S(unit(rng) * o.half_extent * 0.7));
  std::normal_distribution<double> blob(0, o.half_extent * 0.1);
  // Geometries are shared between objects of the same kind and size class, as real scenes do.
  for (std::size_t i = 0; i < o.n; ++i) {
    fcl::Vector3<S> p;
    if (o.layout == Layout::clustered) {
      const auto& c = centres[i % centres.size()];
      p = c + fcl::Vector3<S>(S(blob(rng)), S(blob(rng)), S(blob(rng)));
    } else {
      p = fcl::Vector3<S>(S(unit(rng) * o.half_extent), S(unit(rng) * o.half_extent),
                          S(unit(rng) * o.half_extent));
    }
    const int kind = static_cast<int>(i % 3);
    auto geom = shape<S>(kind, a * size(rng), thin, o.meshes);
    fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
    tf.linear() = randomRotation<S>(rng);
    tf.translation() = p;
    auto obj = std::make_unique<fcl::CollisionObject<S>>(geom, tf);
    obj->computeAABB();
    scene.objects.push_back(std::move(obj));
  }
  return scene;
}

template <typename S>
std::vector<fcl::CollisionObject<S>*> jitter(Scene<S>& scene, double fraction, double step,
                                             bool rotate, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1, 1), pick(0, 1);
  std::vector<fcl::CollisionObject<S>*> moved;
  for (auto& o : scene.objects) {
    if (pick(rng) >= fraction) continue;
    fcl::Transform3<S> tf = o->getTransform();
    tf.translation() += fcl::Vector3<S>(S(unit(rng) * step), S(unit(rng) * step),
                                        S(unit(rng) * step));
    if (rotate) tf.linear() = randomRotation<S>(rng) * tf.linear();
    o->setTransform(tf);
    o->computeAABB();
    moved.push_back(o.get());
  }
  return moved;
}

template struct Scene<double>;
template struct Scene<float>;
template Scene<double> makeScene<double>(const SceneOptions&);
template Scene<float> makeScene<float>(const SceneOptions&);
template std::vector<fcl::CollisionObject<double>*> jitter(Scene<double>&, double, double, bool,
                                                           std::uint32_t);
template std::vector<fcl::CollisionObject<float>*> jitter(Scene<float>&, double, double, bool,
                                                          std::uint32_t);

}  // namespace scenes
}  // namespace cube
