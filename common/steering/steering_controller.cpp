#include "common/steering/steering_controller.h"

#include <algorithm>
#include <chrono>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>

#include "common/control/control_law.h"
#include "common/control/delay_margin.h"
#include "common/control/finite_difference_jacobian.h"
#include "common/control/insertion_step.h"
#include "common/control/needle_tilt.h"
#include "common/core/error.h"
#include "common/robot/pose_math.h"

namespace nsim {
namespace {

// a point seeded within this fraction of a free stretch's length before the final target ties
// the target's tissue to the needle line: the stretch before it is the last free one
constexpr double kSeedBeforeTargetMargin = 0.5;

double Seconds(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

}  // namespace

Iiwa14Config MakeFlangeIiwaConfig(const Iiwa14Config& iiwa) {
  Iiwa14Config c = iiwa;
  c.X_FT = Eigen::Isometry3d::Identity();
  return c;
}

SteeringController::SteeringController(const InverseModelConfig& model,
                                       const SteeringPathConfig& path,
                                       const SteeringControlConfig& control, const TetMesh& mesh,
                                       const Eigen::Isometry3d& X_WE0)
    : control_((control.Validate(), control)),
      iiwa_(MakeFlangeIiwaConfig(control.iiwa)),
      flange_ik_(iiwa_, [] {
        Iiwa14IkConfig c;
        c.max_restarts = 0;
        c.null_space_gain = 0.0;
        c.position_tolerance = 1e-10;
        c.orientation_tolerance = 1e-10;
        return c;
      }()) {
  sim_ = std::make_unique<SteeringSimulation>(model, path, mesh, X_WE0);
  X_WN_step_ = sim_->X_WN();
  switch_distance_ = path.switching.switch_distance;
  advance_ = path.advance;
  needle_p_FBase_ = model.needle.p_FBase;
  needle_axis_F_ = model.needle.axis_F;
  roll_free_ = !model.bevel.enabled;
  align_in_liver_ = control_.liver_alignment == LiverAlignment::kBase ||
                    (control_.liver_alignment == LiverAlignment::kAuto &&
                     model.needle_kind == ModelNeedleKind::kFlexible);
  liver_load_ = control_.liver_load > 0.0 && model.needle_kind != ModelNeedleKind::kFlexible;
}

SteeringController::~SteeringController() = default;

Eigen::Isometry3d SteeringController::CalcFlangePose(const Vector7d& q) const {
  return iiwa_.CalcToolPose(q);
}

Eigen::VectorXd SteeringController::EvaluateObjectives(const Eigen::Isometry3d& X_WF,
                                                       InsertionPhase phase) const {
  return CalcObjectives(sim_->EvaluateAt(X_WF, workspace_), phase);
}

Eigen::VectorXd SteeringController::CalcObjectives(const SteeringEvaluation& eval,
                                                   InsertionPhase phase) const {
  ObjectiveValues values;
  values.e_p = CalcPositionObjective(eval.p_WPath[path_index_], eval.p_WTip);
  // the needle's direction at its tip (the bent needle's) or at its base (the flange's axis);
  // in the liver (align_in_liver_) always the base's
  const bool tip = control_.alignment == AlignmentReference::kTip &&
                   !(align_in_liver_ && phase == InsertionPhase::kInLiver);
  const Eigen::Vector3d z = tip ? Eigen::Vector3d(eval.R_WTip.col(2))
                                : Eigen::Vector3d(eval.X_WN.linear().col(2));
  values.e_a = CalcAngleObjective(z, sim_->path_direction());
  if (entry_known_) {
    // the entry point stays on the needle: it moves rigidly with the perturbed needle
    const Eigen::Vector3d p_WC = eval.X_WN * (X_WN_step_.inverse() * p_WC_);
    values.e_e = CalcEntryObjective(entry_plane_, p_WC);
  }
  values.e_l = load_map_ * eval.needle_force;
  Eigen::VectorXd e;
  AssembleObjectiveVector(phase, values, &e, align_in_liver_, liver_load_);
  return e;
}

CatchUpReport SteeringController::CatchUp(const SteeringInput& input,
                                          const CatchUpConfig& config) {
  Eigen::Isometry3d X_WF = input.X_WE;
  if (control_.dof == SteeringDof::kJoint7) {
    if (!input.q.allFinite()) throw InputError("steering input: joint angles must be finite");
    X_WF = CalcFlangePose(input.q);
  }
  const CatchUpReport report = sim_->CatchUp(input.p_WM, X_WF, config, input.bevel_angle);
  X_WN_step_ = sim_->X_WN();
  return report;
}

SteeringOutput SteeringController::Update(const SteeringInput& input) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  SteeringOutput out;
  Eigen::Isometry3d X_WF = input.X_WE;
  if (control_.dof == SteeringDof::kJoint7) {
    if (!input.q.allFinite()) throw InputError("steering input: joint angles must be finite");
    X_WF = CalcFlangePose(input.q);
  }
  out.model = sim_->Step(input.p_WM, X_WF, input.bevel_angle);
  out.num_unconverged_solves = out.model.solve.converged ? 0 : 1;
  X_WN_step_ = sim_->X_WN();
  const auto t1 = Clock::now();

