#include "direct_sim/viewer.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>

#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/scene/patient_scene.h"

namespace nsim {
namespace {

// colours (BGR)
const cv::Scalar kBackground(40, 32, 28);
const cv::Scalar kLiverColor(60, 70, 170);
const cv::Scalar kSkinColor(150, 180, 225);
const cv::Scalar kRibColor(215, 225, 230);
const cv::Scalar kDiaphragmColor(120, 160, 90);
const cv::Scalar kMarkerColor(80, 220, 80);
const cv::Scalar kTargetColor(255, 0, 255);

struct Triangle {
  Eigen::Vector3d p[3];
  cv::Scalar color;
  bool cull = true;  // closed surface: hide faces turned away from the camera
};

void AddBoxTriangles(const OrientedBox& box, const cv::Scalar& color, std::vector<Triangle>* out) {
  // each face split into a grid of small quads (two triangles each), outward, so that the
  // painter's depth sort stays right next to the small liver triangles
  constexpr int kCells = 8;
  for (int axis = 0; axis < 3; ++axis)
    for (int side : {-1, 1}) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      auto point = [&](double a, double b) {
        Eigen::Vector3d s_B;
        s_B[axis] = side * box.half_size[axis];
        s_B[u] = (2.0 * a / kCells - 1.0) * box.half_size[u];
        s_B[v] = (2.0 * b / kCells - 1.0) * box.half_size[v];
        return Eigen::Vector3d(box.center + box.R_WB * s_B);
      };
      for (int i = 0; i < kCells; ++i)
        for (int j = 0; j < kCells; ++j) {
          // (u, v, axis) is right-handed: counter-clockwise in (u, v) faces +axis
          Eigen::Vector3d p00 = point(i, j), p10 = point(i + 1, j), p11 = point(i + 1, j + 1),
                          p01 = point(i, j + 1);
          if (side < 0) std::swap(p10, p01);
          out->push_back({{p00, p10, p11}, color, true});
          out->push_back({{p00, p11, p01}, color, true});
        }
    }
}

// the surfaces: liver, skin (two-sided: a thin sheet), ribs
std::vector<Triangle> CollectTriangles(const PatientScene& scene) {
  const PatientSceneModel& model = scene.model();
  const PatientSceneState& state = scene.state();
  std::vector<Triangle> triangles;
  const TetMesh& liver = model.liver().get_mesh();
  for (const Eigen::Vector3i& t : liver.surface)
    triangles.push_back(
        {{state.liver.x.col(t[0]), state.liver.x.col(t[1]), state.liver.x.col(t[2])},
         kLiverColor,
         true});
  const TetMesh& skin = model.skin().get_mesh();
  for (const Eigen::Vector3i& t : skin.surface)
    triangles.push_back({{state.skin.x.col(t[0]), state.skin.x.col(t[1]), state.skin.x.col(t[2])},
                         kSkinColor,
                         false});
  for (const OrientedBox& rib : model.config().ribs) AddBoxTriangles(rib, kRibColor, &triangles);
  return triangles;
}

// a triangle in the image: its pixels, mean depth and shaded colour
struct Projected {
  cv::Point points[3];
  double depth;
  cv::Scalar color;
};

// the triangles facing the camera and in front of it, projected and flat-shaded; `forward_W` is
// the view direction
std::vector<Projected> ProjectVisible(const std::vector<Triangle>& triangles,
                                      const SceneRenderer& renderer,
                                      const Eigen::Vector3d& forward_W) {
  const ViewerConfig& config = renderer.config();
  std::vector<Projected> visible;
  visible.reserve(triangles.size());
  const Eigen::Vector3d light = -forward_W + 0.5 * config.up.normalized();
  const Eigen::Vector3d light_dir = light.normalized();
  for (const Triangle& t : triangles) {
    const Eigen::Vector3d n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
    if (!(n.norm() > 0)) continue;
    const Eigen::Vector3d centroid = (t.p[0] + t.p[1] + t.p[2]) / 3.0;
    const Eigen::Vector3d view =
        config.fov_deg > 0 ? Eigen::Vector3d(centroid - config.eye) : forward_W;
    if (t.cull && n.dot(view) > 0) continue;
    Projected p;
    bool in_front = true;
    double depth_sum = 0;
    for (int k = 0; k < 3; ++k) {
      double depth = 0;
      const Eigen::Vector2d px = renderer.Project(t.p[k], &depth);
      in_front = in_front && (config.fov_deg == 0 || depth > 1e-3);
      p.points[k] =
          cv::Point(static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y())));
      depth_sum += depth;
    }
    if (!in_front) continue;
    p.depth = depth_sum / 3.0;
    const double shade = 0.35 + 0.65 * std::abs(n.normalized().dot(light_dir));
    p.color = t.color * shade;
    visible.push_back(p);
  }
  return visible;
}

