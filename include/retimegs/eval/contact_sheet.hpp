#pragma once
// A contact sheet of a scene: one row per camera; columns are frames, then the mask and a
// colour-coded flow (hue = direction, saturation = speed, black = unknown) from the first frame
// to the one `flow_stride` frames later: the flow training reads (stride 2 for --train-frames
// even, which is all prepare writes then).
// With render folders (eval --save-renders): per frame the ground truth, then each folder's
// DIR/<camera>/<frame:05d>.png beside it (no mask / flow columns) — ground truth vs renders.
// Each tile has a caption above it: camera, frame and what it shows ("ground truth", the render
// folder's name, "mask", "flow 0 to 1").
#include <filesystem>
#include <vector>

#include "retimegs/core/image.hpp"
#include "retimegs/io/scene.hpp"

namespace retimegs::eval {

struct SheetOptions {
  std::vector<int> cameras;  // indices; empty = up to 4 spread over the scene's cameras
  std::vector<int> frames;   // empty = first, middle and last frame
  int tile_width = 256;      // every tile is scaled to this width
  int gap = 4;               // pixels between tiles (white)
  std::vector<std::filesystem::path> renders;  // folders of renders to compare, in column order
  bool labels = true;                          // a caption strip above each tile
  // Frames from the first frame to its flow's other end; 0: the stride the default training
  // reads (--train-frames even: 2) when the camera has that flow, else the shortest it has.
  // Throws Error naming --stride when negative.
  int flow_stride = 0;
};

Image contact_sheet(const io::Scene& scene, const SheetOptions& options);

// Colour coding of a flow field: hue = direction, value = 1, saturation = |flow| / max_magnitude
// (the largest known magnitude when max_magnitude <= 0); unknown pixels are black.
Image flow_to_color(const Flow& flow, float max_magnitude = 0);

}  // namespace retimegs::eval
