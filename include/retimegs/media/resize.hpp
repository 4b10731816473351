#pragma once
// Images and flows at another size (import --downscale, train --downscale), by area averaging:
// each output pixel is the mean over the input pixels it covers (OpenCV's INTER_AREA).
#include "retimegs/core/image.hpp"

namespace retimegs::media {

// Area-averaged resize of any number of channels (identity when the size already matches).
Image resize_area(const Image& image, int width, int height);

// A flow at another size: its vectors scaled by width / flow.width and height / flow.height (a
// motion measured in the new pixels), each pixel the mean over its known input pixels. A pixel
// less than half covered by known input pixels is unknown. Identity when the size matches.
Flow resize_flow(const Flow& flow, int width, int height);

}  // namespace retimegs::media
