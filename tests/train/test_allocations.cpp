// A training step in steady state allocates no large block: its renders, gradients, sliced
// batches and SSIM buffers are reused across steps. This test binary replaces the global
// operator new to count the blocks of kLarge bytes or more.
#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "retimegs/train/cpu_step.hpp"
#include "retimegs/train_run/load_training_set.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace {

constexpr std::size_t kLarge = std::size_t(1) << 20;
std::atomic<std::size_t> large_blocks{0};

void* allocate(std::size_t size, std::size_t alignment) {
  if (size >= kLarge) large_blocks.fetch_add(1, std::memory_order_relaxed);
  const std::size_t rounded =
      (std::max<std::size_t>(size, 1) + alignment - 1) / alignment * alignment;
  if (void* p = std::aligned_alloc(alignment, rounded)) return p;
  throw std::bad_alloc();
}

}  // namespace

void* operator new(std::size_t size) {
  return allocate(size, __STDCPP_DEFAULT_NEW_ALIGNMENT__);
}
void* operator new(std::size_t size, std::align_val_t alignment) {
  return allocate(size, std::max<std::size_t>(std::size_t(alignment), sizeof(void*)));
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}

namespace retimegs::train {
namespace {

// Triple rendering at an interior frame of 320x240 views: one RGB + flow render is 2.2 MB, so a
// step that allocated its buffers would allocate several large blocks. After a step on every
// camera (buffers at their largest), a further step allocates none.
TEST(Allocations, ASteadyStateStepAllocatesNoLargeBlock) {
  test::TempDir dir;
  const io::Scene scene = minimal_scene(dir / "scene", 3, 320, 240);
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);
  TrainConfig config;
  config.iters = 40;
  config.cap = 3000;
  CpuStep trainer(set, config);
  trainer.initialize();
  const int frame = 1;  // interior: triple rendering
  for (int c = 0; c < int(set.cameras.size()); ++c) trainer.step_view(c, frame);
  const std::size_t before = large_blocks.load();
  const StepStats s = trainer.step_view(0, frame);
  EXPECT_EQ(s.renders, 3);
  EXPECT_EQ(s.relocated + s.added + s.stretched + s.pruned, 0u);
  EXPECT_EQ(large_blocks.load() - before, 0u);
  // The counter sees the blocks it should: a fresh render's image is one.
  const Image image(320, 240, 7);
  EXPECT_EQ(large_blocks.load() - before, 1u) << image.data.size();
}

}  // namespace
}  // namespace retimegs::train
