#pragma once
// The `flow` in-betweening baseline of `retimegs eval`: a frame at fraction alpha of the way from
// frame a to frame b, interpolated from both by bidirectional optical flow with occlusion-aware
// blending — the frame interpolation algorithm of the Middlebury flow benchmark (Baker, Scharstein,
// Lewis, Roth, Black & Szeliski, "A Database and Evaluation Methodology for Optical Flow", IJCV
// 2011, §3.3), splatting from both frames:
//  1. Flow at time alpha by forward splatting: pixel p of a with flow f lands on the nearest pixel
//     of p + alpha f carrying f; pixel q of b with flow g lands on that of q + (1 - alpha) g
//     carrying -g. Where several land, a known flow beats an unknown one (occluded pixels carry
//     zero motion), then the larger motion wins (z-order by flow magnitude: with still cameras the
//     nearer, moving object is in front). Pixels nothing lands on take the mean of their filled
//     4-neighbours, ring by ring from the outside in.
//  2. With that flow u at pixel x: x_a = x - alpha u, x_b = x + (1 - alpha) u, both sampled
//     bilinearly. x is seen in a (V_a) when x_a is inside a and the pixel of b at x_b passes b's
//     forward-backward check (is not hidden in a); likewise V_b with the roles swapped.
//  3. Blend with weights (1 - alpha) V_a and alpha V_b; where neither sees x, the cross-fade
//     (1 - alpha) a(x) + alpha b(x).
#include "retimegs/core/image.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/prepare/flow_estimate.hpp"

namespace retimegs::eval {

// `flows` holds a -> b and b -> a, each with its forward-backward check applied (unknown pixels
// have valid = 0). alpha in [0, 1]; 0 gives a, 1 gives b. Throws Error when sizes disagree.
Image interpolate_flow(const Image& a, const Image& b, const prepare::FlowPair& flows,
                       double alpha);

// The flows between frames a and b of `camera`: the scene's flow files when both directions exist
// (checked again against each other, as imported flows may be raw; on flows `prepare` wrote this
// only widens the unknown regions by about a pixel), otherwise estimated from the images `image_a`
// and `image_b` with prepare's defaults (DIS, default consistency check).
prepare::FlowPair flow_pair(const io::Scene& scene, int camera, int a, int b, const Image& image_a,
                            const Image& image_b);

}  // namespace retimegs::eval
