#include "common/results/controller_recorder.h"

#include <iomanip>
#include <sstream>

#include "common/core/error.h"
#include "common/results/atomic_file.h"

namespace nsim {
namespace {

using nlohmann::json;

json Timing(const TimingStat& s) {
  return {{"mean_ms", 1e3 * s.mean()}, {"max_ms", 1e3 * s.max}, {"count", s.count}};
}

// the loop delays the controller measured (frame -> frame whose step executed its answer)
json DelayStats(const std::vector<double>& delays_s) {
  if (delays_s.empty()) return {{"median", nullptr}, {"p95", nullptr}, {"max", nullptr}, {"count", 0}};
  const SampleSummary s = Summarize(delays_s);
  return {{"median", 1e3 * s.median}, {"p95", 1e3 * s.p95}, {"max", 1e3 * s.max},
          {"count", s.count}};
}

}  // namespace

ControllerRecorder::ControllerRecorder(const std::string& out_dir) : out_dir_(out_dir) {
  csv_ = std::make_unique<LineFile>(out_dir_ + "/inverse.csv", LineFile::Mode::kInPlace);
  csv_->WriteLine(
      "answers_seq,sim_time,phase,path_index,valid,e_p_norm,horizon,predicted,model_tip_x,"
      "model_tip_y,model_tip_z,step_ms,jacobian_ms,total_ms,model_target_x,model_target_y,"
      "model_target_z,latency_steps,load_gain,preparing,shrinkage,model_depth_m,"
      "model_past_seed_m,model_tip_hold");
}

void ControllerRecorder::AddAnswer(const ControllerLoop& loop) {
  const ControllerRecord& r = loop.last_record();
  std::ostringstream row;  // the whole row, written at once: a kill leaves no half row
  row << std::setprecision(17);
  row << r.answers_seq << ',' << r.t << ',' << r.phase << ',' << r.path_index << ',' << r.valid
      << ',' << r.e_p_norm << ',' << r.horizon << ',' << r.predicted << ',' << r.model_tip.x()
      << ',' << r.model_tip.y() << ',' << r.model_tip.z() << ',' << 1e3 * r.timings.simulation
      << ',' << 1e3 * r.timings.jacobian << ',' << 1e3 * r.timings.total << ','
      << r.model_target.x() << ',' << r.model_target.y() << ',' << r.model_target.z() << ','
      << r.latency_steps << ',' << r.load_gain << ',' << r.preparing << ',' << r.shrinkage << ','
      << r.model_depth << ',' << r.model_past_seed << ',' << r.model_tip_hold;
  csv_->WriteLine(row.str());
}

json ControllerRecorder::Summary(const ControllerLoop& loop, const ControllerRunInfo& info) const {
  const ControllerLoopConfig& c = loop.config();
  const ControllerCounts& n = loop.counts();
  const PredictionScore& score = loop.score();
  json nrms = json::array(), rms = json::array(), bias = json::array();
  for (const auto& v : score.NrmsPercent()) nrms.push_back(v ? json(*v) : json(nullptr));
  for (double v : score.Rms()) rms.push_back(1e3 * v);
  for (const Eigen::Vector3d& b : score.Bias()) bias.push_back({1e3 * b.x(), 1e3 * b.y(), 1e3 * b.z()});
  // the predictor's own predictions (before prediction.shrink) and their shrinkage factors
  json predictor_nrms = json::array();
  for (const auto& v : loop.predictor_score().NrmsPercent())
    predictor_nrms.push_back(v ? json(*v) : json(nullptr));
  const json shrinkage = loop.predictor_score().Shrinkage();
  // the LF regression window WF each marker's predictor uses at the end (0: no window)
  json windows = json::array();
  if (const MarkerPredictor* p = loop.predictor())
    for (int m = 0; m < p->num_markers(); ++m) windows.push_back(p->filter(m).window());
  return {{"ending", info.ending},
          {"scenario_hash", info.scenario_hash},
          {"transport", info.transport},
          {"inverse_rate_hz", loop.loop_period().rate()},
          {"targets_sent", n.targets},
          {"frames_answered", n.answered},
          {"frames_received", info.frames_received},
          {"frames_missing", info.frames_missing},
          {"frames_skipped", info.frames_skipped},
          {"direct_losses", info.direct_losses},
          {"link_delay_ms", 1e3 * info.link_delay},
          {"frames_out_of_order", info.frames_out_of_order},
          {"rejected_frames", n.rejected_frames},
          {"invalid_outputs", n.invalid_outputs},
          {"tilt_limited", n.tilt_limited},
          {"insertion_limited", n.insertion_limited},
          // the preparation phase (prediction.preparation): frames answered with the hold
          {"preparation_frames", n.prepared},
          // commands the robot did not carry out when due (the forecast pose runs only: lost)
          {"unapplied_targets", n.unapplied_targets},
          {"last_rejection", n.last_rejection},
          {"timings",
           {{"model_step", Timing(loop.model_time())},
            {"jacobian", Timing(loop.jacobian_time())},
            {"total", Timing(loop.total_time())},
            {"loop_period", Timing(loop.loop_period())},
            {"frame_sent_to_target_sent", Timing(info.frame_to_target)}}},
          {"measured_loop_delay_ms", DelayStats(loop.measured_delays())},
          {"nrms_percent", nrms},
          {"prediction_rms_mm", rms},
          {"prediction_bias_mm", bias},
          {"predictions_scored", score.scored()},
          {"prediction_windows", windows},
          {"predictor_nrms_percent", predictor_nrms},
          {"prediction_shrinkage", shrinkage},
          // the model built mid-insertion (a restarted controller): how it caught up
          {"catch_up",
           {{"first_answered_seq", loop.first_answered_seq()},
            {"done", loop.catch_up().done},
            {"depth_mm", 1e3 * loop.catch_up().depth},
            {"aligned_mm", 1e3 * loop.catch_up().aligned},
            {"aligned_rad", loop.catch_up().aligned_angle},
            {"model_steps", loop.catch_up().steps},
            {"liver_phase", ToString(loop.catch_up().liver_phase)},
            {"liver_points", loop.catch_up().liver_points},
            {"wall_s", loop.catch_up().wall_time}}},
          {"settings",
           {{"config", info.scenario},
            {"mesh", info.mesh},
            {"mesh_nodes", loop.mesh().num_nodes()},
            {"dof", ToString(c.control.dof)},
            {"prediction", c.prediction_enabled},
            {"filter", ToString(c.prediction.filter)},
            {"order", c.prediction.order},
            {"optimize_window", c.prediction.optimize_window},
            {"search_lead", loop.search_lead()},
            {"search_interval", c.prediction.search_interval},
            {"preparation", c.preparation == Preparation::kNone     ? "none"
                            : c.preparation == Preparation::kBuffer ? "buffer"
                                                                    : "exhale"},
            {"prediction_displacement", c.prediction_displacement},
            {"prediction_shrink", c.prediction_shrink},
            {"model_pose", ModelPoseName(c.model_pose)},
            {"localization_delay_s", c.horizon.localization_delay},
            {"young_modulus_factor", c.model.young_modulus_factor},
            {"model_needle",
             c.model.needle_kind == ModelNeedleKind::kFlexible ? "flexible" : "rigid"},
            {"model_bevel", c.model.bevel.enabled},
            {"alignment", c.control.alignment == AlignmentReference::kTip ? "tip" : "base"},
            {"max_needle_tilt_rad", c.control.max_needle_tilt},
            {"max_insertion_step_m", c.control.max_insertion_step},
            {"free_stretch_step_m", c.control.free_stretch_step},
            {"free_stretch_tolerance_m", c.control.free_stretch_tolerance},
            {"liver_alignment", c.control.liver_alignment == LiverAlignment::kAuto   ? "auto"
                                : c.control.liver_alignment == LiverAlignment::kNone ? "none"
                                                                                      : "base"},
            {"liver_load", c.control.liver_load},
            {"gains",
             {{"position", c.control.gains.position},
              {"angle", c.control.gains.angle},
              {"entry", c.control.gains.entry},
              {"load", c.control.gains.load}}},
            {"regularization", c.control.law.regularization},
            {"compensate_in_flight", c.control.compensate_in_flight},
            {"path_advance", c.path.advance == PathAdvance::kCommanded ? "commanded" : "measured"},
            {"measure_latency", c.measure_latency},
            {"mode", info.lockstep ? "lockstep" : "realtime"},
            {"domain", info.domain},
            {"partition", info.partition}}}};
}

void ControllerRecorder::WriteSummary(const ControllerLoop& loop,
                                      const ControllerRunInfo& info) const {
  csv_->Commit();  // inverse.csv flushed and closed, then the summary that describes it
  json summary = Summary(loop, info);
  // only in secured runs: the summary of any other run stays as it was
  if (!info.dds_identity.empty()) summary["dds_security"] = {{"identity", info.dds_identity}};
  WriteFileAtomically(out_dir_ + "/summary.json", summary.dump(2) + "\n");
}

}  // namespace nsim
