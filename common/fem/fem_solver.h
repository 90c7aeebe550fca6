#pragma once
// Implicit co-rotational FEM time stepping and the linear-system API used by the Lagrangian
// constraint solver (common/constraints).
//
// One step (backward Euler linearized once, DESIGN.md "Physics"):
//
//   A dv = b,   A = (1 + h alpha) M + (h beta + h^2) K(R),
//               b = h f - h alpha M v - (h beta + h^2) K(R) v,
//   v+ = v + dv,  x+ = x + h v+,
//
// with M the lumped mass, K(R) = sum_e R_e K_e R_e^T the co-rotated stiffness (positive
// semi-definite, K = -df/dx up to the rotation derivative), C = alpha M + beta K the Rayleigh
// damping and f = elastic + gravity + external forces at x. (This is DESIGN.md's
// (M + hC + h^2K) dv = h (f + hKv) written with K positive and the damping force -C v in f.)
// Dirichlet nodes (fixed: v+ = 0; prescribed: x+ = FemState::prescribed_positions) are
// eliminated exactly: their dv is known, A_fd dv_d moves to the right-hand side, and only the
// free block A_ff dv_f = b_f - A_fd dv_d is solved. Nothing allocates inside a step apart from
// CHOLMOD's internal workspaces (see fem_solver_no_malloc_test.cpp for what is checked).
//
// Constraint-solver API (Duriez 2009 / thesis §3.1), per step:
//
//   FemSolver solver(model);                 // once: pattern analysis, rest factorization
//   solver.BeginStep(state);                 // (1) free motion: state.dv_free, state.x_free
//   solver.ApplyInverse(Ht, AinvHt);         // (2) A^-1 H^T, 3n x k (dense or sparse H^T);
//                                            //     W = H A^-1 H^T is formed by the caller
//   ... solve for lambda ...
//   dv_c = AinvHt * impulse;                 // impulse in N s (h * force lambda)
//   solver.CommitStep(state, dv_c);          // (3) v+ = v + dv_free + dv_c, x+ = x + h v+
//
// Units: A is in kg, so A^-1 maps an impulse (N s) to a velocity change (m/s); a position
// correction is h dv. All 3n-sized vectors and matrices use node-major DOF order
// (node i -> rows 3i, 3i+1, 3i+2) over ALL nodes; the rows of Dirichlet nodes of A^-1 B are zero
// (their motion is prescribed, so no impulse moves them; an impulse on them goes to the support
// and appears in FemState::reaction_forces).
//
// Exactness of A^-1 (FemInverse):
//   kCurrentSystem  A^-1 of this step's co-rotated A. Direct solver: one multi-RHS CHOLMOD solve
//                   with this step's factor, exact to round-off. PCG solver: one PCG per column,
//                   each to cg_relative_tolerance (k solves: costly for many columns).
//   kCachedFactor   the PCG preconditioner P^-1 = Q A_ref^-1 Q^T (A_ref: the cached factor's
//                   matrix, Q: nodal rotations since it was factored), one multi-RHS CHOLMOD
//                   solve. On the direct path P = A exactly. On the PCG path it is an
//                   APPROXIMATE compliance (exact for rigidly rotated, otherwise off by the
//                   deviation of the current rotations from the cached ones): constraints
//                   solved with it are satisfied by the corrected state (dv_c is computed with
//                   the same operator), but the correction's dynamics are approximate, as with
//                   SOFA's cached-compliance constraint corrections.
//   kReferenceFactor A_ref^-1 itself, unwarped: the exact inverse of the system matrix at the
//                   last factorization (its rotations, its time step). It stays the same between
//                   factorizations (get_factor_version() tells when it changed), so compliance
//                   columns of constraint points can be cached across steps, and, being the
//                   inverse of a true co-rotational system, it moves a rigid translation as a
//                   rigid translation (no spurious momentum). Approximate by the rotation
//                   since the last factorization; the fast path refreshes the factor when PCG
//                   needs more than refactor_iterations, which bounds that rotation. With
//                   FemConfig::background_refactor the factor is adopted refactor_adopt_delay
//                   steps after the state it was made from: a compliance that lags the state
//                   (see fem_config.h for when that destabilizes constraint forces).
//   kRestFactor     A_0^-1: the exact inverse of the rest system, from the factorization made
//                   at construction, kept unchanged for the solver's lifetime (no refresh, in
//                   the step or in the background, replaces it). Constant, so compliance
//                   columns of constraint points can be cached for good (SOFA's precomputed
//                   compliance); approximate by the element rotations since rest (K_0 instead
//                   of K(R)). It does not depend on the refresh schedule, so it never lags the
//                   state by refactor_adopt_delay (safe with background_refactor). Costs the
//                   memory of one more factor (a copy made at construction).
//
// Threading: a FemSolver belongs to one thread (plus its own background worker when
// FemConfig::background_refactor is set on the PCG path, at the lowest priority, nice 19, so
// that on a shared core the steps go first). The worker assembles and factorizes A from the
// rotated gradients of the step that asked (copied there), and makes the factor's
// single-precision copy for the preconditioner; on a process confined to one CPU each step
// with a refresh in flight waits up to FemConfig::refactor_slice for it, the only time the
// worker then gets the core besides the steps' idle time. What it factorizes (A of the step that asked)
// and, with FactorAdoption::kScheduled, when its factor is adopted (refactor_adopt_delay steps
// later, at the start of BeginStep, waiting if necessary) follow from the calls alone, so
// results do not depend on thread timing (given a BLAS that is deterministic for a fixed thread
// count). With kWhenReady (realtime) the adoption is the first BeginStep from then on that
// finds the worker done: no step waits, and runs differ at the PCG tolerance. BLAS threads: set
// OPENBLAS_NUM_THREADS=1 for single-core timing.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/fem/fem_model.h"
#include "common/fem/fem_state.h"

