#pragma once
// Everything direct_sim writes while a patient loop runs, whatever drives it (DDS or the
// in-process closed loop): the recorder's CSVs and summary, VTK snapshots, the rendered view
// (window or video, and the last frame as PNG) and the progress lines.

#include <memory>
#include <string>

#include "common/results/patient_recorder.h"
#include "common/scene/patient_loop.h"
#include "direct_sim/scenario_loader.h"
#include "direct_sim/viewer.h"

namespace nsim {

class PatientOutputs {
 public:
  /// Creates `out_dir` (and out_dir/vtk when snapshots are asked for).
  PatientOutputs(const std::string& out_dir, const RunConfig& run, const ViewerConfig& view,
                 bool quiet);
  ~PatientOutputs();

  /// The frame the loop hands out now (its CSV row).
  void OnFrame(const PatientLoop& loop);
  /// After a step: VTK snapshot and view when due, a progress line once a second.
  void OnStep(const PatientLoop& loop, int64_t total_steps);
  /// Closes the view and writes summary.json; prints the closing line.
  void Finish(const PatientLoop& loop, PatientRunInfo* info);

  const PatientRecorder& recorder() const { return recorder_; }
  const std::string& out_dir() const { return out_dir_; }

 private:
  void WriteVtk(const PatientLoop& loop);
  void Render(const PatientLoop& loop);

  std::string out_dir_;
  RunConfig run_;
  bool quiet_;
  PatientRecorder recorder_;
  std::unique_ptr<SceneRenderer> renderer_;
  std::unique_ptr<SceneViewer> viewer_;
  int vtk_written_ = 0;
  double next_progress_ = 0.0;
};

/// Reports the state the physics watchdog refused (PatientLoop::fault) on stderr and in `info`
/// (exit "implausible_state"): the run ends as a runtime failure.
void ReportFault(const PatientLoop& loop, PatientRunInfo* info);

}  // namespace nsim
