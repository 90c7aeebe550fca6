#include "common/breathing/marker_motion.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "common/core/error.h"

namespace nsim {
namespace {
constexpr int kMaxMarkers = 100;
}  // namespace

void MarkerMotionConfig::Validate() const {
  if (num_markers < 1 || num_markers > kMaxMarkers)
    throw InputError(
        Str("markers.num_markers must be in [1, ", kMaxMarkers, "], got ", num_markers));
  if (!region_center.allFinite())
    throw InputError(
        Str("markers.region_center must be finite (m), got [", region_center.transpose(), "]"));
  if (!region_semi_axes.allFinite() || !(region_semi_axes.minCoeff() > 0))
    throw InputError(
        Str("markers.region_semi_axes must be > 0 (m), got [", region_semi_axes.transpose(), "]"));
  if (!(min_gain > 0) || !std::isfinite(min_gain))
    throw InputError(Str("markers.min_gain must be > 0, got ", min_gain));
  if (!(max_gain >= min_gain) || !std::isfinite(max_gain))
    throw InputError(Str("markers.max_gain must be >= min_gain (", min_gain, "), got ", max_gain));
  if (!(max_tilt >= 0 && max_tilt <= 0.5))
    throw InputError(Str("markers.max_tilt must be in [0, 0.5] (rad), got ", max_tilt));
  if (!(rate > 0) || !std::isfinite(rate))
    throw InputError(Str("markers.rate must be > 0 (Hz), got ", rate));
  if (!(duration > 0) || !std::isfinite(duration))
    throw InputError(Str("markers.duration must be > 0 (s), got ", duration));
}

MarkerMotion MakeMarkerMotion(const BreathingModel& model, const MarkerMotionConfig& config) {
  config.Validate();
  std::seed_seq seq{config.random_seed, uint64_t{0x6d61726b}};
  std::mt19937_64 rng(seq);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> fraction(0.0, 1.0);
  const Eigen::Vector3d up = -model.config().axis_si.normalized();
  // support of the ellipsoid along `up`: the largest height a point inside can have
  const double half_height = (config.region_semi_axes.array() * up.array()).matrix().norm();

  MarkerMotion motion;
  for (int m = 0; m < config.num_markers; ++m) {
    // uniform in the unit ball by rejection, then scaled to the ellipsoid
    Eigen::Vector3d u;
    do {
      u = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    } while (u.squaredNorm() > 1.0);
    const Eigen::Vector3d offset = config.region_semi_axes.cwiseProduct(u);
    const double height = offset.dot(up) / half_height;  // in [-1, 1]
    Eigen::Vector3d axis;
    do {
      axis = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    } while (axis.squaredNorm() > 1.0 || axis.squaredNorm() < 1e-6);
    const double angle = config.max_tilt * fraction(rng);
    motion.p0_W.push_back(config.region_center + offset);
    motion.gain.push_back(config.min_gain +
                          (config.max_gain - config.min_gain) * 0.5 * (height + 1));
    motion.R_tilt.push_back(Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix());
  }
  return motion;
}

Eigen::Vector3d CalcMarkerPosition(const BreathingModel& model, const MarkerMotion& motion, int m,
                                   double t) {
  return motion.p0_W[m] + motion.gain[m] * (motion.R_tilt[m] * model.CalcDisplacement(t));
}

MarkerStream MakeBreathingMarkerStream(const BreathingModel& model,
                                       const MarkerMotionConfig& config) {
  const MarkerMotion motion = MakeMarkerMotion(model, config);
  if (config.duration > model.t_end())
    throw InputError(Str("markers.duration (", config.duration,
                         " s) exceeds the breathing model horizon (", model.t_end(), " s)"));
  const long num_frames = static_cast<long>(std::floor(config.duration * config.rate + 1e-9)) + 1;
  MarkerStream stream;
  stream.num_markers = config.num_markers;
  stream.frames.resize(num_frames);
  for (long k = 0; k < num_frames; ++k) {
    MarkerFrame& frame = stream.frames[k];
    const double t = std::min(static_cast<double>(k) / config.rate, config.duration);
    frame.stamp.seq = static_cast<uint64_t>(k);
    frame.stamp.sim_time = t;
    frame.p_WM.resize(config.num_markers);
    for (int m = 0; m < config.num_markers; ++m)
      frame.p_WM[m] = CalcMarkerPosition(model, motion, m, t);
  }
  return stream;
}

}  // namespace nsim
