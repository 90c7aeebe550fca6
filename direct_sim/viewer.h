#pragma once
// The view of the direct simulation, rendered with OpenCV: the liver surface, the skin, the
// ribs, the diaphragm box outline, the needle, the markers and the target, from a fixed camera
// (perspective or orthographic), as flat-shaded triangles sorted back to front (painter's
// algorithm). Shown in a live window when a display exists, written to a video file otherwise,
// and the last frame saved as PNG.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

namespace nsim {

class PatientScene;

/// Colour of the needle overlay (BGR); nothing else in the view has it.
inline cv::Scalar NeedleColor() { return cv::Scalar(0, 230, 255); }

/// Camera and image settings. World frame, SI units.
struct ViewerConfig {
  int width = 960;                           ///< image width (px), >= 64
  int height = 720;                          ///< image height (px), >= 64
  Eigen::Vector3d eye{0.45, 0.35, 0.25};     ///< camera position (m)
  Eigen::Vector3d look_at{0.02, 0.02, 0.0};  ///< point at the image centre (m)
  Eigen::Vector3d up{0.0, 0.0, 1.0};         ///< world direction shown upwards
  /// Vertical field of view (deg) in (0, 170); 0 = orthographic.
  double fov_deg = 35.0;
  /// Orthographic: world height shown by the image (m), > 0.
  double ortho_height = 0.3;
  double fps = 25.0;  ///< video frame rate (Hz), > 0

  /// Throws InputError "view.<key> ...".
  void Validate() const;
};

/// Fixed-camera projection and the painter's-algorithm renderer.
class SceneRenderer {
 public:
  explicit SceneRenderer(const ViewerConfig& config);

  /// Pixel coordinates (x right, y down) of a world point, and its depth along the view
  /// direction (m, > 0 in front of a perspective camera).
  Eigen::Vector2d Project(const Eigen::Vector3d& p_W, double* depth = nullptr) const;

  /// Renders the scene now, with `caption` (one line) at the top left. 8-bit BGR image.
  cv::Mat Render(const PatientScene& scene, const std::string& caption) const;

  const ViewerConfig& config() const { return config_; }

 private:
  ViewerConfig config_;
  Eigen::Matrix3d R_CW_;  // world -> camera (rows: right, down, forward)
  double focal_px_ = 0.0;
};

/// Where rendered frames go: a live window (DISPLAY set and highgui works), else a video file
/// (MJPG .avi); the last frame is kept for a PNG.
class SceneViewer {
 public:
  /// `video_path` is used when no window can be opened.
  SceneViewer(const ViewerConfig& config, const std::string& video_path);
  ~SceneViewer();

  /// Shows or writes one frame.
  void Add(const cv::Mat& frame);
  /// Closes the window or the file and writes the last frame to `png_path` (if any frame).
  void Finish(const std::string& png_path);

  bool has_window() const { return window_; }
  /// The video file written, empty when a window was used or nothing was written.
  const std::string& video_path() const { return written_video_; }
  int frames() const { return frames_; }

 private:
  ViewerConfig config_;
  std::string video_path_, written_video_;
  bool window_ = false;
  std::unique_ptr<cv::VideoWriter> writer_;
  cv::Mat last_;
  int frames_ = 0;
};

}  // namespace nsim
