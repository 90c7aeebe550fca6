#pragma once
// A tracker's measurement noise on the fiducial markers the patient side publishes: white
// Gaussian, independent per frame, marker and coordinate, with a standard deviation in metres
// (an optical or electromagnetic tracker's RMS error per axis). The simulated markers are
// otherwise exact, so the controller's predictor and registration see a cleaner signal than a
// real tracker gives them (thesis §5.2.1 adds noise offline, at an SNR; this is the same noise
// in the closed loop, at a physical size).

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <vector>

namespace nsim {

struct TrackerNoiseConfig {
  /// Standard deviation of each coordinate of each measured marker (m), in [0, 0.01]; 0: the
  /// markers are exact and no random number is drawn.
  double marker_std = 0.0;
  /// Seeds the draws (std::mt19937_64 through a seed sequence with its own tag, so that the
  /// same run seed gives draws independent of the breathing's).
  uint64_t random_seed = 1;

  /// Throws InputError "tracker.marker_noise must be ..." for a negative, non-finite or
  /// larger than 1 cm value.
  void Validate() const;
};

class TrackerNoise {
 public:
  explicit TrackerNoise(const TrackerNoiseConfig& config);

  /// Adds one frame's noise to the exact marker positions (unchanged when marker_std is 0).
  /// The sequence of draws depends only on the seed and the number of coordinates drawn so
  /// far: the same run gives the same noise.
  void Apply(std::vector<Eigen::Vector3d>* markers);

  const TrackerNoiseConfig& config() const { return config_; }

 private:
  TrackerNoiseConfig config_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
};

}  // namespace nsim
