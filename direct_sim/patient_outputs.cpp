#include "direct_sim/patient_outputs.h"

#include <cstdio>
#include <filesystem>
#include <iostream>

#include "common/core/clock.h"
#include "common/mesh/vtk_writer.h"

namespace nsim {
namespace {

std::string MakeDirs(const std::string& out_dir, const RunConfig& run) {
  std::filesystem::create_directories(out_dir);
  if (run.vtk_every > 0) std::filesystem::create_directories(out_dir + "/vtk");
  return out_dir;
}

}  // namespace

PatientOutputs::PatientOutputs(const std::string& out_dir, const RunConfig& run,
                               const ViewerConfig& view, bool quiet)
    : out_dir_(MakeDirs(out_dir, run)), run_(run), quiet_(quiet), recorder_(out_dir) {
  if (run.video) {
    renderer_ = std::make_unique<SceneRenderer>(view);
    viewer_ = std::make_unique<SceneViewer>(view, out_dir_ + "/view.avi");
  }
  next_progress_ = MonotonicSeconds() + 1.0;
}

PatientOutputs::~PatientOutputs() = default;

void PatientOutputs::OnFrame(const PatientLoop& loop) { recorder_.AddFrame(loop); }

void PatientOutputs::OnStep(const PatientLoop& loop, int64_t total_steps) {
  recorder_.AddStep(loop);
  const int64_t k = loop.steps();
  if (run_.vtk_every > 0 && k % run_.vtk_every == 0) WriteVtk(loop);
  if (viewer_ && k % run_.view_every == 0) Render(loop);
  const double now = MonotonicSeconds();
  if (quiet_ || now < next_progress_) return;
  std::printf("run: t = %6.2f s, step %lld/%lld, %.1f ms/step, phase %d, tip-target %.2f mm%s\n",
              loop.time(), static_cast<long long>(k), static_cast<long long>(total_steps),
              loop.last_step().wall_ms, loop.record().phase, 1e3 * loop.record().distance,
              loop.last_step().holding ? ", holding" : "");
  std::fflush(stdout);
  next_progress_ = now + 1.0;
}

void PatientOutputs::WriteVtk(const PatientLoop& loop) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06lld", static_cast<long long>(loop.steps()));
  const std::string dir = out_dir_ + "/vtk/";
  const PatientScene& scene = loop.scene();
  const PatientSceneState& st = scene.state();
  WriteVtkTetMesh(dir + "liver_" + name + ".vtk", scene.model().liver().get_mesh(), st.liver.x);
  WriteVtkTetMesh(dir + "skin_" + name + ".vtk", scene.model().skin().get_mesh(), st.skin.x);
  WriteVtkPolyline(dir + "needle_" + name + ".vtk", scene.CalcNeedlePolyline());
  ++vtk_written_;
}

void PatientOutputs::Render(const PatientLoop& loop) {
  static const char* kPhase[] = {"outside", "in skin", "in liver"};
  char caption[160];
  std::snprintf(caption, sizeof(caption), "t = %.2f s   phase: %s   tip-target %.1f mm%s",
                loop.time(), kPhase[loop.record().phase], 1e3 * loop.record().distance,
                loop.last_step().holding ? "   HOLD" : "");
  viewer_->Add(renderer_->Render(loop.scene(), caption));
}

void PatientOutputs::Finish(const PatientLoop& loop, PatientRunInfo* info) {
  if (viewer_) viewer_->Finish(out_dir_ + "/view.png");
  info->video = viewer_ && !viewer_->video_path().empty();
  info->png = viewer_ && viewer_->frames() > 0;
  info->vtk_snapshots = vtk_written_;
  recorder_.WriteSummary(loop, *info);
  const PatientRecord& r = loop.record();
  std::printf(
      "run: %s after %lld steps (%.2f s simulated, %.2f s wall), median step %.2f ms, "
      "final tip-target %.2f mm, skin %s, liver %s\n",
      info->exit.c_str(), static_cast<long long>(loop.steps()), loop.time(), info->wall_time,
      recorder_.median_step_ms(), 1e3 * r.distance, r.skin.punctured ? "punctured" : "intact",
      r.liver.punctured ? "punctured" : "intact");
}

void ReportFault(const PatientLoop& loop, PatientRunInfo* info) {
  std::cerr << "direct_sim run: stopped at t = " << loop.time()
            << " s, the state is not plausible: " << loop.fault() << "\n";
  info->exit = "implausible_state";
  info->fault = loop.fault();
}

}  // namespace nsim
