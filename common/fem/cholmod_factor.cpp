#include "common/fem/cholmod_factor.h"

#include <cholmod.h>
#include <omp.h>

#include "common/core/error.h"
#include "common/fem/supernodal_solve.h"

namespace nsim {

struct CholmodFactor::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  int n = 0;
  // Solve's workspace (supernodal_solve.h): the permuted columns, grown as needed
  Eigen::VectorXd y_perm;
  Eigen::VectorXd gathered;

  Impl() {
    cholmod_start(&common);
    common.supernodal = CHOLMOD_SUPERNODAL;
    common.final_asis = 1;  // keep the supernodal LL' form
    // fill-reducing ordering: the one of AMD and METIS (nested dissection) with the fewest
    // nonzeros in L. CHOLMOD's default (nmethods = 0) tries METIS only when AMD's fill looks high
    // (flops / nnz(L) >= 500), which the 2660-node liver just misses (489): there METIS gives
    // 13 % fewer nonzeros and a third fewer flops (1.53 M against 1.75 M, 0.57 against 0.86
    // GFlop), so smaller solves and faster refreshes. method[0] is a given permutation (none).
    common.nmethods = 3;
    common.print = 0;
    common.error_handler = nullptr;
  }
  ~Impl() {
    if (factor) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
};

namespace {

// view of an Eigen compressed matrix as a symmetric CHOLMOD matrix (upper triangle read), no copy
cholmod_sparse View(const Eigen::SparseMatrix<double>& A) {
  NSIM_CHECK(A.isCompressed(), "CHOLMOD needs a compressed matrix");
  NSIM_CHECK(A.rows() == A.cols(), "CHOLMOD needs a square matrix, got ", A.rows(), " x ",
             A.cols());
  cholmod_sparse s{};
  s.nrow = static_cast<size_t>(A.rows());
  s.ncol = static_cast<size_t>(A.cols());
  s.nzmax = static_cast<size_t>(A.nonZeros());
  s.p = const_cast<int*>(A.outerIndexPtr());
  s.i = const_cast<int*>(A.innerIndexPtr());
  s.x = const_cast<double*>(A.valuePtr());
  s.stype = 1;
  s.itype = CHOLMOD_INT;
  s.xtype = CHOLMOD_REAL;
  s.dtype = CHOLMOD_DOUBLE;
  s.sorted = 1;
  s.packed = 1;
  return s;
}

// CHOLMOD's supernodal factorization (SuiteSparse 5.x) opens OpenMP regions with a fixed
// num_threads(4) clause (its memory loops: clearing the Map and each supernode), which
// OMP_NUM_THREADS does not override. On a two-core machine that is four threads meeting at a
// barrier per supernode: measured on the 2660-node liver, a factorization took 241 ms of wall
// clock for 154 ms of CPU (futex wake-ups, ~16 000 context switches a second), and its
// threads took the core a step runs on. The simulators and scripts also set OMP_THREAD_LIMIT=1
// (common/core/library_threads.h); this guard holds without that environment (benchmarks run
// by hand, tests, other programs linking the library). The calling thread's max-active-levels ICV set to 0
// makes every region it opens run on itself alone (OpenMP 5.1, 2.6.1); the loops only clear
// and scatter entries, so the factor is the same to the bit. Restored on return.
class SerialOpenMp {
 public:
  SerialOpenMp() : levels_(omp_get_max_active_levels()) { omp_set_max_active_levels(0); }
  ~SerialOpenMp() { omp_set_max_active_levels(levels_); }
  SerialOpenMp(const SerialOpenMp&) = delete;
  SerialOpenMp& operator=(const SerialOpenMp&) = delete;

