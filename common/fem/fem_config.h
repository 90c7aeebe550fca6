#pragma once
// Configuration of the soft-tissue FEM engine (one plain struct, SI units, validated on load).

#include <Eigen/Core>
#include <string>

namespace nsim {

/// How FemSolver solves the per-step linear system A dv = b (A = M + h C + h^2 K).
enum class FemLinearSolver {
  /// Assemble A every step and refactorize it with CHOLMOD (supernodal); exact up to round-off.
  /// Reference path: about 25x slower than kPcgCachedFactor on a 2660-node liver.
  kDirect,
  /// Conjugate gradient on the current co-rotated A (matrix-free), preconditioned by a cached
  /// CHOLMOD factor warped by nodal rotations; always iterated to cg_relative_tolerance.
  kPcgCachedFactor,
};

/// Parses "direct" / "pcg_cached_factor"; throws InputError naming `key` otherwise.
FemLinearSolver ParseFemLinearSolver(const std::string& text, const std::string& key);

/// When a background factorization (FemConfig::background_refactor) is adopted.
enum class FactorAdoption {
  /// At the start of step k + refactor_adopt_delay for a request of step k, waiting for the
  /// worker there if it is not done: deterministic (lockstep, batches, tests).
  kScheduled,
  /// At the start of the first step from k + refactor_adopt_delay on at which the worker is
  /// done; a step never waits for it. For realtime runs: which factor preconditions a step then
  /// depends on the worker's timing, so runs differ at the PCG tolerance (every solve is still
  /// iterated to cg_relative_tolerance); a late factor only costs PCG iterations, and a PCG that
  /// reaches cg_max_iterations falls back to a factor of its own step (the job in flight is
  /// dropped).
  kWhenReady,
};

/// Material, damping, time stepping and solver settings of one FEM body.
struct FemConfig {
  double young_modulus = 5500.0;  ///< E (Pa); liver 5.5 kPa (thesis §5.1)
  double poisson_ratio = 0.45;    ///< nu (-), in (-1, 0.5)
  double density = 1060.0;        ///< rho (kg/m^3); liver 1060
  double rayleigh_mass = 0.0;     ///< alpha (1/s) of C = alpha M + beta K
  double rayleigh_stiffness = 0.0;  ///< beta (s) of C = alpha M + beta K
  double time_step = 0.02;        ///< h (s) of implicit Euler
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};  ///< gravitational acceleration (m/s^2), world frame

