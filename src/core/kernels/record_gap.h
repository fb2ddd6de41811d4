#pragma once

// recordBoxGap (record_gap_portable.h), with the instruction set chosen here at compile time, as
// box_ops.h chooses its own: the cull's separating-axis test on two records' boxes.

#if defined(__SSE2__)
#include "core/kernels/record_gap_sse2.h"
#else
#include "core/kernels/record_gap_portable.h"
#endif

namespace cube {
namespace detail {

#if defined(__SSE2__)
using sse2::recordBoxGap;
#else
using portable::recordBoxGap;
#endif

}  // namespace detail
}  // namespace cube