  // entry point of e_e (eq. 3.5): the measured skin entry, else the liver's own
  if (input.entry.punctured) {
    if (!input.entry.p_WP.allFinite() || !input.entry.n_W.allFinite()) {
      throw InputError("steering input: entry point must be finite");
    }
    if (!entry_known_) entry_plane_ = MakeSkinPlane(input.entry.p_WP, input.entry.n_W);
    entry_known_ = true;
    p_WC_ = input.entry.p_WP;
  } else if (control_.liver_entry_objective) {
    Eigen::Vector3d p;
    if (sim_->CalcLiverEntryPoint(&p)) {
      if (!entry_known_) entry_plane_ = MakeSkinPlane(p, -sim_->path_direction());
      entry_known_ = true;
      p_WC_ = p;
    }
  }
  out.phase = DetermineInsertionPhase(input.entry.punctured, sim_->liver_punctured());
  if (out.phase == InsertionPhase::kInLiver && !entry_known_) {
    // no entry point known (no skin, liver entry objective off): e_e rows are zero
    entry_plane_ = MakeSkinPlane(sim_->X_WN().translation(), -sim_->path_direction());
  }

  // advance the path target with the model's tip: when the tip is within switch_distance of
  // it, or has passed it along the (deformed) path; without the second rule a lateral error
  // the needle cannot remove inside the tissue stalls the insertion at an intermediate point
  // (the unperturbed frozen-step solve, done once: it also gives e and the reported state)
  const SteeringEvaluation now = sim_->EvaluateAt(X_WF, workspace_);
  out.num_unconverged_solves += now.solve.converged ? 0 : 1;
  {
    const Eigen::Vector3d p_WTip = CalcSwitchingTip(input, X_WF, now.p_WTip);
    const int last = static_cast<int>(now.p_WPath.size()) - 1;
    auto passed = [&](int i) {
      const Eigen::Vector3d along = now.p_WPath[i + 1] - now.p_WPath[i];
      return (p_WTip - now.p_WPath[i]).dot(along) >= 0.0;
    };
    while (path_index_ < last &&
           ((now.p_WPath[path_index_] - p_WTip).norm() <= switch_distance_ ||
            passed(path_index_))) {
      ++path_index_;
    }
  }
  out.path_index = path_index_;
  out.reached_end = path_index_ == static_cast<int>(sim_->path().size()) - 1;

  // e_l's map for this step (the liver's lateral stiffness at the unperturbed needle)
  if (liver_load_ && out.phase == InsertionPhase::kInLiver) UpdateLoadMap();

  if (input.hold) {  // the model followed the markers; the robot stays where it is
    out.e = CalcObjectives(now, out.phase);
    out.e_expected = out.e;
    out.p_WTip = now.p_WTip;
    out.p_WTarget = now.p_WPath[path_index_];
    out.p_WFinal = now.p_WPath.back();
    out.valid = out.num_unconverged_solves == 0 && out.e.allFinite();
    out.X_WE_target = X_WF;
    out.q_target = input.q;
    out.timings.simulation = Seconds(t0, t1);
    out.timings.total = Seconds(t0, Clock::now());
    return out;
  }

  // Jacobian by central differences (eq. 3.6 / A.2)
  const auto t2 = Clock::now();
  const int n = control_.dof == SteeringDof::kCartesian6 ? 6 : 7;
  std::vector<Eigen::VectorXd> samples;
  samples.reserve(2 * n);
  Eigen::VectorXd steps(n);
  auto evaluate = [&](const Eigen::Isometry3d& X) {
    const SteeringEvaluation eval = sim_->EvaluateAt(X, workspace_);
    out.num_unconverged_solves += eval.solve.converged ? 0 : 1;
    return CalcObjectives(eval, out.phase);
  };
  if (control_.dof == SteeringDof::kCartesian6) {
    steps = control_.pose_steps;
    for (const Eigen::Isometry3d& X :
         MakePosePerturbations(X_WF, control_.pose_steps, control_.law.frame))
      samples.push_back(evaluate(X));
  } else {
    steps = control_.joint_steps;
    for (const Vector7d& q : MakeJointPerturbations(input.q, control_.joint_steps))
      samples.push_back(evaluate(CalcFlangePose(q)));
  }
  const bool converged = out.num_unconverged_solves == 0;
  out.num_perturbations = static_cast<int>(samples.size());
  const FiniteDifferenceStatus status = AssembleCentralDifferenceJacobian(samples, steps, &out.J);
  out.e = CalcObjectives(now, out.phase);
  const auto t3 = Clock::now();

