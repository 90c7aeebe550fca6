#include "common/fem/worker_gate.h"

#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>

namespace nsim {

namespace {
thread_local WorkerGate* this_thread_gate = nullptr;
}  // namespace

void WorkerGate::Close() {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
}

void WorkerGate::Open() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = false;
  }
  opened_.notify_all();
}

bool WorkerGate::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

long WorkerGate::waits() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return waits_;
}

void WorkerGate::BindToThisThread() { this_thread_gate = this; }

void WorkerGate::UnbindThisThread() { this_thread_gate = nullptr; }

void WorkerGate::Pass() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!closed_) return;
  ++waits_;
  opened_.wait(lock, [this] { return !closed_; });
}

void PassWorkerGate() {
  if (WorkerGate* gate = this_thread_gate) gate->Pass();
}

}  // namespace nsim

// The BLAS / LAPACK routines CHOLMOD's supernodal factorization calls (SuiteSparse 5, 32-bit
// BLAS integers: cholmod_blas.h), interposed: each passes the calling thread's gate, then calls
// the next definition in the dynamic linker's search order (the BLAS library's). The hidden
// string-length arguments of the Fortran interface are not declared: CHOLMOD does not pass them
// and OpenBLAS does not read them.
namespace {

template <typename Fn>
Fn NextDefinition(const char* name) {
  void* next = dlsym(RTLD_NEXT, name);
  if (next == nullptr) {
    std::fprintf(stderr, "nsim: %s has no definition after the worker gate's (BLAS library not loaded)\n",
                 name);
    std::abort();
  }
  return reinterpret_cast<Fn>(next);
}

}  // namespace

extern "C" {

void dgemm_(char* transa, char* transb, int* m, int* n, int* k, double* alpha, double* a, int* lda,
            double* b, int* ldb, double* beta, double* c, int* ldc) {
  using Fn = void (*)(char*, char*, int*, int*, int*, double*, double*, int*, double*, int*,
                      double*, double*, int*);
  static const Fn next = NextDefinition<Fn>("dgemm_");
  nsim::PassWorkerGate();
  next(transa, transb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc);
}

void dsyrk_(char* uplo, char* trans, int* n, int* k, double* alpha, double* a, int* lda,
            double* beta, double* c, int* ldc) {
  using Fn = void (*)(char*, char*, int*, int*, double*, double*, int*, double*, double*, int*);
  static const Fn next = NextDefinition<Fn>("dsyrk_");
  nsim::PassWorkerGate();
  next(uplo, trans, n, k, alpha, a, lda, beta, c, ldc);
}

void dtrsm_(char* side, char* uplo, char* transa, char* diag, int* m, int* n, double* alpha,
            double* a, int* lda, double* b, int* ldb) {
  using Fn = void (*)(char*, char*, char*, char*, int*, int*, double*, double*, int*, double*,
                      int*);
  static const Fn next = NextDefinition<Fn>("dtrsm_");
  nsim::PassWorkerGate();
  next(side, uplo, transa, diag, m, n, alpha, a, lda, b, ldb);
}

void dpotrf_(char* uplo, int* n, double* a, int* lda, int* info) {
  using Fn = void (*)(char*, int*, double*, int*, int*);
  static const Fn next = NextDefinition<Fn>("dpotrf_");
  nsim::PassWorkerGate();
  next(uplo, n, a, lda, info);
}

}  // extern "C"