// painter's algorithm: far to near, each filled over the farther ones
void FillFarToNear(std::vector<Projected> triangles, cv::Mat* image) {
  std::sort(triangles.begin(), triangles.end(),
            [](const Projected& a, const Projected& b) { return a.depth > b.depth; });
  for (const Projected& p : triangles)
    cv::fillConvexPoly(*image, p.points, 3, p.color, cv::LINE_AA);
}

void DrawLine(const SceneRenderer& renderer, const Eigen::Vector3d& a_W, const Eigen::Vector3d& b_W,
              const cv::Scalar& color, int thickness, int line_type, cv::Mat* image) {
  const Eigen::Vector2d a = renderer.Project(a_W), b = renderer.Project(b_W);
  cv::line(*image, cv::Point2d(a.x(), a.y()), cv::Point2d(b.x(), b.y()), color, thickness,
           line_type);
}

// the twelve edges of a box
void DrawBoxOutline(const SceneRenderer& renderer, const OrientedBox& box, const cv::Scalar& color,
                    cv::Mat* image) {
  auto corner = [&](int c) {
    const Eigen::Vector3d s((c & 1) ? 1 : -1, (c & 2) ? 1 : -1, (c & 4) ? 1 : -1);
    return Eigen::Vector3d(box.center + box.R_WB * s.cwiseProduct(box.half_size));
  };
  for (int i = 0; i < 8; ++i)
    for (int k = 0; k < 3; ++k) {
      const int j = i ^ (1 << k);
      if (j < i) continue;
      DrawLine(renderer, corner(i), corner(j), color, 1, cv::LINE_AA, image);
    }
}

// drawn over the surfaces, always visible: needle, markers, target, caption
void DrawOverlays(const SceneRenderer& renderer, const PatientScene& scene,
                  const std::string& caption, cv::Mat* image) {
  const Eigen::Matrix3Xd needle = scene.CalcNeedlePolyline();
  for (int k = 0; k + 1 < needle.cols(); ++k)
    DrawLine(renderer, needle.col(k), needle.col(k + 1), NeedleColor(), 3, cv::LINE_8, image);
  std::vector<Eigen::Vector3d> markers;
  scene.CalcMarkerPositions(&markers);
  for (const Eigen::Vector3d& m : markers) {
    const Eigen::Vector2d px = renderer.Project(m);
    cv::circle(*image, cv::Point2d(px.x(), px.y()), 5, kMarkerColor, cv::FILLED, cv::LINE_AA);
  }
  const Eigen::Vector2d target = renderer.Project(scene.CalcTargetPosition());
  const cv::Point2d tc(target.x(), target.y());
  cv::drawMarker(*image, tc, kTargetColor, cv::MARKER_TILTED_CROSS, 14, 2);
  cv::circle(*image, tc, 8, kTargetColor, 1, cv::LINE_AA);
  if (!caption.empty())
    cv::putText(*image, caption, cv::Point(10, 24), cv::FONT_HERSHEY_SIMPLEX, 0.6,
                cv::Scalar(240, 240, 240), 1, cv::LINE_AA);
}

}  // namespace