  // nominal state for reports
  out.p_WTip = now.p_WTip;
  out.p_WTarget = now.p_WPath[path_index_];
  out.p_WFinal = now.p_WPath.back();

  Eigen::VectorXd k;
  ObjectiveGains gains = control_.gains;  // e_l's capped for the measured latency
  gains.load = LimitGainForDelay(gains.load, std::max(0, input.latency_steps), kLoadGainMargin);
  AssembleGainVector(out.phase, gains, &k, align_in_liver_, liver_load_);
  if (GetObjectiveLayout(out.phase, align_in_liver_, liver_load_).load_row >= 0)
    out.load_gain = gains.load;
  // the commands in flight: the error they will leave, and the base the new step adds to
  const bool in_flight = control_.compensate_in_flight &&
                         (control_.dof == SteeringDof::kCartesian6 ? input.X_WE_commanded.has_value()
                                                                  : input.q_commanded.has_value());
  out.e_expected = out.e;
  // only the part of the motion in flight that the objectives see (its projection J_r^+ J,
  // the regularized inverse's own): in a direction the Jacobian barely sees (the needle's roll,
  // lateral motion of a needle held by the tissue, the iiwa's null space) the command would
  // otherwise accumulate steps that the error never acknowledges (integral wind-up)
  auto seen = [&](const Eigen::VectorXd& in_flight_motion) -> Eigen::VectorXd {
    Eigen::MatrixXd J_r_plus;
    CalcTikhonovPseudoInverse(out.J, control_.law.regularization, &J_r_plus,
                              control_.law.tikhonov_form);
    return J_r_plus * (out.J * in_flight_motion);
  };
  if (control_.dof == SteeringDof::kCartesian6) {
    Eigen::Isometry3d base = X_WF;
    if (in_flight && IsFinitePose(*input.X_WE_commanded) && out.J.allFinite()) {
      const Vector6d motion =
          seen(CalcPoseDifference(*input.X_WE_commanded, X_WF, control_.law.frame));
      base = ApplyPoseIncrement(X_WF, motion, control_.law.frame);
      out.e_expected += out.J * motion;
    }
    const CartesianControlOutput law =
        CalcCartesianTarget(base, out.J, out.e_expected, k, control_.law);
    out.valid = law.valid && status.all_finite && converged;
    out.X_WE_target = out.valid ? law.X_WE_target : X_WF;
    if (out.valid) {
      out.insertion_limited =
          LimitAdvance(out.phase, base, out.p_WTip, out.p_WFinal, &out.X_WE_target);
      out.tilt_limited = LimitNeedleTilt(needle_axis_F_, sim_->path_direction(),
                                         TiltPivot(out.X_WE_target), control_.max_needle_tilt,
                                         &out.X_WE_target);
    }
    out.step_limited = law.step_limited;
    out.q_target = input.q;
  } else {
    Vector7d base = input.q;
    if (in_flight && input.q_commanded->allFinite() && out.J.allFinite()) {
      const Vector7d motion = seen(*input.q_commanded - input.q);
      base = input.q + motion;
      out.e_expected += out.J * motion;
    }
    const JointControlOutput law = CalcJointTarget(base, out.J, out.e_expected, k, control_.law);
    out.valid = law.valid && status.all_finite && converged;
    // the flange no faster than the Cartesian law may move it (max_translation_step and
    // max_rotation_step per step), whatever the joint step's cap allows
    Vector7d q_target = base + LimitFlangeMotion(base, law.q_target - base, &out.step_limited);
    out.step_limited = out.step_limited || law.step_limited;
    if (out.valid && control_.null_space_gain > 0) {
      out.null_space_step = CalcNullSpaceStep(q_target);
      q_target += out.null_space_step;
    }
    if (out.valid) {
      Eigen::Isometry3d X = CalcFlangePose(q_target);
      out.insertion_limited =
          LimitAdvance(out.phase, CalcFlangePose(base), out.p_WTip, out.p_WFinal, &X);
      out.tilt_limited = LimitNeedleTilt(needle_axis_F_, sim_->path_direction(), TiltPivot(X),
                                         control_.max_needle_tilt, &X);
      if (out.insertion_limited || out.tilt_limited) q_target = flange_ik_.Solve(X, q_target).q;
    }
    out.q_target = out.valid ? ClampWithMargin(q_target) : input.q;
    out.X_WE_target = CalcFlangePose(out.q_target);
  }
  const auto t4 = Clock::now();
  out.timings.simulation = Seconds(t0, t1);
  out.timings.jacobian = Seconds(t2, t3);
  out.timings.control = Seconds(t3, t4);
  out.timings.total = Seconds(t0, t4);
  return out;
}

Eigen::Vector3d SteeringController::CalcSwitchingTip(const SteeringInput& input,
                                                    const Eigen::Isometry3d& X_WF,
                                                    const Eigen::Vector3d& p_WTip) const {
  if (advance_ != PathAdvance::kCommanded || !control_.compensate_in_flight) return p_WTip;
  Eigen::Isometry3d X_WF_commanded;
  if (control_.dof == SteeringDof::kCartesian6) {
    if (!input.X_WE_commanded.has_value() || !IsFinitePose(*input.X_WE_commanded)) return p_WTip;
    X_WF_commanded = *input.X_WE_commanded;
  } else {
    if (!input.q_commanded.has_value() || !input.q_commanded->allFinite()) return p_WTip;
    X_WF_commanded = CalcFlangePose(*input.q_commanded);
  }
  // the tip carried rigidly with the flange: the along-path progress of the command
  return X_WF_commanded * (X_WF.inverse() * p_WTip);
}

Vector7d SteeringController::LimitFlangeMotion(const Vector7d& q, const Vector7d& dq,
                                               bool* limited) const {
  *limited = false;
  if (!dq.allFinite() || !q.allFinite()) return dq;
  Iiwa14Kinematics kinematics;
  iiwa_.CalcForwardKinematics(q, &kinematics);
  Jacobian67 J_F;
  iiwa_.CalcToolJacobian(kinematics, &J_F);  // the tool is the flange (MakeFlangeIiwaConfig)
  const Vector6d twist = J_F * dq;
  const double translation = twist.head<3>().norm(), rotation = twist.tail<3>().norm();
  const double scale = std::min({1.0, control_.law.max_translation_step / translation,
                                 control_.law.max_rotation_step / rotation});
  if (!(scale < 1.0)) return dq;
  *limited = true;
  return scale * dq;
}

Eigen::MatrixXd SteeringController::CalcNeedleMotionRows(const Eigen::Isometry3d& X_WF) const {
  // the needle's base point and axis in W; a twist [v_F; w] of the flange (v_F at its origin)
  // moves the base point by v_F + w x (p_B - p_F)
  const Eigen::Vector3d p_B = X_WF * needle_p_FBase_;
  const Eigen::Vector3d a = X_WF.linear() * needle_axis_F_.normalized();
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(roll_free_ ? 5 : 6, 6);
  M.block<3, 3>(0, 0).setIdentity();
  M.block<3, 3>(0, 3) = -Skew(p_B - X_WF.translation());
  if (!roll_free_) {
    M.block<3, 3>(3, 3).setIdentity();
  } else {
    // the turn about the two directions across the needle; its roll is free
    Eigen::Vector3d t1, t2;
    CalcTangentBasis(a, t1, t2);
    M.block<1, 3>(3, 3) = t1.transpose();
    M.block<1, 3>(4, 3) = t2.transpose();
  }
  return M;
}

Vector7d SteeringController::CalcNullSpaceStep(const Vector7d& q) const {
  if (!q.allFinite()) return Vector7d::Zero();
  Iiwa14Kinematics kinematics;
  iiwa_.CalcForwardKinematics(q, &kinematics);
  Jacobian67 J_F;
  iiwa_.CalcToolJacobian(kinematics, &J_F);  // the tool is the flange (MakeFlangeIiwaConfig)
  const Eigen::Isometry3d X_before = kinematics.X_WT;
  const Eigen::MatrixXd M = CalcNeedleMotionRows(X_before);
  const Eigen::MatrixXd J_N = M * J_F;  // the needle's motion: its base point and direction
  // the projector on J_N's null space: the arm's self-motion and, without a bevel, the roll
  // about the needle's own axis (neither moves a point of the needle to first order); its
  // significant singular values only, as near a singularity
  constexpr double kRankTolerance = 1e-3;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J_N, Eigen::ComputeFullV);
  const Eigen::VectorXd& sigma = svd.singularValues();
  Eigen::Matrix<double, 7, 7> N = Eigen::Matrix<double, 7, 7>::Identity();
  for (int i = 0; i < sigma.size(); ++i)
    if (sigma[i] > kRankTolerance * sigma[0])
      N -= svd.matrixV().col(i) * svd.matrixV().col(i).transpose();
  Vector7d step = N * (-control_.null_space_gain * (q - iiwa_.CalcMidRange()));
  const double largest = step.cwiseAbs().maxCoeff();
  if (!std::isfinite(largest)) return Vector7d::Zero();
  if (largest > control_.law.max_joint_step) step *= control_.law.max_joint_step / largest;
  // second order: a finite step along the null space still moves the needle by O(|step|^2)
  // (0.1 mm for 0.01 rad a joint), which the law would have to correct every step; one Newton
  // step on the needle's pose takes it back (to third order)
  const Eigen::Isometry3d X_after = iiwa_.CalcToolPose(q + step);
  Vector6d drift;
  drift.head<3>() = X_after.translation() - X_before.translation();
  drift.tail<3>() = LogSO3(X_after.linear() * X_before.linear().transpose());
  const Eigen::VectorXd needle_drift = M * drift;
  const Eigen::MatrixXd JJt = J_N * J_N.transpose();
  const Vector7d correction = J_N.transpose() * JJt.ldlt().solve(needle_drift);
  const Vector7d corrected = step - correction;
  return corrected.allFinite() ? corrected : Vector7d::Zero();
}