  FemLinearSolver linear_solver = FemLinearSolver::kPcgCachedFactor;
  /// The conjugate gradient's preconditioner solves with a single-precision copy of the cached
  /// factor (common/fem/single_precision_factor.h): about half the bytes of L to read per
  /// solve, 0.5-0.65x the time of CHOLMOD's double solve at 2660 nodes, 0.4x at 10000
  /// (fem_bench Solve / SolveSingle). The iterations and the converged solution are those of
  /// the double preconditioner to within the tolerance (the CG is iterated on the exact
  /// operator to cg_relative_tolerance); only the preconditioner's round-off changes. The
  /// constraint compliance (FemInverse) always uses the double factors. false: double.
  bool single_precision_preconditioner = true;
  /// Relative residual ||b - A dv||_2 / ||b||_2 the conjugate gradient must reach (-). 1e-4
  /// from an error budget (docs/performance.md, "The PCG tolerance from an error budget"): on
  /// the default closed loop the solver moves the true target and the tip by at most 0.15 um
  /// and the final error by 4e-5 mm against 1e-6. Tests of the solver's own precision (exact
  /// conservation, holds) set 1e-6 themselves.
  double cg_relative_tolerance = 1e-4;
  /// When the conjugate gradient has not converged after this many iterations, the current A is
  /// factorized and solved directly (the solve is never truncated).
  int cg_max_iterations = 100;
  /// A free-motion solve that needed more iterations than this refreshes the cached factor with
  /// the current A (synchronously, or in the background thread below). Measured on the patient
  /// scene and the controller's step (docs/performance.md, "When to refresh the factor").
  int refactor_iteration_threshold = 3;
  /// Refresh the cached factor in a worker thread (the second core), deterministically: a
  /// free-motion solve of step k that asks for a refresh hands this step's A to the worker, and
  /// the new factor is adopted at the start of step k + refactor_adopt_delay (counted in
  /// BeginStep calls), waiting for the worker there if it is not done. Which factor
  /// preconditions each step therefore depends only on the simulation, never on thread timing:
  /// runs are bit-identical whatever the load (fem_background_refresh_test checks it). No step
  /// pays a factorization unless the worker is late. Off: refresh on the calling thread, inside
  /// the step that asks for it (the factor is then adopted one step earlier; also deterministic).
  /// Off by default: the free motion is as exact either way (PCG to the tolerance), but a
  /// constraint compliance built on the factor (FemInverse::kReferenceFactor) then lags the
  /// state by refactor_adopt_delay steps, and on a fast-deforming body this delayed feedback
  /// destabilizes the constraint forces (fem_body_test's hanging 5.5 kPa cube: lambda
  /// oscillates and grows to 10-30x the weight with a delay of 1-3, stays within 0.4-1.9x
  /// with the in-step refresh). Safe where the compliance does not depend on the factor (the
  /// patient liver's rest compliance, kRestFactor; kCachedFactor, kCurrentSystem) or the body
  /// moves slowly. The default scenarios turn it on for the patient liver (patient.liver:
  /// background_refactor: true with constraint_compliance: rest).
  bool background_refactor = false;
  /// Steps from the request of a background refresh to its adoption (>= 1). With 1 the factor
  /// preconditions the same steps as a refresh on the calling thread (free steps are then
  /// bit-identical to background_refactor = false). 3: on the 2660-node liver a factorization
  /// takes ~30-60 ms, i.e. 2-3 steps of 20 ms; the older factor costs ~0.2 PCG iterations a
  /// step more in the patient scene (tests/bench/scene_bench.cpp, DirectSceneSequence).
  int refactor_adopt_delay = 3;
  /// Scheduled (deterministic) or as soon as the worker is done (realtime); see FactorAdoption.
  /// In the scheduled mode an adoption waits whenever a factorization outlasts
  /// refactor_adopt_delay steps: on a slow or loaded machine the refreshes of a deforming liver
  /// then follow one another every delay + 1 steps and each adoption stalls its step.
  FactorAdoption refactor_adoption = FactorAdoption::kScheduled;
  /// Seconds (>= 0) each step gives a background refresh in flight when the process may run on
  /// one CPU only (its affinity mask when the solver is made: `taskset -c 0`, a one-CPU
  /// cpuset): the step waits at its end until the worker is done or this time has passed. The
  /// worker runs at the lowest priority, so on one CPU it otherwise gets the core only when
  /// the steps leave it idle, and an adoption then waits for the whole factorization (30-60 ms
  /// at 2660 nodes) in one step. With a slice s a factorization of T seconds spreads over about
  /// T / s steps, each at most s longer; which factor preconditions which step does not change
  /// (the adoption is as refactor_adoption says), so neither do the results. Pair it with
  /// refactor_adoption: when_ready, or a refactor_adopt_delay of at least T / s, else the
  /// adopting step still waits for the rest. Ignored with two CPUs or more (the worker then
  /// runs beside the step) and without background_refactor. 0 (the default): never.
  double refactor_slice = 0.0;
  /// Steps (>= 0) for which a background refresh in flight is kept off the CPU while the patient
  /// scene steps (FemSolver::HoldRefresh), when the process may run on one CPU only (as for
  /// refactor_slice): the step closes the worker's gate (common/fem/worker_gate.h) and the worker
  /// waits at its next safe point (between the factorization's BLAS calls, microseconds) instead
  /// of taking the core for a scheduler tick (4 ms at HZ 250) when the fair scheduler hands it
  /// its share; it then runs only in the time between steps (a paced loop's wait for its next
  /// period). A refresh requested more than this many steps ago is no longer held, so that
  /// steps back to back (no time between them) still refresh, at the fair scheduler's pace.
  /// Nothing else changes: which factor preconditions which step is refactor_adoption's (the
  /// scheduled adoption's wait opens the gate). Ignored with two CPUs or more and without
  /// background_refactor. 0 (the default): never. Only the patient scene's step takes the hold
  /// (PatientScene::Step); the controller's model (inverse.liver) reads the key but never holds.
  int refactor_hold_steps = 0;
  /// The background refresh's worker in the lowest scheduling class (SCHED_IDLE, else nice 19)
  /// when adoptions are when_ready: on a core a step also wants, the step goes first. Right for
  /// a realtime loop, whose steps' latency is what counts. A scheduled adoption waits for the
  /// worker, so its worker is never idle-class, whatever this says (RefreshWorkerIdle): on a
  /// machine busy with anything else (a compile, a second batch) an idle-class worker gets no
  /// CPU, and each adoption then waits until the machine is idle (measured: a 20 s lockstep
  /// run took 678 s of wall clock beside a two-job build, 54 of 59 adoptions waiting, against
  /// about 60 s alone; a realtime control step once waited 27 s, until direct_sim ended).
  /// false, or a scheduled adoption: the worker stays in the normal class of its creator's kind
  /// (SCHED_OTHER, nice 0; a SCHED_FIFO creator's worker is still moved out of the realtime
  /// class, to SCHED_OTHER). Results do not depend on it (the adoption schedule is
  /// refactor_adoption's). Not a YAML key: InverseScenario::LoopConfig sets it false in
  /// lockstep.
  bool idle_refresh_worker = true;
  /// Whether the refresh worker runs in the idle class: idle_refresh_worker with when_ready
  /// adoptions, never with scheduled ones (they wait for it).
  bool RefreshWorkerIdle() const {
    return idle_refresh_worker && refactor_adoption == FactorAdoption::kWhenReady;
  }
  /// Threads of the element passes (the elastic forces and rotations of each step, and the
  /// matrix-free products of the conjugate gradient), 1-8: the tets are split into this many
  /// fixed, contiguous parts, part 0 on the calling thread and the others on helper threads
  /// (common/fem/fork_join.h), each part summing into its own buffers, added in part order.
  /// Deterministic for a given count (every run gives the same bits); a different count
  /// changes the result at round-off (the sums are associated differently). 1 (the default):
  /// the serial passes, exactly as without this setting. Pays only with a free core.
  int element_threads = 1;

  /// Throws InputError with "fem.<key> must be ..., got <value>" for the first invalid field.
  void Validate() const;
};

/// Lamé parameters of an isotropic linear material (Pa).
struct LameParameters {
  double lambda = 0.0;  ///< first Lamé parameter (Pa)
  double mu = 0.0;      ///< shear modulus (Pa)
};

/// lambda = E nu / ((1 + nu)(1 - 2 nu)), mu = E / (2 (1 + nu)). Requires nu in (-1, 0.5).
LameParameters CalcLameParameters(double young_modulus, double poisson_ratio);

}  // namespace nsim
