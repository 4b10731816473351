// Flow-aware initialisation on a synthetic scene with exact flows: the 3-D motion lifted from the
// cameras' flows carries frame t_i's points onto frame t_{i+1}'s, and static ground stays put.
#include <cmath>

#include <gtest/gtest.h>

#include "retimegs/train/initialize.hpp"
#include "retimegs/train/neighbors.hpp"
#include "synth_scene.hpp"
#include "test_util.hpp"

namespace retimegs::train {
namespace {

TEST(Initialize, FlowMotionCarriesPointsToTheNextFrame) {
  test::TempDir dir;
  minimal_scene(dir / "scene", 6, 128, 96);
  const io::Scene scene = io::read_scene(dir / "scene");
  const TrainingSet set = load_training_set(scene, io::FrameSelection::kEven);  // frames 0, 2, 4
  const std::vector<PointMotion> motion = estimate_point_motion(set, 1);        // frame 2
  const io::PointCloud& here = *set.points[1];
  const io::PointCloud& next = *set.points[2];
  const PointIndex index(next.xyz);
  double moved_error = 0, still_error = 0, ground_motion = 0;
  int objects = 0, ground = 0;
  for (std::size_t k = 0; k < here.size(); ++k) {
    const Eigen::Vector3d x(here.xyz[3 * k], here.xyz[3 * k + 1], here.xyz[3 * k + 2]);
    if (!motion[k].forward_views || x.norm() > 8) continue;  // seen with a flow; not the sky
    if (x.y() > -0.01) {                                     // ground
      ground_motion += motion[k].forward.norm();
      ++ground;
      continue;
    }
    auto nearest = [&](const Eigen::Vector3d& p) {
      const float q[3] = {float(p.x()), float(p.y()), float(p.z())};
      std::uint32_t id;
      float d2;
      index.knn(q, 1, &id, &d2);
      return std::sqrt(double(d2));
    };
    moved_error += nearest(x + motion[k].forward);
    still_error += nearest(x);
    ++objects;
  }
  ASSERT_GT(objects, 200);
  ASSERT_GT(ground, 200);
  // Measured: 2.7 cm moved vs 8.7 cm unmoved (the points are ~2 cm apart).
  EXPECT_LT(moved_error / objects, 0.4 * still_error / objects)
      << "moved " << moved_error / objects << " still " << still_error / objects;
  EXPECT_LT(ground_motion / ground, 0.01);

  std::string note;
  const model::Primitives p = initialize(set, {}, note);
  EXPECT_NE(note.find("with flow-based motion"), std::string::npos) << note;
  // Two intervals, each seeded from both of its frames; windows of one interval each.
  ASSERT_GT(p.size(), 1000u);
  for (std::size_t i = 0; i < p.size(); ++i) {
    ASSERT_TRUE(p.mu_tau[i] == 1.0f || p.mu_tau[i] == 3.0f) << p.mu_tau[i];
    ASSERT_EQ(p.tau_l[i], 1.0f);
    ASSERT_EQ(p.velocity[9 * i], p.velocity[9 * i + 3]);  // v1 = v2 = v3 at initialisation
  }
}

TEST(Initialize, RandomFallbackWithoutPointsIsStated) {
  test::TempDir dir;
  minimal_scene(dir / "scene", 3, 48, 36);
  std::filesystem::remove_all(dir / "scene" / "points");
  const TrainingSet set =
      load_training_set(io::read_scene(dir / "scene"), io::FrameSelection::kEven);
  std::string note;
  InitOptions init;
  init.max_primitives = 5000;
  const model::Primitives p = initialize(set, init, note);
  EXPECT_NE(note.find("no points"), std::string::npos) << note;
  EXPECT_EQ(p.size(), 5000u);
  int seen = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_TRUE(p.mu_tau[i] == 1.0f || p.mu_tau[i] == 3.0f);
    const Eigen::Vector3d x(p.mu[3 * i], p.mu[3 * i + 1], p.mu[3 * i + 2]);
    const Camera& cam = set.scene.cameras[0];
    const Eigen::Vector3d xc = cam.world_to_cam(x);
    seen += xc.z() > 0 && cam.in_image(cam.project_cam(xc));
  }
  EXPECT_GT(seen, 1000) << "random points should fill the cameras' common view";
}

}  // namespace
}  // namespace retimegs::train