namespace nsim {

/// Which operator FemSolver::ApplyInverse applies; see the header comment.
enum class FemInverse { kCurrentSystem, kCachedFactor, kReferenceFactor, kRestFactor };

/// The one compliance policy of the scenarios' constraint bodies (YAML
/// patient.constraint_compliance for the patient's liver, inverse.constraint_compliance for the
/// controller's model), named by what it selects: "rest" = kRestFactor (h^2 A_0^-1, constant),
/// "last_factor" = kReferenceFactor (the last factorization). The choices, in that order:
const std::vector<std::string>& ConstraintComplianceNames();
/// The operator of a constraint body whose scenario chose rest (true) or last_factor (false).
FemInverse SelectConstraintCompliance(bool rest);

/// What the last free-motion solve did.
struct FemStepStats {
  int cg_iterations = 0;          ///< PCG iterations (0 on the direct path)
  /// ||b - A dv|| / ||b|| of the free-motion solve: PCG's recursive residual (the true one up to
  /// round-off; the true one when PCG ran out of iterations, and on the direct path)
  double relative_residual = 0;
  /// ||b - A dv_0|| / ||b|| of the warm start dv_0 the PCG began from (0 on the direct path)
  double initial_residual = 0;
  bool refactorized = false;      ///< a numeric factorization ran on this thread in this step
  bool factor_swapped = false;    ///< a background factorization was adopted at this step
  bool refresh_requested = false;  ///< this step's A was handed to the background worker
  /// The adoption at this step had to wait for the worker (the only field that depends on
  /// timing; nothing else does).
  bool waited_for_worker = false;
  /// Steps from the request to the adoption of the factor adopted at this step (0: none);
  /// refactor_adopt_delay when scheduled, at least that when ready (timing-dependent).
  int adoption_lag = 0;
  bool fell_back_to_direct = false;  ///< PCG hit cg_max_iterations; solved with a fresh factor
  /// Seconds this step waited to give a refresh in flight the only CPU (FemConfig::
  /// refactor_slice; timing-dependent like waited_for_worker, and nothing depends on it).
  double slice_wait = 0.0;
  int inverted_tets = 0;          ///< tets with det F <= kPolarSvdThreshold at the step's x
};

class FemSolver {
  struct Impl;

 public:
  /// Analyses the pattern, factorizes the rest system A_0 = (1 + h alpha) M + (h beta + h^2) K_0
  /// (kept for FemInverse::kRestFactor; the cached factor starts as a copy of it).
  /// `model` must outlive the solver.
  explicit FemSolver(const FemModel& model);
  ~FemSolver();
  FemSolver(const FemSolver&) = delete;
  FemSolver& operator=(const FemSolver&) = delete;

  /// One unconstrained step: BeginStep then CommitStep(state).
  FemStepStats Step(FemState& state);

  /// (1) Free motion: computes the element rotations at state.x, the forces and this step's
  /// A and b, solves A dv = b and writes state.rotations, state.dv_free and
  /// state.x_free. Does not advance state.x, state.v or state.time. Throws InputError when
  /// state.prescribed_positions or state.external_forces contain non-finite values.
  FemStepStats BeginStep(FemState& state);

