#pragma once

// What the per-pair Python hooks (CollisionManager._collide_python / _distance_python) hand to
// their callback: an object of a manager, or the query object. Shared with the benchmark module
// (python/benchmarks/fcl_way.cpp), whose python-fcl stand-ins read the FCL object behind it.

#include <fcl/narrowphase/collision_object.h>
#include <pybind11/pybind11.h>

#include <string>

namespace cubepy {

struct Handle {
  std::string name;            ///< the object's name, "__external" for the query object
  fcl::CollisionObjectd* obj;  ///< valid during the callback only
  pybind11::object geometry;   ///< the Geometry the object was added with (None: query)
};

}  // namespace cubepy
