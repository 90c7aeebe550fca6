#pragma once
// The start of end-exhale in a breathing marker stream, for a respiratory-gated insertion
// start (ControllerLoopConfig::preparation kExhale). Clinically a needle goes in at end-exhale;
// in this simulator the final error depends on the breathing phase at which the needle crosses
// the skin and the liver's surface (README "Control under latency", the preparation phase).
//
// The signal is the first principal component of the markers' centroid over the last
// `capacity` frames (a PcaBuffer). Lujan's cos^2n breathing rests at exhale and dips to
// inhale, so the exhale end is the extreme of the buffer's range that the median is nearer
// to. The gate reports the frame at which the component enters the band within
// `band` x range of that extreme from outside it: the start of the exhale rest.

#include <Eigen/Core>
#include <vector>

#include "common/prediction/pca_buffer.h"

namespace nsim {

struct ExhaleGateConfig {
  int capacity = 300;       ///< frames of history (the predictor's PCA window), >= 3
  double band = 0.1;        ///< the exhale band's width as a fraction of the range, in (0, 0.5)
  double min_range = 1e-4;  ///< below this range (m) there is no breathing to wait for

  /// Throws InputError naming the field.
  void Validate() const;
};

class ExhaleGate {
 public:
  /// Validates config (InputError).
  explicit ExhaleGate(const ExhaleGateConfig& config);

  /// Adds the markers' centroid of a frame (m) at time t (s, increasing). Returns true when
  /// the history is full and this frame enters the exhale band from outside it, or when the
  /// history is full and its range is below min_range (no breathing: nothing to wait for).
  bool Add(double t, const Eigen::Vector3d& centroid);

  /// The history's range along its first principal axis at the last Add (m; 0 before full).
  double range() const { return range_; }

 private:
  ExhaleGateConfig config_;
  PcaBuffer buffer_;
  PrincipalAxes axes_;
  std::vector<double> scratch_;
  double range_ = 0.0;
};

}  // namespace nsim
