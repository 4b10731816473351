#pragma once
// A small valid scene on disk, shared by the io and eval tests.
#include <filesystem>

#include "retimegs/core/camera.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/io/scene.hpp"
#include "retimegs/media/image_io.hpp"

namespace retimegs::test {

// A valid 2-camera, 3-frame scene with 12x8 images, masks for cam0 and one flow file.
inline io::Scene write_small_scene(const std::filesystem::path& root) {
  io::Scene scene;
  scene.root = root;
  scene.num_frames = 3;
  scene.fps = 12.5;
  scene.up = {0, 0, 1};
  for (int c = 0; c < 2; ++c) {
    Camera cam;
    cam.name = c == 0 ? "cam00" : "7";
    cam.width = 12, cam.height = 8;
    cam.fx = 10 + c, cam.fy = 11, cam.cx = 6, cam.cy = 4.25;
    cam.world_to_camera = look_at({3.0 * c - 1, -1, -4}, {0, 0, 0}, scene.up);
    cam.split = c == 0 ? Split::kTrain : Split::kTest;
    scene.cameras.push_back(cam);
  }
  for (int c = 0; c < 2; ++c)
    for (int k = 0; k < 3; ++k) {
      Image image(12, 8, 3);
      for (std::size_t i = 0; i < image.data.size(); ++i)
        image.data[i] = float((i * 7 + k) % 256) / 255;
      media::write_png(scene.image_path(c, k), image);
      if (c == 0) media::write_png(scene.mask_path(c, k), Image(12, 8, 1, 1.0f));
    }
  Flow flow(12, 8);
  flow.uv[0] = 1.5f;
  flow.valid[3] = 0;
  io::write_flo(scene.flow_path(0, 0, 1), flow);
  io::write_scene_json(scene);
  return scene;
}

}  // namespace retimegs::test
