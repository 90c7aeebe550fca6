#pragma once
// Discrete-time velocity and acceleration limiting shared by the Cartesian and joint
// interpolators. Motion model of one step of length dt: v' = v + dv with |dv| <= a_max dt and
// |v'| <= v_max, then x' = x + v' dt (semi-implicit Euler), so the position never jumps.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace nsim {

/// Largest speed (m/s or rad/s) from which a body that changes its speed by at most a_max dt
/// per step (the model above) can come to rest exactly at `distance` (m or rad) ahead. In units
/// of a_max dt and a_max dt^2, with x = distance / (a_max dt^2): the fastest profile is
/// n + c, n - 1 + c, ..., c, 0 with n(n+1)/2 <= x < (n+1)(n+2)/2 and c = (x - n(n+1)/2) / (n+1)
/// in [0, 1), so the speed is a_max dt (n + c). It is consistent from step to step (after one
/// step at this speed the next one is exactly a_max dt lower), and below one step of braking
/// (x < 1) it is distance / dt: the body lands on the target and stops in the next step.
/// Preconditions: distance >= 0, a_max > 0, dt > 0.
inline double CalcBrakingSpeed(double distance, double max_acceleration, double dt) {
  const double adt = max_acceleration * dt;
  const double x = distance / (adt * dt);
  double n = std::floor(0.5 * (std::sqrt(1.0 + 8.0 * x) - 1.0));
  // guard the floor against rounding of the square root
  if (n > 0.0 && 0.5 * n * (n + 1.0) > x) n -= 1.0;
  if (0.5 * (n + 1.0) * (n + 2.0) <= x) n += 1.0;
  const double c = (x - 0.5 * n * (n + 1.0)) / (n + 1.0);
  return adt * (n + c);
}

/// One step of the velocity of a point in R^N (N = 1 joint, N = 3 position or rotation vector)
/// that heads for `error` = target - current under the limits: the desired velocity points along
/// the error with speed min(v_max, CalcBrakingSpeed(|error|)), so the point stops exactly on a
/// fixed target without overshoot when its velocity is aligned with the error (e.g. from rest);
/// the change of velocity is then clamped to a_max dt. Keeps |v| <= v_max when the
/// incoming |v| <= v_max (the new velocity lies on the segment between v and the desired one).
/// Returns true if the acceleration limit was active. No allocation.
template <int N>
bool StepVelocityTowards(const Eigen::Matrix<double, N, 1>& error, double max_speed,
                         double max_acceleration, double dt,
                         Eigen::Matrix<double, N, 1>* velocity) {
  const double distance = error.norm();
  Eigen::Matrix<double, N, 1> desired = Eigen::Matrix<double, N, 1>::Zero();
  if (distance > 0.0) {
    const double speed = std::min(max_speed, CalcBrakingSpeed(distance, max_acceleration, dt));
    desired = error * (speed / distance);
  }
  Eigen::Matrix<double, N, 1> change = desired - *velocity;
  const double max_change = max_acceleration * dt;
  const double change_norm = change.norm();
  const bool limited = change_norm > max_change;
  if (limited) change *= max_change / change_norm;
  *velocity += change;
  return limited;
}

/// One step of braking to rest: reduces |v| by at most a_max dt along -v. No allocation.
template <int N>
void StepVelocityToRest(double max_acceleration, double dt, Eigen::Matrix<double, N, 1>* velocity) {
  const double speed = velocity->norm();
  const double max_change = max_acceleration * dt;
  if (speed <= max_change) {
    velocity->setZero();
  } else {
    *velocity *= (speed - max_change) / speed;
  }
}

}  // namespace nsim
