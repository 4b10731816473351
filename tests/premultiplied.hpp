#pragma once
// Straight RGBA (ModelRenderer::render_rgba) as the premultiplied colour and alpha it composites
// from: what two renders are compared by, since the straight colour divides rounding by alpha.
#include <vector>

#include "retimegs/core/image.hpp"

namespace retimegs::test {

inline std::vector<float> premultiplied(const Image& rgba) {
  std::vector<float> out(rgba.data.size());
  for (std::size_t i = 0; i < rgba.pixels(); ++i) {
    const float a = rgba.data[4 * i + 3];
    for (int c = 0; c < 3; ++c) out[4 * i + c] = a * rgba.data[4 * i + c];
    out[4 * i + 3] = a;
  }
  return out;
}

}  // namespace retimegs::test
