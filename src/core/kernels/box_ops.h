#pragma once

// The per-box operations the tree and the walks are made of (overlap, gaps, unions, outward
// rounding), inlined where they are used. The instruction set is chosen here, once, at compile
// time: SSE2 is x86-64's baseline, so no run-time choice is needed. This file, its two
// implementations, the records' box gap (record_gap*.h) and the pair kernels (pair_kernels*.cpp)
// are the only places in the library with intrinsics or instruction-set conditionals.

#if defined(__SSE2__)
#include "core/kernels/box_ops_sse2.h"
#else
#include "core/kernels/box_ops_portable.h"
#endif

namespace cube {
namespace detail {

#if defined(__SSE2__)
namespace box_ops = sse2;
#else
namespace box_ops = portable;
#endif

using box_ops::boxGap2;
using box_ops::cubeGap2;
using box_ops::FixedBox;
using box_ops::floatBelow;
using box_ops::fourToColumns;
using box_ops::overlap;
using box_ops::roundOut;
using box_ops::sameBounds;
using box_ops::sameBox;
using box_ops::unionOfCubes;
using box_ops::unionOfItems;
using box_ops::unionOfRecords;

}  // namespace detail
}  // namespace cube