void ViewerConfig::Validate() const {
  if (width < 64 || height < 64)
    throw InputError(
        Str("view.width and view.height must be >= 64 (px), got ", width, " x ", height));
  if (!eye.allFinite() || !look_at.allFinite() || !up.allFinite() ||
      !((look_at - eye).norm() > 1e-6) || !((look_at - eye).normalized().cross(up).norm() > 1e-3))
    throw InputError(
        "view.eye, view.look_at and view.up must be finite, eye != look_at, and up "
        "not along the view direction");
  if (!(fov_deg >= 0 && fov_deg < 170))
    throw InputError(
        Str("view.fov_deg must be in [0, 170) (deg; 0 = orthographic), got ", fov_deg));
  if (!(ortho_height > 0))
    throw InputError(Str("view.ortho_height must be > 0 (m), got ", ortho_height));
  if (!(fps > 0)) throw InputError(Str("view.fps must be > 0 (Hz), got ", fps));
  // an 8K frame (7680 x 4320) is the largest a video writer takes; 240 fps the fastest
  // display; 100 m of orthographic view is no scene of a patient
  if (width > 8192 || height > 8192)
    throw InputError(
        Str("view.width and view.height must be <= 8192 (px), got ", width, " x ", height));
  CheckAtMost(fps, 240.0, "view.fps", "Hz");
  CheckAtMost(ortho_height, 100.0, "view.ortho_height", "m");
  CheckNormAtMost(eye, 100.0, "view.eye", "m");
  CheckNormAtMost(look_at, 100.0, "view.look_at", "m");
}

SceneRenderer::SceneRenderer(const ViewerConfig& config) : config_(config) {
  config_.Validate();
  const Eigen::Vector3d forward = (config_.look_at - config_.eye).normalized();
  const Eigen::Vector3d right = forward.cross(config_.up).normalized();
  const Eigen::Vector3d up = right.cross(forward);
  R_CW_.row(0) = right.transpose();
  R_CW_.row(1) = -up.transpose();
  R_CW_.row(2) = forward.transpose();
  focal_px_ = config_.fov_deg > 0
                  ? 0.5 * config_.height / std::tan(0.5 * config_.fov_deg * M_PI / 180.0)
                  : config_.height / config_.ortho_height;
}

Eigen::Vector2d SceneRenderer::Project(const Eigen::Vector3d& p_W, double* depth) const {
  const Eigen::Vector3d p_C = R_CW_ * (p_W - config_.eye);
  if (depth != nullptr) *depth = p_C.z();
  const double scale = config_.fov_deg > 0 ? focal_px_ / std::max(p_C.z(), 1e-6) : focal_px_;
  return Eigen::Vector2d(0.5 * config_.width + scale * p_C.x(),
                         0.5 * config_.height + scale * p_C.y());
}

cv::Mat SceneRenderer::Render(const PatientScene& scene, const std::string& caption) const {
  cv::Mat image(config_.height, config_.width, CV_8UC3, kBackground);
  FillFarToNear(ProjectVisible(CollectTriangles(scene), *this, R_CW_.row(2).transpose()), &image);
  DrawBoxOutline(*this, scene.model().config().diaphragm, kDiaphragmColor, &image);
  DrawOverlays(*this, scene, caption, &image);
  return image;
}

SceneViewer::SceneViewer(const ViewerConfig& config, const std::string& video_path)
    : config_(config), video_path_(video_path) {
  const char* display = std::getenv("DISPLAY");
  if (display != nullptr && display[0] != '\0') {
    try {
      cv::namedWindow("direct_sim", cv::WINDOW_AUTOSIZE);
      window_ = true;
    } catch (const cv::Exception&) {
      window_ = false;
    }
  }
}

SceneViewer::~SceneViewer() {
  if (writer_) writer_->release();
  if (window_) cv::destroyAllWindows();
}

void SceneViewer::Add(const cv::Mat& frame) {
  last_ = frame.clone();
  ++frames_;
  if (window_) {
    cv::imshow("direct_sim", frame);
    cv::waitKey(1);
    return;
  }
  if (!writer_) {
    writer_ = std::make_unique<cv::VideoWriter>(
        video_path_, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), config_.fps, frame.size());
    if (!writer_->isOpened()) {
      std::cerr << "direct_sim: cannot open the video file " << video_path_ << " (no video)\n";
      video_path_.clear();
    } else {
      written_video_ = video_path_;
    }
  }
  if (writer_->isOpened()) writer_->write(frame);
}

void SceneViewer::Finish(const std::string& png_path) {
  if (writer_) writer_->release();
  if (!last_.empty() && !png_path.empty()) cv::imwrite(png_path, last_);
}

}  // namespace nsim
