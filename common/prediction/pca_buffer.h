#pragma once
// Rolling buffer of one marker's 3D positions and their principal axes (thesis §4.1.1, fig. 4.1,
// eq. 4.1).

#include <Eigen/Core>

namespace nsim {

/// Principal axes of a set of 3D positions: the SVD X = U S V^T of the centred 3 x n buffer
/// (thesis eq. 4.1). The thesis names the directions "columns of V"; for a 3 x n buffer the
/// directions in R^3 are the left singular vectors U, computed here as the eigenvectors of the
/// 3 x 3 scatter X X^T (same vectors, singular values = sqrt of its eigenvalues).
struct PrincipalAxes {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();  ///< buffer mean (m)
  /// Unit directions D1, D2, D3 as columns, by decreasing singular value. Sign convention: the
  /// largest-magnitude component of each column is positive (the first one on exact ties), so
  /// an SI-dominant motion along world z gives D1 ~ +z whatever the data order.
  Eigen::Matrix3d directions = Eigen::Matrix3d::Identity();
  Eigen::Vector3d singular_values = Eigen::Vector3d::Zero();  ///< s1 >= s2 >= s3 (m sqrt(#samples))

  /// First principal component of p: D1 . (p - mean) (m).
  double Project(const Eigen::Vector3d& p) const { return directions.col(0).dot(p - mean); }
  /// Reprojection to 3D (thesis eq. 4.4, with the mean added back): mean + pc D1 (m).
  Eigen::Vector3d Reproject(double pc) const { return mean + pc * directions.col(0); }
};

/// Ring buffer of the last `capacity` (WP) samples (t, p) of one marker. Preallocated; Push and
/// CalcPrincipalAxes never allocate.
class PcaBuffer {
 public:
  /// capacity = WP (samples), >= 2 (checked).
  explicit PcaBuffer(int capacity);

  /// Appends a sample, dropping the oldest when full. O(1). t (s), p (m); the caller ensures
  /// finite values and increasing t.
  void Push(double t, const Eigen::Vector3d& p);
  void Clear();

  int size() const { return size_; }
  int capacity() const { return static_cast<int>(t_.size()); }
  bool full() const { return size_ == capacity(); }

  /// Time of the i-th stored sample, i = 0 the oldest, size()-1 the newest (s).
  double time(int i) const { return t_[Index(i)]; }
  /// Position of the i-th stored sample (m).
  Eigen::Vector3d position(int i) const { return p_.col(Index(i)); }
  double newest_time() const { return time(size_ - 1); }
  Eigen::Vector3d newest_position() const { return position(size_ - 1); }

  /// Principal axes of the stored samples (eq. 4.1). Precondition: size() >= 2. O(size()).
  void CalcPrincipalAxes(PrincipalAxes* axes) const;

 private:
  int Index(int i) const {
    const int k = head_ - size_ + i;
    return k < 0 ? k + capacity() : k;
  }
  Eigen::Matrix<double, 3, Eigen::Dynamic> p_;  // 3 x WP (m)
  Eigen::VectorXd t_;                           // WP (s)
  int head_ = 0;                                // slot of the next write
  int size_ = 0;
};

}  // namespace nsim