  /// (2) out = A^-1 rhs for rhs of size 3n x k (n = #nodes, node-major DOFs), out resized to
  /// 3n x k; rows of Dirichlet DOFs of rhs are ignored and zero in out. Valid between BeginStep
  /// and the next BeginStep.
  void ApplyInverse(const Eigen::Ref<const Eigen::MatrixXd>& rhs, Eigen::MatrixXd& out,
                    FemInverse which = FemInverse::kCurrentSystem);
  /// Same with sparse columns (e.g. H^T, 3n x k with 12 entries a column for a barycentric
  /// point): only the touched entries are gathered; the solve itself is a dense multi-RHS solve.
  void ApplyInverse(const Eigen::SparseMatrix<double>& rhs, Eigen::MatrixXd& out,
                    FemInverse which = FemInverse::kCurrentSystem);

  /// (3) Ends the step: v+ = v + dv_free + dv_correction, x+ = x + h v+, time += h, and the
  /// reaction forces at the Dirichlet nodes. dv_correction is 3n (m/s) with zero Dirichlet rows
  /// (as returned by ApplyInverse); checked, NaN rejected with InputError.
  void CommitStep(FemState& state, const Eigen::Ref<const Eigen::VectorXd>& dv_correction);
  /// Ends the step without a correction.
  void CommitStep(FemState& state);

  /// Keeps the background refresh off the CPU while it lives (FemConfig::refactor_hold_steps):
  /// made by HoldRefresh for one step of the scene the solver belongs to (all its bodies and
  /// constraints), released when it goes out of scope. Empty (holds nothing) when the config,
  /// the CPU count or the age of the refresh in flight says no.
  class RefreshHold {
   public:
    ~RefreshHold();
    RefreshHold(RefreshHold&& other) noexcept;
    RefreshHold(const RefreshHold&) = delete;
    RefreshHold& operator=(const RefreshHold&) = delete;
    RefreshHold& operator=(RefreshHold&&) = delete;
    bool holds() const { return impl_ != nullptr; }

   private:
    friend class FemSolver;
    explicit RefreshHold(Impl* impl) : impl_(impl) {}
    Impl* impl_;  // the solver's, null when nothing is held; must not outlive the solver
  };
  /// Closes the worker's gate (common/fem/worker_gate.h) until the returned hold ends, on a
  /// process confined to one CPU with refactor_hold_steps > 0 and a background worker, unless
  /// the refresh in flight was requested more than refactor_hold_steps steps before the coming
  /// step. Call it before BeginStep; a wait for the worker (the scheduled adoption,
  /// refactor_slice, WaitForBackgroundFactorization) opens the gate, and the scheduled adoption
  /// and the slice close it again once their wait is over.
  [[nodiscard]] RefreshHold HoldRefresh();
  /// Safe points at which the worker waited for a held step to end, since construction
  /// (timing-dependent; for benchmarks and tests).
  long get_refresh_gate_waits() const;
  /// Test hook: treat the process as confined to one CPU (refactor_slice, refactor_hold_steps)
  /// whatever its affinity mask.
  void AssumeOneCpuForTesting(bool one_cpu);

  /// Waits for a running background factorization (if any) to finish. It is still adopted at
  /// its scheduled step (FemConfig::refactor_adopt_delay steps after the request), not earlier.
  void WaitForBackgroundFactorization();
  /// Test hook: the worker sleeps this long before each factorization (simulates a loaded or
  /// slow second core; results must not change).
  void SetWorkerDelayForTesting(std::chrono::microseconds delay);
  /// Test hook: the worker starts each factorization only when the main thread waits for it
  /// (the adopting step, or WaitForBackgroundFactorization): a worker that is always late,
  /// whatever the machine's load.
  void HoldWorkerForTesting(bool hold);

  const FemModel& get_model() const { return model_; }
  const FemStepStats& get_last_stats() const { return stats_; }
  /// Numeric factorizations done so far (construction included), on any thread.
  int get_factorization_count() const;
  /// Changes whenever the factor used by kCachedFactor / kReferenceFactor is replaced (a
  /// factorization on this thread, or an adopted background one). The kRestFactor factor never
  /// changes.
  std::uint64_t get_factor_version() const;
  /// The reduced system matrix A_ff of the current step (assembled on demand, Calc: costs an
  /// assembly). For tests and diagnostics.
  const Eigen::SparseMatrix<double>& CalcSystemMatrix();

 private:
  const FemModel& model_;
  std::unique_ptr<Impl> impl_;
  FemStepStats stats_;
};

}  // namespace nsim
