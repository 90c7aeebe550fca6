#pragma once
// A gate a background thread waits at between pieces of its work, closed and opened by the
// thread it works for: cooperative preemption at safe points.
//
// Why: on one CPU the liver's factor refresh (FemSolver's worker, SCHED_IDLE) still gets the
// core in whole scheduler ticks while a step runs (common/core/thread_priority.h: 4 ms lost by
// 3-8 % of the paced steps on one core). A step that closes the gate takes the worker off the
// CPU at its next safe point, microseconds after the scheduler handed it the core, instead of
// a tick later.
//
// Safe points: PassWorkerGate() where the worker's own code calls it (FemSolver's assembly,
// the single-precision copy) and every level-3 BLAS / LAPACK call the factorization makes
// (dgemm_, dsyrk_, dtrsm_, dpotrf_: CHOLMOD's supernodal factorization calls them once or more
// per supernode). Those four are interposed by this file's object (worker_gate.cpp): an
// executable linking it defines them, the dynamic linker binds CHOLMOD's calls to them, and
// they pass the gate and call the BLAS library's (dlsym RTLD_NEXT). At a safe point the
// thread holds no lock (none of ours; the BLAS library's allocation mutex is taken inside the
// call, after the gate), so a step never waits for a gated worker.
//
// A thread that never bound a gate passes every safe point at the cost of a thread-local read.

#include <condition_variable>
#include <mutex>

namespace nsim {

class WorkerGate {
 public:
  WorkerGate() = default;
  WorkerGate(const WorkerGate&) = delete;
  WorkerGate& operator=(const WorkerGate&) = delete;

  /// The bound thread waits at its next safe point until Open.
  void Close();
  void Open();
  bool closed() const;
  /// Safe points the bound thread has waited at since the gate was made.
  long waits() const;

  /// Makes this gate the calling thread's: its safe points wait while the gate is closed.
  /// Unbind (or the thread's end) before the gate is destroyed.
  void BindToThisThread();
  static void UnbindThisThread();

 private:
  friend void PassWorkerGate();
  void Pass();

  mutable std::mutex mutex_;
  std::condition_variable opened_;
  bool closed_ = false;
  long waits_ = 0;
};

/// A safe point: waits while the calling thread's gate (if it has one) is closed.
void PassWorkerGate();

}  // namespace nsim
