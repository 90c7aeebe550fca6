#include "common/fem/single_precision_factor.h"

#include <Eigen/Dense>
#include <algorithm>

#include "common/core/error.h"
#include "common/fem/supernodal_solve.h"
#include "common/fem/worker_gate.h"

namespace nsim {

void SinglePrecisionFactor::Assign(const SupernodalFactorView& view) {
  NSIM_CHECK(view.n > 0 && view.nsuper > 0 && view.super && view.pi && view.px && view.s &&
                 view.x && view.perm,
             "SinglePrecisionFactor::Assign needs a supernodal factor");
  n_ = view.n;
  super_.assign(view.super, view.super + view.nsuper + 1);
  pi_.assign(view.pi, view.pi + view.nsuper + 1);
  px_.assign(view.px, view.px + view.nsuper + 1);
  s_.assign(view.s, view.s + pi_.back());
  perm_.assign(view.perm, view.perm + n_);
  NSIM_CHECK(super_.front() == 0 && super_.back() == n_, "the supernodes cover columns ",
             super_.front(), " to ", super_.back(), " of ", n_);
  values_.resize(static_cast<size_t>(px_.back()));
  // in chunks, each a safe point for a background refresh's gate (common/fem/worker_gate.h)
  constexpr size_t kChunk = size_t{1} << 16;
  for (size_t begin = 0; begin < values_.size(); begin += kChunk) {
    PassWorkerGate();
    const size_t end = std::min(values_.size(), begin + kChunk);
    std::transform(view.x + begin, view.x + end, values_.begin() + static_cast<std::ptrdiff_t>(begin),
                   [](double v) { return static_cast<float>(v); });
  }
  int max_below = 0;
  for (size_t j = 0; j + 1 < super_.size(); ++j)
    max_below = std::max(max_below, (pi_[j + 1] - pi_[j]) - (super_[j + 1] - super_[j]));
  y_.resize(n_);
  gathered_.resize(max_below);
}

void SinglePrecisionFactor::Solve(const Eigen::Ref<const Eigen::VectorXd>& b,
                                  Eigen::Ref<Eigen::VectorXd> x) {
  NSIM_CHECK(n_ > 0, "SinglePrecisionFactor::Solve without a factor");
  NSIM_CHECK(b.size() == n_ && x.size() == n_, "SinglePrecisionFactor::Solve size mismatch: n = ",
             n_, ", b ", b.size(), ", x ", x.size());
  for (int k = 0; k < n_; ++k) y_[k] = static_cast<float>(b[perm_[k]]);
  SupernodalFactorView view;
  view.n = n_;
  view.nsuper = static_cast<int>(super_.size()) - 1;
  view.super = super_.data();
  view.pi = pi_.data();
  view.px = px_.data();
  view.s = s_.data();
  SupernodalSolveInPlace(view, values_.data(), y_, gathered_);
  for (int k = 0; k < n_; ++k) x[perm_[k]] = static_cast<double>(y_[k]);
}

}  // namespace nsim
