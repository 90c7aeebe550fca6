#include "direct_sim/breathe_command.h"

#include <iostream>
#include <sstream>
#include <string>

#include "common/breathing/breathing.h"
#include "common/breathing/marker_motion.h"
#include "common/core/cli.h"
#include "common/core/error.h"
#include "common/markers/marker_csv.h"

namespace nsim {
namespace {

// "x,y,z" -> vector; errors name the option
Eigen::Vector3d ParseVector3(const std::string& text, const std::string& what) {
  std::stringstream in(text);
  std::string part;
  Eigen::Vector3d v;
  int i = 0;
  while (std::getline(in, part, ',')) {
    if (i == 3) break;
    v[i++] = ParseDouble(part, what);
  }
  if (i != 3 || std::getline(in, part, ','))
    throw InputError(Str(what, ": expected three comma-separated numbers x,y,z, got '", text, "'"));
  return v;
}

int ParseIntOption(const CommandLine& cli, const std::string& name, long lo, long hi) {
  const long v = cli.GetInt(name);
  if (v < lo || v > hi)
    throw InputError(Str("--", name, " must be in [", lo, ", ", hi, "], got ", v));
  return static_cast<int>(v);
}

}  // namespace

int RunBreathe(int argc, char** argv) {
  CommandLine cli(
      "direct_sim breathe --out OUT.csv [options]",
      "Writes a synthetic marker stream: markers in a liver-sized region moving with a "
      "Lujan-type cos^2n breathing curve (cycle-to-cycle variation of amplitude and "
      "period, SI-dominant 3D motion, optional drift). CSV columns t,m0_x,m0_y,m0_z,... "
      "(s, m, world frame; z superior, y anterior, x patient right: the frame of configs/meshes).");
  cli.Option("out", "FILE", "output marker CSV", "", true)
      .Option("duration", "S", "stream duration (s)", "60")
      .Option("rate", "HZ", "sampling rate (Hz)", "30")
      .Option("markers", "N", "number of markers", "5")
      .Option("seed", "N", "random seed of the breathing cycles and the marker placement", "1")
      .Option("period", "S", "mean breathing period (s)", "4")
      .Option("period-cv", "X", "per-cycle period std / mean", "0.1")
      .Option("amplitude-cv", "X", "per-cycle amplitude factor std", "0.15")
      .Option("si-amplitude", "M", "mean peak-to-peak superior-inferior amplitude (m)", "0.012")
      .Option("ap-amplitude", "M", "mean peak-to-peak antero-posterior amplitude (m)", "0.0038")
      .Option("lr-amplitude", "M", "mean peak-to-peak left-right amplitude (m)", "0.0013")
      .Option("shape-n", "N", "exponent n of cos^2n", "2")
      .Option("start-phase", "X", "fraction of the first cycle elapsed at t = 0, [0, 1)", "0")
      .Option("drift", "X,Y,Z", "linear baseline drift velocity (m/s)", "0,0,0")
      .Option("center", "X,Y,Z", "centre of the marker region (m)", "0,0,0")
      .Option("semi-axes", "X,Y,Z", "semi-axes of the ellipsoidal marker region (m)",
              "0.08,0.04,0.06")
      .Option("min-gain", "X", "motion gain of the most inferior markers", "0.6")
      .Option("max-gain", "X", "motion gain of the most superior markers", "1.0")
      .Option("max-tilt", "RAD", "largest per-marker tilt of the motion direction (rad)", "0.15");
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;

  const long seed = cli.GetInt("seed");
  if (seed < 0) throw InputError(Str("--seed must be >= 0, got ", seed));
  BreathingConfig breathing;
  breathing.period = cli.GetDouble("period");
  breathing.period_cv = cli.GetDouble("period-cv");
  breathing.amplitude_cv = cli.GetDouble("amplitude-cv");
  breathing.si_amplitude = cli.GetDouble("si-amplitude");
  breathing.ap_amplitude = cli.GetDouble("ap-amplitude");
  breathing.lr_amplitude = cli.GetDouble("lr-amplitude");
  breathing.shape_exponent = ParseIntOption(cli, "shape-n", 1, 6);
  breathing.start_phase = cli.GetDouble("start-phase");
  breathing.drift_velocity = ParseVector3(cli.GetString("drift"), "--drift");
  breathing.random_seed = static_cast<uint64_t>(seed);

  MarkerMotionConfig markers;
  markers.num_markers = ParseIntOption(cli, "markers", 1, 100);
  markers.rate = cli.GetDouble("rate");
  markers.duration = cli.GetDouble("duration");
  markers.region_center = ParseVector3(cli.GetString("center"), "--center");
  markers.region_semi_axes = ParseVector3(cli.GetString("semi-axes"), "--semi-axes");
  markers.min_gain = cli.GetDouble("min-gain");
  markers.max_gain = cli.GetDouble("max-gain");
  markers.max_tilt = cli.GetDouble("max-tilt");
  markers.random_seed = static_cast<uint64_t>(seed);
  markers.Validate();
  // the cycle table only needs to cover the stream
  breathing.horizon = markers.duration + 2 * breathing.period;

  const BreathingModel model(breathing);
  const MarkerStream stream = MakeBreathingMarkerStream(model, markers);
  const std::string out = cli.GetString("out");
  WriteMarkerCsv(out, stream);
  std::cout << "breathe: wrote " << stream.frames.size() << " frames of " << stream.num_markers
            << " markers (" << markers.duration << " s at " << markers.rate << " Hz, "
            << model.cycles().size() << " breathing cycles, seed " << seed << ") to " << out
            << "\n";
  return 0;
}

}  // namespace nsim
