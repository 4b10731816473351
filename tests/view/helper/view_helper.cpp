// The browser test's C++ side (web/test/viewer.test.mjs):
//   view_helper fixture DIR [N]  writes DIR/model.rgs (N primitives, default 4000) and
//                                DIR/scene/scene.json (view_fixture.hpp)
//   view_helper compare A B   prints "psnr P ssim S" of two images (core/psnr, core/ssim)
#include <cstdio>
#include <filesystem>
#include <string>

#include "../view_fixture.hpp"
#include "retimegs/core/error.hpp"
#include "retimegs/core/psnr.hpp"
#include "retimegs/core/ssim.hpp"
#include "retimegs/media/image_io.hpp"

int main(int argc, char** argv) {
  using namespace retimegs;
  try {
    const std::string command = argc > 1 ? argv[1] : "";
    if (command == "fixture" && (argc == 3 || argc == 4)) {
      const std::filesystem::path dir = argv[2];
      const std::size_t count = argc == 4 ? std::stoul(argv[3]) : 4000;
      std::filesystem::create_directories(dir / "scene");
      model::write_model(dir / "model.rgs", test::view_fixture_model(count, 7));
      io::write_scene_json(test::view_fixture_scene(dir / "scene"));
      return 0;
    }
    if (command == "compare" && argc == 4) {
      const Image a = media::read_image(argv[2]), b = media::read_image(argv[3]);
      std::printf("psnr %.3f ssim %.4f\n", psnr(a, b), ssim(a, b));
      return 0;
    }
    std::fprintf(stderr, "usage: view_helper fixture DIR [N] | compare A.png B.png\n");
  } catch (const Error& e) {
    std::fprintf(stderr, "view_helper: %s\n", e.what());
  }
  return 2;
}
