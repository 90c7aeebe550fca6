#pragma once
// The bound on the needle's advance per control step: how far a commanded flange pose moves the
// needle along its own axis.
//
// Why: the path target leads the tip by up to control.path.switch_distance plus a spacing, so
// with the gain k the law advances the needle k * lead per step, up to the translation cap
// (0.001 m, 50 mm/s): the rigid needle crosses the liver in about 1.5 s. The tip can be moved
// across its tissue only in the first quarter of each trajectory-point spacing (the coupling's
// free stretch, common/needle/needle_tissue.h); at that speed the stretch lasts a few steps, and
// a lateral error left when it ends is carried to the target (README, "Where the target falls
// between the trajectory points"). A slower advance gives the lateral correction those steps.
// Everywhere in the liver (controller.max_insertion_step) it costs more than it gives: at 10 mm/s
// both livers are dragged through a breathing cycle by the half-inserted needle and the
// registration fails (docs/control.md, "Two remedies that are not"); that bound is off by
// default, kept to study the insertion speed. In the last free stretch before a target the tip
// would reach held (controller.free_stretch_step, SteeringController::LimitAdvance) it is on by
// default: that one stretch is where the lateral error the target sees is last corrected.
//
// Only the forward part along the needle is bounded: retraction, the motion across the needle
// and the turn are returned unchanged, so breathing is followed as before.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace nsim {

/// The advance (m) along the needle from flange pose X_WF_from to X_WF_to: the motion of the
/// needle point p_F (flange frame) projected on the needle's axis at X_WF_from (axis_F in the
/// flange frame, need not be unit). Positive: forward, along the axis.
double CalcNeedleAdvance(const Eigen::Vector3d& axis_F, const Eigen::Vector3d& p_F,
                         const Eigen::Isometry3d& X_WF_from, const Eigen::Isometry3d& X_WF_to);

/// Moves *X_WF_to back along the needle axis (at X_WF_from) so that its advance is at most
/// max_advance (m, > 0); returns whether it moved it. Within the bound, and for non-finite
/// input or max_advance <= 0, the pose is returned unchanged (bit for bit).
bool LimitNeedleAdvance(const Eigen::Vector3d& axis_F, const Eigen::Vector3d& p_F,
                        const Eigen::Isometry3d& X_WF_from, double max_advance,
                        Eigen::Isometry3d* X_WF_to);

}  // namespace nsim
