#include "common/breathing/breathing.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTruncationStd = 3.0;  // per-cycle factors are redrawn beyond this many std

bool IsFinite(const Eigen::Vector3d& v) { return v.allFinite(); }

// a normal factor 1 + cv * N(0,1), truncated at kTruncationStd
double DrawFactor(std::mt19937_64& rng, double cv) {
  std::normal_distribution<double> normal(0.0, 1.0);
  while (true) {
    const double z = normal(rng);
    if (std::abs(z) <= kTruncationStd) return 1.0 + cv * z;
  }
}

}  // namespace

void BreathingConfig::Validate() const {
  if (!(period > 0) || !std::isfinite(period))
    throw InputError(Str("breathing.period must be > 0 (s), got ", period));
  // human breathing: 2..10 s per cycle at rest (a newborn 1 s); 30 s is no breathing
  CheckRange(period, 0.5, 30.0, "breathing.period", "s");
  if (!(period_cv >= 0 && period_cv <= 0.3))
    throw InputError(Str("breathing.period_cv must be in [0, 0.3], got ", period_cv));
  if (!(amplitude_cv >= 0 && amplitude_cv <= 0.3))
    throw InputError(Str("breathing.amplitude_cv must be in [0, 0.3], got ", amplitude_cv));
  if (!(si_amplitude >= 0) || !std::isfinite(si_amplitude))
    throw InputError(Str("breathing.si_amplitude must be >= 0 (m), got ", si_amplitude));
  if (!(ap_amplitude >= 0) || !std::isfinite(ap_amplitude))
    throw InputError(Str("breathing.ap_amplitude must be >= 0 (m), got ", ap_amplitude));
  if (!(lr_amplitude >= 0) || !std::isfinite(lr_amplitude))
    throw InputError(Str("breathing.lr_amplitude must be >= 0 (m), got ", lr_amplitude));
  // the liver moves 5..25 mm superior-inferior (Liang 2018), never 10 cm
  CheckAtMost(si_amplitude, 0.1, "breathing.si_amplitude", "m");
  CheckAtMost(ap_amplitude, 0.1, "breathing.ap_amplitude", "m");
  CheckAtMost(lr_amplitude, 0.1, "breathing.lr_amplitude", "m");
  if (shape_exponent < 1 || shape_exponent > 6)
    throw InputError(Str("breathing.shape_exponent must be in [1, 6], got ", shape_exponent));
  if (!(start_phase >= 0 && start_phase < 1))
    throw InputError(Str("breathing.start_phase must be in [0, 1), got ", start_phase));
  const char* names[] = {"axis_si", "axis_ap", "axis_lr"};
  const Eigen::Vector3d* axes[] = {&axis_si, &axis_ap, &axis_lr};
  for (int i = 0; i < 3; ++i) {
    if (!IsFinite(*axes[i]) || !(axes[i]->norm() > 0))
      throw InputError(Str("breathing.", names[i], " must be a finite non-zero vector, got [",
                           axes[i]->transpose(), "]"));
  }
  if (!IsFinite(drift_velocity))
    throw InputError(Str("breathing.drift_velocity must be finite (m/s), got [",
                         drift_velocity.transpose(), "]"));
  // a drift of 1 cm/s moves the organ 10 cm in 10 s: baseline drift is mm per minute
  CheckNormAtMost(drift_velocity, 0.01, "breathing.drift_velocity", "m/s");
  if (!(horizon > 0) || !std::isfinite(horizon))
    throw InputError(Str("breathing.horizon must be > 0 (s), got ", horizon));
  // the cycles are drawn up front to the horizon: a day of breathing at most (~2e4 cycles)
  CheckAtMost(horizon, 86400.0, "breathing.horizon", "s");
}

BreathingModel::BreathingModel(const BreathingConfig& config) : config_(config) {
  config_.Validate();
  peak_ = config_.si_amplitude * config_.axis_si.normalized() +
          config_.ap_amplitude * config_.axis_ap.normalized() +
          config_.lr_amplitude * config_.axis_lr.normalized();
  // separate streams for periods and amplitudes, so changing one cv leaves the other's draws
  std::seed_seq period_seq{config_.random_seed, uint64_t{0x7065726f}};
  std::seed_seq amplitude_seq{config_.random_seed, uint64_t{0x616d706c}};
  std::mt19937_64 period_rng(period_seq), amplitude_rng(amplitude_seq);
  double start = 0.0;
  bool first = true;
  while (first || start <= config_.horizon) {
    BreathingCycle c;
    c.period = config_.period * DrawFactor(period_rng, config_.period_cv);
    c.amplitude_factor = DrawFactor(amplitude_rng, config_.amplitude_cv);
    c.start = first ? -config_.start_phase * c.period : start;
    start = c.start + c.period;
    cycles_.push_back(c);
    first = false;
  }
}

int BreathingModel::FindCycle(double t) const {
  NSIM_CHECK(t >= t_begin() && t <= t_end(), "breathing time ", t, " s outside [", t_begin(), ", ",
             t_end(), "]");
  const auto it = std::upper_bound(cycles_.begin(), cycles_.end(), t,
                                   [](double v, const BreathingCycle& c) { return v < c.start; });
  return static_cast<int>(it - cycles_.begin()) - 1;
}

double BreathingModel::CalcShape(double t) const {
  const BreathingCycle& c = cycles_[FindCycle(t)];
  const double s = std::sin(kPi * (t - c.start) / c.period);
  return c.amplitude_factor * std::pow(s * s, config_.shape_exponent);
}

Eigen::Vector3d BreathingModel::CalcDisplacement(double t) const {
  return CalcShape(t) * peak_ + config_.drift_velocity * t;
}

Eigen::Vector3d BreathingModel::CalcVelocity(double t) const {
  const BreathingCycle& c = cycles_[FindCycle(t)];
  const int n = config_.shape_exponent;
  const double angle = kPi * (t - c.start) / c.period;
  const double s = std::sin(angle);
  // d/dt a sin^2n(angle) = a 2n sin^(2n-1) cos (pi / tau)
  const double ds =
      c.amplitude_factor * 2.0 * n * std::pow(s, 2 * n - 1) * std::cos(angle) * kPi / c.period;
  return ds * peak_ + config_.drift_velocity;
}

}  // namespace nsim
