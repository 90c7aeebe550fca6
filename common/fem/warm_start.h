#pragma once
// The initial guess of the free-motion PCG solve. FemSolver predicts the free motion's end
// velocity u = v + dv_free of the next step by extrapolating its changes from step to step
// (the constant, the line or the parabola through the last one, two or three changes, of the
// order that would have predicted the latest change best) and starts from u - v, where v
// already carries the constraints' last correction: a contact's impulse, which the free motion
// of the stiff modes undoes, is not extrapolated. Without corrections (v = the last u) that is
// the same as extrapolating dv_free itself. On smooth motion (breathing) the parabola wins, by
// 10x over the line once transients have died out; at a start from rest or in an oscillation
// from step to step the lower orders do (docs/performance.md, "The warm start").

#include <Eigen/Core>

namespace nsim {

/// The order's extrapolation of the next value from the last three, dv1 (newest), dv2, dv3.
template <typename A, typename B, typename C>
auto ExtrapolateWarmStart(int order, const A& dv1, const B& dv2, const C& dv3) {
  using Result = decltype((3.0 * (dv1 - dv2) + dv3).eval());
  if (order >= 3) return Result(3.0 * (dv1 - dv2) + dv3);
  if (order == 2) return Result(2.0 * dv1 - dv2);
  return Result(dv1);
}

/// Squared prediction errors of the three orders for the value dv given the three before it,
/// accumulated over a set of columns (Add once per node, then ChooseOrder).
struct WarmStartErrors {
  double constant = 0.0, line = 0.0, parabola = 0.0;

  template <typename V, typename A, typename B, typename C>
  void Add(const V& dv, const A& dv1, const B& dv2, const C& dv3) {
    constant += (dv - dv1).squaredNorm();
    line += (dv - 2.0 * dv1 + dv2).squaredNorm();
    parabola += (dv - 3.0 * (dv1 - dv2) - dv3).squaredNorm();
  }

  /// The order (1, 2 or 3) with the smallest error; ties go to the higher order.
  int ChooseOrder() const {
    if (parabola <= line && parabola <= constant) return 3;
    return line <= constant ? 2 : 1;
  }
};

}  // namespace nsim
