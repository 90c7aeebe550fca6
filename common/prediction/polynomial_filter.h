#pragma once
// Polynomial least-squares prediction of a scalar signal (the thesis's linear filter, LF, §4.1.1-
// 4.1.2, eq. 4.2-4.6), its one-step cost over a buffer (Algorithm 1) and the integer golden-section
// search of the regression window WF (§4.1.4, eq. 4.11-4.18).

#include <array>
#include <cmath>
#include <limits>

#include "common/core/error.h"

namespace nsim {

/// Highest polynomial order the filters support.
constexpr int kMaxPolynomialOrder = 3;

/// Fits a polynomial of `order` (1: eq. 4.2, 2: eq. 4.5, up to kMaxPolynomialOrder) to the n
/// samples (t_i, y_i) by least squares and evaluates it at t_eval (eq. 4.3 / 4.6). For
/// conditioning, time enters as tau = (t - t_{n-1}) / (t_{n-1} - t_0), relative to the newest
/// sample. Units of y are the caller's; t and t_eval share a unit. Throws InputError if
/// n < order + 1, order is out of range or the times span zero. No allocation.
double ExtrapolatePolynomial(const double* t, const double* y, int n, int order, double t_eval);

/// Algorithm 1 (thesis §4.1.4): the mean squared prediction error of the order-`order` filter
/// with regression window `window` over a buffer of n samples. Every run of `window`
/// consecutive samples predicts the sample `lead` steps after its newest one (lead = 1 is the
/// thesis's one-step cost); the N = n - window - lead + 1 errors are averaged. Units: y^2.
/// Throws InputError if window < order + 1 or N < 1.
double WindowCost(const double* t, const double* y, int n, int order, int window, int lead);

/// Result of an integer search.
struct IntSearchResult {
  int x = 0;            ///< argmin found
  double cost = 0.0;    ///< its cost
  int evaluations = 0;  ///< distinct cost evaluations
};

/// Golden-section search for a minimum of cost(x) over the integers [lo, hi] (thesis §4.1.4).
/// Interior points p2 < p3 split [p1, p4] in the golden ratio and are rounded to integers; if
/// C(p2) < C(p3) the minimum is kept in [p1, p3], else in [p2, p4] (eq. 4.13-4.16; the thesis's
/// eq. 4.11/4.12 write p2 and p3 the other way round, which contradicts its own cases; this
/// follows the cases). When the bracket is <= 3 wide, every integer left in it is evaluated.
/// Costs are memoized; the best evaluated point is returned (ties: the smaller x). Finds the
/// minimum of a unimodal cost; NaN costs count as +inf. `cost` is any callable int -> double.
template <typename Cost>
IntSearchResult GoldenSectionSearchInt(int lo, int hi, Cost&& cost) {
  NSIM_CHECK(lo <= hi, "empty search range [", lo, ", ", hi, "]");
  constexpr double kInvPhi = 0.61803398874989484820;  // 1 / phi, phi = (sqrt 5 + 1) / 2
  constexpr int kMemo = 128;
  std::array<int, kMemo> memo_x{};
  std::array<double, kMemo> memo_c{};
  int memo_n = 0;
  IntSearchResult best;
  best.x = lo;
  best.cost = std::numeric_limits<double>::infinity();
  auto eval = [&](int x) {
    for (int i = 0; i < memo_n; ++i) {
      if (memo_x[i] == x) return memo_c[i];
    }
    double c = cost(x);
    if (std::isnan(c)) c = std::numeric_limits<double>::infinity();
    ++best.evaluations;
    if (memo_n < kMemo) {
      memo_x[memo_n] = x;
      memo_c[memo_n] = c;
      ++memo_n;
    }
    if (c < best.cost || (c == best.cost && x < best.x)) {
      best.x = x;
      best.cost = c;
    }
    return c;
  };
  int p1 = lo, p4 = hi;
  while (p4 - p1 > 3) {
    const double length = p4 - p1;
    const int p2 = static_cast<int>(std::lround(p4 - length * kInvPhi));
    int p3 = static_cast<int>(std::lround(p1 + length * kInvPhi));
    if (p3 <= p2) p3 = p2 + 1;
    if (eval(p2) < eval(p3)) {
      p4 = p3;  // eq. 4.13-4.14: the minimum lies left of p3
    } else {
      p1 = p2;  // eq. 4.15-4.16: the minimum lies right of p2 (or at p2, already evaluated)
    }
  }
  for (int x = p1; x <= p4; ++x) eval(x);
  return best;
}

/// WF by golden-section search of WindowCost over [window_min, window_max] (inclusive).
/// Returns the window and its cost. Throws InputError like WindowCost for invalid bounds.
IntSearchResult SearchWindow(const double* t, const double* y, int n, int order, int window_min,
                             int window_max, int lead);

}  // namespace nsim
