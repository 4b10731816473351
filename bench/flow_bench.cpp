// Every optical-flow estimator `retimegs prepare --flow` offers, against the ground truth of the
// shared flow data (data/flow/README.md): mean end-point error, outlier share (KITTI's Fl: error
// above 3 px and above 5 % of the motion) and seconds per pair on one thread, the estimator run as
// prepare runs it (prepare::estimate_flow). Prints a Markdown table; bench/flow_estimators.sh
// writes it to bench/results/flow_estimators.md.
//
// Usage: flow_bench [FLOW_DATA_DIR]   (default: the shared data's flow/ folder)
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "retimegs/core/error.hpp"
#include "retimegs/io/flow_io.hpp"
#include "retimegs/media/image_io.hpp"
#include "retimegs/prepare/flow_estimate.hpp"

namespace fs = std::filesystem;
using namespace retimegs;

namespace {

// A pair of data/flow: its column title, its two frames, its ground truth and, for Sintel, the
// mask of pixels whose ground truth is invalid (data/flow/README.md: left out of the EPE).
struct Pair {
  const char* title;
  const char *first, *second, *truth, *invalid;
};

constexpr Pair kPairs[] = {
    {"RubberWhale", "middlebury-rubberwhale/frame10.png", "middlebury-rubberwhale/frame11.png",
     "middlebury-rubberwhale/flow10.flo", nullptr},
    {"Urban", "middlebury-urban/frame10.png", "middlebury-urban/frame11.png",
     "middlebury-urban/flow10.flo", nullptr},
    {"Sintel alley_1", "sintel-alley_1-clean/frame_0002.png", "sintel-alley_1-clean/frame_0003.png",
     "sintel-alley_1-clean/flow_0002.flo", "sintel-alley_1-clean/invalid_0002.png"},
    {"Chairs 0", "flyingchairs/0000000-img0.png", "flyingchairs/0000000-img1.png",
     "flyingchairs/0000000-gt.flo", nullptr},
    {"Chairs 4", "flyingchairs/0000004-img0.png", "flyingchairs/0000004-img1.png",
     "flyingchairs/0000004-gt.flo", nullptr},
};

struct Loaded {
  Image first, second;
  Flow truth;
  std::vector<unsigned char> valid;  // known ground truth, not flagged invalid
};

Loaded load(const fs::path& dir, const Pair& pair) {
  Loaded l{media::read_image(dir / pair.first),
           media::read_image(dir / pair.second),
           io::read_flo(dir / pair.truth),
           {}};
  l.valid = l.truth.valid;
  if (pair.invalid) {
    const Image invalid = media::read_mask(dir / pair.invalid);
    for (std::size_t i = 0; i < l.valid.size(); ++i) l.valid[i] &= invalid.data[i] < 0.5f;
  }
  return l;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const fs::path dir = argc > 1 ? fs::path(argv[1]) : fs::path(RETIMEGS_SHARED_DATA) / "flow";
    cv::setNumThreads(1);  // seconds per pair on one core, comparable between estimators
    std::vector<Loaded> pairs;
    for (const Pair& pair : kPairs) pairs.push_back(load(dir, pair));

    std::printf("| method |");
    for (const Pair& pair : kPairs) std::printf(" %s EPE (Fl %%) |", pair.title);
    std::printf(" mean EPE | mean Fl %% | s / pair |\n|---|");
    for (std::size_t k = 0; k < std::size(kPairs); ++k) std::printf("---|");
    std::printf("---|---|---|\n");
    for (const prepare::FlowMethod method : prepare::flow_methods()) {
      double epe = 0, outliers = 0, seconds = 0;
      std::printf("| `%s` |", prepare::flow_method_name(method));
      for (const Loaded& pair : pairs) {
        const auto start = std::chrono::steady_clock::now();
        const Flow flow = prepare::estimate_flow(pair.first, pair.second, method);
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const prepare::FlowErrors e = prepare::flow_errors(flow, pair.truth, pair.valid);
        std::printf(" %.3f (%.1f) |", e.epe, 100 * e.outliers);
        epe += e.epe, outliers += e.outliers;
      }
      const double n = double(pairs.size());
      std::printf(" %.3f | %.1f | %.2f |\n", epe / n, 100 * outliers / n, seconds / n);
      std::fflush(stdout);
    }
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "flow_bench: %s\n", e.what());
    return 2;
  }
}
