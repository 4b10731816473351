#pragma once
// Row moves of [rows, width] float arrays on the device, which the primitives and the optimiser
// share (cuda/primitives.hpp reorder and copy_rows, cuda/adam.hpp reorder). Launched on the
// default stream; `from` and `to` are device arrays of int32 row indices.
#include <cstddef>
#include <cstdint>

namespace retimegs::cuda {

// out row k = in row from[k], for k in [0, count); out holds count rows, in and out distinct.
void gather_rows(const float* in, float* out, int width, const std::int32_t* from,
                 std::size_t count);

// Row to[k] of values = its row from[k], for k in [0, count), in place: the to rows distinct and
// none of them a from row, so that the order of the copies does not matter.
void copy_rows(float* values, int width, const std::int32_t* to, const std::int32_t* from,
               std::size_t count);

}  // namespace retimegs::cuda
