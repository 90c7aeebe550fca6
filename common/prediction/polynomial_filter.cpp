#include "common/prediction/polynomial_filter.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace nsim {
namespace {

constexpr int kMaxTerms = kMaxPolynomialOrder + 1;
using Gram =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxTerms, kMaxTerms>;
using Terms = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxTerms, 1>;

void CheckOrder(int order, int n) {
  if (order < 1 || order > kMaxPolynomialOrder)
    throw InputError(
        Str("polynomial order must be in [1, ", kMaxPolynomialOrder, "], got ", order));
  if (n < order + 1)
    throw InputError(Str("a polynomial fit of order ", order,
                         " needs at least order+1 = ", order + 1, " samples, got ", n));
}

}  // namespace

double ExtrapolatePolynomial(const double* t, const double* y, int n, int order, double t_eval) {
  CheckOrder(order, n);
  const double t_ref = t[n - 1];
  const double span = t_ref - t[0];
  if (!(span > 0))
    throw InputError(Str("polynomial fit: sample times must increase, got span ", span));
  const int m = order + 1;
  // normal equations in tau = (t - t_ref) / span in [-1, 0]: sum_i phi_i phi_i^T x = sum_i phi_i
  // y_i with phi = (1, tau, tau^2, ...); the Gram matrix is Hankel in the power sums
  double power_sum[2 * kMaxTerms - 1] = {};
  Terms rhs = Terms::Zero(m);
  for (int i = 0; i < n; ++i) {
    const double tau = (t[i] - t_ref) / span;
    double power = 1.0;
    for (int k = 0; k < 2 * m - 1; ++k) {
      power_sum[k] += power;
      if (k < m) rhs[k] += power * y[i];
      power *= tau;
    }
  }
  Gram gram(m, m);
  for (int r = 0; r < m; ++r) {
    for (int c = 0; c < m; ++c) gram(r, c) = power_sum[r + c];
  }
  const Terms x = gram.ldlt().solve(rhs);
  // evaluate at tau_eval with Horner's rule
  const double tau_eval = (t_eval - t_ref) / span;
  double value = 0.0;
  for (int k = m - 1; k >= 0; --k) value = value * tau_eval + x[k];
  return value;
}

double WindowCost(const double* t, const double* y, int n, int order, int window, int lead) {
  CheckOrder(order, window);
  if (lead < 1) throw InputError(Str("window cost lead must be >= 1 sample, got ", lead));
  const int terms = n - window - lead + 1;
  if (terms < 1)
    throw InputError(Str("window cost: a buffer of ", n, " samples is too short for window ",
                         window, " and lead ", lead));
  double cost = 0.0;
  for (int c = 0; c < terms; ++c) {
    const int target = c + window - 1 + lead;
    const double e = ExtrapolatePolynomial(t + c, y + c, window, order, t[target]) - y[target];
    cost += e * e;
  }
  return cost / terms;
}

IntSearchResult SearchWindow(const double* t, const double* y, int n, int order, int window_min,
                             int window_max, int lead) {
  CheckOrder(order, window_min);
  if (window_max < window_min)
    throw InputError(Str("window search: empty range [", window_min, ", ", window_max, "]"));
  if (lead < 1) throw InputError(Str("window search lead must be >= 1 sample, got ", lead));
  // the widest window must leave at least one cost term
  if (n < window_max + lead)
    throw InputError(Str("window search: a buffer of ", n, " samples is too short for window ",
                         window_max, " and lead ", lead));
  return GoldenSectionSearchInt(
      window_min, window_max, [&](int window) { return WindowCost(t, y, n, order, window, lead); });
}

}  // namespace nsim