void SteeringController::UpdateLoadMap() {
  load_map_.setZero();
  const Eigen::Matrix3d K = sim_->CalcNeedleTranslationStiffness(workspace_);
  Eigen::Vector3d t1, t2;
  CalcTangentBasis(X_WN_step_.linear().col(2).normalized(), t1, t2);
  Eigen::Matrix<double, 3, 2> T;
  T << t1, t2;
  const Eigen::Matrix2d K_t = T.transpose() * K * T;
  // a translation dp across the needle changes the force by -K dp: e_l = K_t^-1 T^T F is the
  // displacement across the needle that removes the lateral force (only a well-posed K_t)
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(K_t);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues()[0] > 1e-6 * eig.eigenvalues()[1]) ||
      !(eig.eigenvalues()[1] > 0.0))
    return;
  load_map_ = control_.liver_load * K_t.inverse() * T.transpose();
}

bool SteeringController::LimitAdvance(InsertionPhase phase, const Eigen::Isometry3d& X_WF_base,
                                      const Eigen::Vector3d& p_WTip,
                                      const Eigen::Vector3d& p_WFinal,
                                      Eigen::Isometry3d* X_WF_target) const {
  if (phase != InsertionPhase::kInLiver) return false;
  double bound = control_.max_insertion_step;
  std::optional<NeedleTissueCoupling::TipStretch> stretch;
  if (control_.free_stretch_step > 0.0) stretch = sim_->CalcLiverTipStretch();
  if (stretch && stretch->free_reach > 0.0) {
    // the last free stretch before the target: past it the tip reaches the target held, over
    // more than a stretch's length, with no point seeded on the way, or one seeded within half
    // a stretch's length before the target (that point would tie the target's tissue to the
    // needle line: the stretch it starts is too short to correct anything)
    const Eigen::Vector3d z = (X_WF_base.linear() * needle_axis_F_).normalized();
    const Eigen::Vector3d e = p_WFinal - p_WTip;
    const double ahead = z.dot(e);
    const bool last_free =
        ahead - stretch->free_reach > stretch->free_length &&
        ahead < stretch->next_seed + kSeedBeforeTargetMargin * stretch->free_length;
    if (last_free && (e - z * ahead).norm() > control_.free_stretch_tolerance)
      bound =
          bound > 0.0 ? std::min(bound, control_.free_stretch_step) : control_.free_stretch_step;
  }
  return bound > 0.0 &&
         LimitNeedleAdvance(needle_axis_F_, needle_p_FBase_, X_WF_base, bound, X_WF_target);
}

Eigen::Vector3d SteeringController::TiltPivot(const Eigen::Isometry3d& X_WF) const {
  return entry_known_ ? p_WC_ : Eigen::Vector3d(X_WF.translation());
}

Vector7d SteeringController::ClampWithMargin(const Vector7d& q) const {
  const Iiwa14Config& c = iiwa_.config();
  const Vector7d m = Vector7d::Constant(control_.joint_limit_margin);
  return q.cwiseMax(c.position_lower + m).cwiseMin(c.position_upper - m);
}

}  // namespace nsim
