#include "common/prediction/pca_buffer.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "common/core/error.h"

namespace nsim {

PcaBuffer::PcaBuffer(int capacity) {
  NSIM_CHECK(capacity >= 2, "PCA buffer capacity must be >= 2, got ", capacity);
  p_.setZero(3, capacity);
  t_.setZero(capacity);
}

void PcaBuffer::Push(double t, const Eigen::Vector3d& p) {
  t_[head_] = t;
  p_.col(head_) = p;
  head_ = head_ + 1 == capacity() ? 0 : head_ + 1;
  if (size_ < capacity()) ++size_;
}

void PcaBuffer::Clear() {
  head_ = 0;
  size_ = 0;
}

void PcaBuffer::CalcPrincipalAxes(PrincipalAxes* axes) const {
  NSIM_CHECK(size_ >= 2, "principal axes need >= 2 samples, got ", size_);
  // mean, then the scatter of the centred samples (accumulated relative to the mean: no
  // cancellation for markers far from the origin)
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i = 0; i < size_; ++i) mean += p_.col(Index(i));
  mean /= size_;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (int i = 0; i < size_; ++i) {
    const Eigen::Vector3d d = p_.col(Index(i)) - mean;
    scatter.noalias() += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);  // ascending eigenvalues
  axes->mean = mean;
  for (int c = 0; c < 3; ++c) {
    Eigen::Vector3d v = eig.eigenvectors().col(2 - c);
    int k = 0;
    for (int j = 1; j < 3; ++j) {
      if (std::abs(v[j]) > std::abs(v[k])) k = j;
    }
    if (v[k] < 0) v = -v;
    axes->directions.col(c) = v;
    axes->singular_values[c] = std::sqrt(std::max(eig.eigenvalues()[2 - c], 0.0));
  }
}

}  // namespace nsim