 private:
  int levels_;
};

}  // namespace

CholmodFactor::CholmodFactor() : impl_(std::make_unique<Impl>()) {}
CholmodFactor::~CholmodFactor() = default;

void CholmodFactor::Analyze(const Eigen::SparseMatrix<double>& A) {
  cholmod_sparse view = View(A);
  if (impl_->factor) cholmod_free_factor(&impl_->factor, &impl_->common);
  const SerialOpenMp serial;
  impl_->factor = cholmod_analyze(&view, &impl_->common);
  NSIM_CHECK(impl_->factor != nullptr, "cholmod_analyze failed, status ", impl_->common.status);
  impl_->n = static_cast<int>(A.rows());
  factorized_ = false;
}

bool CholmodFactor::Factorize(const Eigen::SparseMatrix<double>& A) {
  NSIM_CHECK(impl_->factor != nullptr, "CholmodFactor::Factorize before Analyze");
  NSIM_CHECK(A.rows() == impl_->n, "matrix size ", A.rows(), " differs from the analysed ",
             impl_->n);
  cholmod_sparse view = View(A);
  const SerialOpenMp serial;
  const int ok = cholmod_factorize(&view, impl_->factor, &impl_->common);
  factorized_ = ok && impl_->common.status == CHOLMOD_OK && impl_->factor->minor == impl_->factor->n;
  return factorized_;
}

void CholmodFactor::CopyFrom(const CholmodFactor& other) {
  NSIM_CHECK(other.impl_->factor != nullptr, "CholmodFactor::CopyFrom an unanalysed factor");
  if (impl_->factor) cholmod_free_factor(&impl_->factor, &impl_->common);
  impl_->factor = cholmod_copy_factor(other.impl_->factor, &impl_->common);
  NSIM_CHECK(impl_->factor != nullptr, "cholmod_copy_factor failed, status ", impl_->common.status);
  impl_->n = other.impl_->n;
  factorized_ = other.factorized_;
}

void CholmodFactor::Solve(const Eigen::Ref<const Eigen::MatrixXd>& B,
                          Eigen::Ref<Eigen::MatrixXd> X) {
  NSIM_CHECK(factorized_, "CholmodFactor::Solve without a valid factorization");
  NSIM_CHECK(B.rows() == impl_->n && X.rows() == B.rows() && X.cols() == B.cols(),
             "CholmodFactor::Solve size mismatch: n = ", impl_->n, ", B ", B.rows(), " x ",
             B.cols(), ", X ", X.rows(), " x ", X.cols());
  const SupernodalFactorView view = supernodal_view();
  Impl& s = *impl_;
  // the permuted columns (grown, never shrunk: no allocation once k columns were seen)
  if (s.y_perm.size() < B.size()) s.y_perm.resize(B.size());
  Eigen::Map<Eigen::MatrixXd> Y(s.y_perm.data(), view.n, B.cols());
  for (Eigen::Index c = 0; c < B.cols(); ++c)
    for (int k = 0; k < view.n; ++k) Y(k, c) = B(view.perm[k], c);
  SupernodalSolveInPlace(view, view.x, Y, s.gathered);
  for (Eigen::Index c = 0; c < B.cols(); ++c)
    for (int k = 0; k < view.n; ++k) X(view.perm[k], c) = Y(k, c);
}

SupernodalFactorView CholmodFactor::supernodal_view() const {
  NSIM_CHECK(factorized_, "CholmodFactor::supernodal_view without a valid factorization");
  const cholmod_factor* L = impl_->factor;
  NSIM_CHECK(L->is_super && L->is_ll && L->itype == CHOLMOD_INT && L->xtype == CHOLMOD_REAL &&
                 L->dtype == CHOLMOD_DOUBLE,
             "CholmodFactor::supernodal_view needs a supernodal LL' factor with int indices");
  SupernodalFactorView view;
  view.n = static_cast<int>(L->n);
  view.nsuper = static_cast<int>(L->nsuper);
  view.super = static_cast<const int*>(L->super);
  view.pi = static_cast<const int*>(L->pi);
  view.px = static_cast<const int*>(L->px);
  view.s = static_cast<const int*>(L->s);
  view.x = static_cast<const double*>(L->x);
  view.perm = static_cast<const int*>(L->Perm);
  return view;
}

int CholmodFactor::rows() const { return impl_->n; }
bool CholmodFactor::is_analyzed() const { return impl_->factor != nullptr; }
double CholmodFactor::get_factor_nnz() const { return impl_->common.lnz; }
double CholmodFactor::get_factor_flops() const { return impl_->common.fl; }

}  // namespace nsim
