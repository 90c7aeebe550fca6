#include "direct_sim/viewer.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include <opencv2/imgcodecs.hpp>

#include "common/scene/patient_scene.h"
#include "common/scene/robot_driver.h"
#include "tests/scene/scene_test_util.h"

namespace nsim {
namespace {

bool IsNeedleColor(const cv::Vec3b& px) {
  const cv::Scalar c = NeedleColor();
  return px[0] == c[0] && px[1] == c[1] && px[2] == c[2];
}

struct ViewRig {
  DirectScenario s = testing::LoadCoarseScenario();
  std::unique_ptr<PatientScene> scene;
  ViewRig() {
    const RigidNeedleModel needle(s.scene.needle.geometry());
    const InsertionPlan plan = MakeInsertionPlan(s.scene.entry_W, s.scene.target_W, needle, 0.01);
    scene =
        std::make_unique<PatientScene>(s.scene, s.liver_mesh, s.skin_mesh, plan.CalcFlangePose(0));
  }
};

TEST(ViewerTest, ProjectionOfThePerspectiveCamera) {
  ViewerConfig config;
  config.eye = Eigen::Vector3d(0, 0, 1);
  config.look_at = Eigen::Vector3d::Zero();
  config.up = Eigen::Vector3d::UnitY();
  config.fov_deg = 90;
  config.width = config.height = 200;
  const SceneRenderer renderer(config);
  double depth = 0;
  // the look-at point is the image centre; y up in the world is up (smaller row) in the image
  EXPECT_TRUE(
      renderer.Project(Eigen::Vector3d::Zero(), &depth).isApprox(Eigen::Vector2d(100, 100)));
  EXPECT_DOUBLE_EQ(depth, 1.0);
  // 90 deg vertical fov: a point at 45 deg above the axis is on the top edge
  EXPECT_TRUE(renderer.Project(Eigen::Vector3d(0, 1, 0)).isApprox(Eigen::Vector2d(100, 0), 1e-12));
  EXPECT_TRUE(
      renderer.Project(Eigen::Vector3d(0.5, 0, 0)).isApprox(Eigen::Vector2d(150, 100), 1e-12));
}

TEST(ViewerTest, RenderedFrameShowsTheSceneAndTheNeedleWhereItProjects) {
  ViewRig rig;
  const SceneRenderer renderer(rig.s.view);
  const cv::Mat image = renderer.Render(*rig.scene, "test");
  ASSERT_EQ(image.cols, rig.s.view.width);
  ASSERT_EQ(image.rows, rig.s.view.height);
  // the needle's pixels lie on its projected segment
  const Eigen::Matrix3Xd needle = rig.scene->CalcNeedlePolyline();
  const Eigen::Vector2d a = renderer.Project(needle.col(0)), b = renderer.Project(needle.col(1));
  int on = 0, samples = 0;
  for (double u = 0.1; u <= 0.9; u += 0.05, ++samples) {
    const Eigen::Vector2d p = a + u * (b - a);
    const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
    if (x >= 0 && y >= 0 && x < image.cols && y < image.rows &&
        IsNeedleColor(image.at<cv::Vec3b>(y, x)))
      ++on;
  }
  EXPECT_GE(on, samples - 1) << "needle pixels on its projection: " << on << " of " << samples;
  // and nowhere else: every needle-coloured pixel is within 3 px of the segment
  int needle_pixels = 0, off = 0;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      if (!IsNeedleColor(image.at<cv::Vec3b>(y, x))) continue;
      ++needle_pixels;
      const Eigen::Vector2d p(x, y), ab = b - a;
      const double u = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      if ((a + u * ab - p).norm() > 3.0) ++off;
    }
  EXPECT_GT(needle_pixels, 20);
  EXPECT_EQ(off, 0);
  // the liver fills a good part of the view (its shaded red), the background the rest
  int liver_like = 0;
  for (int y = 0; y < image.rows; y += 4)
    for (int x = 0; x < image.cols; x += 4) {
      const cv::Vec3b px = image.at<cv::Vec3b>(y, x);
      if (px[2] > px[1] + 30 && px[2] > px[0] + 30) ++liver_like;
    }
  EXPECT_GT(liver_like, (image.rows / 4) * (image.cols / 4) / 20);
  // the target marker is drawn at the target's projection
  const Eigen::Vector2d t = renderer.Project(rig.scene->CalcTargetPosition());
  const cv::Vec3b target_px = image.at<cv::Vec3b>(static_cast<int>(std::lround(t.y())),
                                                  static_cast<int>(std::lround(t.x())));
  EXPECT_EQ(target_px, cv::Vec3b(255, 0, 255));
}

TEST(ViewerTest, WritesAVideoAndThePngWithoutADisplay) {
  ViewRig rig;
  const std::string dir = std::string(NSIM_BINARY_DIR) + "/viewer_test_out";
  std::filesystem::create_directories(dir);
  std::filesystem::remove(dir + "/view.avi");
  std::filesystem::remove(dir + "/view.png");
  {
    SceneViewer viewer(rig.s.view, dir + "/view.avi");
    if (viewer.has_window()) GTEST_SKIP() << "a display exists: the live window is used";
    const SceneRenderer renderer(rig.s.view);
    for (int k = 0; k < 3; ++k) viewer.Add(renderer.Render(*rig.scene, "frame"));
    viewer.Finish(dir + "/view.png");
    EXPECT_EQ(viewer.frames(), 3);
  }
  EXPECT_GT(std::filesystem::file_size(dir + "/view.avi"), 1000u);
  const cv::Mat png = cv::imread(dir + "/view.png");
  EXPECT_EQ(png.cols, rig.s.view.width);
}

}  // namespace
}  // namespace nsim
