// The browser test's C++ side (web/test/viewer.test.mjs):
//   view_helper fixture DIR [N]  writes DIR/model.rgs (N primitives, default 4000) and
//                                DIR/scene/scene.json (view_fixture.hpp)
//   view_helper merged DIR       writes DIR/merged.rgs (view_fixture_merged_model, 4000)
//   view_helper compare A B [C W]  prints "psnr P ssim S" of image A against image B, or against
//                                the mix W B + (1 - W) C (core/psnr, core/ssim)
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
    if (command == "merged" && argc == 3) {
      model::write_model(std::filesystem::path(argv[2]) / "merged.rgs",
                         test::view_fixture_merged_model(4000, 7));
      return 0;
    }
    if (command == "compare" && (argc == 4 || argc == 6)) {
      const Image a = media::read_image(argv[2]);
      Image b = media::read_image(argv[3]);
      if (argc == 6) {
        const Image c = media::read_image(argv[4]);
        const float w = std::stof(argv[5]);
        if (c.width != b.width || c.height != b.height || c.channels != b.channels)
          fail("compare: {} is {}x{}x{} but {} is {}x{}x{}", argv[3], b.width, b.height, b.channels,
               argv[4], c.width, c.height, c.channels);
        for (std::size_t k = 0; k < b.data.size(); ++k)
          b.data[k] = w * b.data[k] + (1 - w) * c.data[k];
      }
      std::printf("psnr %.3f ssim %.4f\n", psnr(a, b), ssim(a, b));
      return 0;
    }
    std::fprintf(stderr,
                 "usage: view_helper fixture DIR [N] | merged DIR | compare A.png B.png "
                 "[C.png W]\n");
  } catch (const Error& e) {
    std::fprintf(stderr, "view_helper: %s\n", e.what());
  }
  return 2;
}
