#include "common/fem/fem_solver.h"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>

#include "common/core/error.h"
#include "common/core/thread_priority.h"
#include "common/fem/cholmod_factor.h"
#include "common/fem/fork_join.h"
#include "common/fem/single_precision_factor.h"
#include "common/fem/warm_start.h"
#include "common/fem/worker_gate.h"

namespace nsim {

struct FemSolver::Impl {
  const FemModel& model;
  const FemConfig& config;
  const LameParameters lame;
  const double h;
  const double mass_scale;  // 1 + h alpha
  const double stiffness_scale;  // h beta + h^2
  const int num_free;

  Eigen::VectorXd mass_free;            // lumped mass per reduced DOF (kg), 3 #free
  Eigen::SparseMatrix<double> matrix;   // A_ff assembled on this thread
  std::unique_ptr<CholmodFactor> active;  // factor used by solves on this thread
  // its single-precision copy, the PCG preconditioner's (FemConfig::single_precision_preconditioner)
  std::unique_ptr<SinglePrecisionFactor> active_single;
  std::unique_ptr<CholmodFactor> rest;    // factor of A_0, never replaced (kRestFactor)
  std::vector<Eigen::Matrix3d> rotations;     // element rotations of the current step
  // R_e grad_n of the current step (1/m), per block of the model's TetBlocks
  std::vector<TetLanes34> rotated_grad;
  std::vector<Eigen::Matrix3d> nodal_rotations;  // current, per free node
  std::vector<Eigen::Matrix3d> nodal_means;      // scratch: their mean element rotations
  std::unique_ptr<bool[]> nodal_svd;             // scratch: CalcPolarRotations' branch flags
  // per entry j of the model's node-tet lists: tet j's volume over the summed volume of its
  // free node's tets (the weights of the nodal average, flat: no rest shape read per step)
  std::vector<double> node_tet_weights;
  std::vector<Eigen::Matrix3d> reference_rotations;  // nodal rotations the active factor was made at
  std::vector<Eigen::Matrix3d> warp;  // Q = current * reference^T, per free node
  bool factor_is_current = false;     // active factor is this step's A (Q = I)

  // element passes over FemConfig::element_threads parts: part p covers the blocks of
  // kTetLanes tets [part_begin[p], part_begin[p + 1]) (TetBlocks); parts p >= 1 sum into
  // part_out[p - 1], added to part 0's sums in part order
  std::unique_ptr<ForkJoin> pool;  // null with one part
  std::vector<int> part_begin;
  std::vector<Eigen::Matrix3Xd> part_out;
  std::vector<int> part_inverted;

  // scratch, preallocated
  Eigen::Matrix3Xd full_in, full_out, full_w;  // full_in: Dirichlet columns always zero
  Eigen::Matrix3Xd velocity_change;  // this step's change of the free end velocity
  Eigen::Matrix3Xd full_sum;                   // dv + v in CommitStep
  Eigen::Matrix3Xd support_elastic;  // the reactions' elastic part at the Dirichlet nodes, in CommitStep
  Eigen::VectorXd b, dv, r, z, p, ap, tmp;
  Eigen::MatrixXd multi_in, multi_out, multi_rotated;
  Eigen::VectorXd zero_correction;  // 3n zeros for CommitStep without a correction

  // background factorization (FemConfig::background_refactor). Deterministic schedule: the
  // request is made at step k from A_k, the result adopted at the start of step adopt_step =
  // k + refactor_adopt_delay, whatever the worker's timing (the main thread waits there if
  // needed; FactorAdoption::kWhenReady: at the first step from adopt_step on at which the
  // worker is done, never waiting). Ownership: background_matrix and spare belong to the
  // worker from the request until job_done is seen under the mutex; background_rotations only
  // to this thread. The worker assembles the request's A from background_grad (its copy of
  // rotated_grad), so that the requesting step only copies the rotated gradients.
  std::unique_ptr<CholmodFactor> spare;
  std::unique_ptr<SinglePrecisionFactor> spare_single;  // its copy, made by the worker
  Eigen::SparseMatrix<double> background_matrix;
  std::vector<TetLanes34> background_grad;
  std::vector<Eigen::Matrix3d> background_rotations;
  std::thread worker;
  std::mutex mutex;
  std::condition_variable wake;
  bool job_pending = false, job_done = false, job_ok = false, quit = false;  // under mutex
  std::chrono::microseconds worker_delay{0};  // under mutex; test hook (a late worker)
  // under mutex; test hook: the worker starts a job only once the main thread waits for it
  bool hold_worker = false, main_waiting = false;
  std::int64_t step_index = -1;  // index of the current step (BeginStep calls - 1)
  std::int64_t adopt_step = -1;  // step at which the job in flight is adopted; -1: none
  std::atomic<int> factorizations{0};
  std::uint64_t factor_version = 0;  // bumped when `active` is replaced or refactorized
  // the process may run on one CPU only (its affinity mask when the solver was made): the
  // worker then gets the core only while a step waits (FemConfig::refactor_slice)
  bool single_cpu = false;
  // closed while a step holds the refresh (FemConfig::refactor_hold_steps); the worker waits
  // at its safe points then
  WorkerGate gate;
  bool holding = false;  // a RefreshHold of this solver is alive (its gate closed but for waits)

  explicit Impl(const FemModel& m)
      : model(m),
        config(m.get_config()),
        lame(m.get_lame()),
        h(m.get_config().time_step),
        mass_scale(1.0 + h * m.get_config().rayleigh_mass),
        stiffness_scale(h * m.get_config().rayleigh_stiffness + h * h),
        num_free(m.num_free_nodes()) {
    const int n = model.num_nodes();
    const int ndof = 3 * num_free;
    mass_free.resize(ndof);
    for (int k = 0; k < num_free; ++k)
      mass_free.segment<3>(3 * k).setConstant(model.get_lumped_mass()[model.get_free_nodes()[k]]);
    matrix = model.get_system_pattern();
    rotations.assign(model.num_tets(), Eigen::Matrix3d::Identity());
    rotated_grad = model.get_tet_blocks().grad;
    nodal_rotations.assign(num_free, Eigen::Matrix3d::Identity());
    nodal_means.resize(num_free);
    nodal_svd = std::make_unique<bool[]>(num_free);
    {
      const auto& offsets = model.get_node_tet_offsets();
      const auto& node_tets = model.get_node_tets();
      node_tet_weights.assign(node_tets.size(), 0.0);
      for (int k = 0; k < num_free; ++k) {
        double volume = 0.0;
        for (int j = offsets[k]; j < offsets[k + 1]; ++j)
          volume += model.get_rest_shapes()[node_tets[j]].volume;
        for (int j = offsets[k]; j < offsets[k + 1]; ++j)
          node_tet_weights[j] = model.get_rest_shapes()[node_tets[j]].volume / volume;
      }
    }
    reference_rotations = nodal_rotations;
    warp = nodal_rotations;
    full_in = Eigen::Matrix3Xd::Zero(3, n);
    full_out = Eigen::Matrix3Xd::Zero(3, n);
    full_w = Eigen::Matrix3Xd::Zero(3, n);
    full_sum = Eigen::Matrix3Xd::Zero(3, n);
    support_elastic = Eigen::Matrix3Xd::Zero(3, n);
    zero_correction = Eigen::VectorXd::Zero(3 * n);
    for (Eigen::VectorXd* v : {&b, &dv, &r, &z, &p, &ap, &tmp}) *v = Eigen::VectorXd::Zero(ndof);
    const int parts = config.element_threads;
    const int blocks = model.get_tet_blocks().num_blocks();
    for (int q = 0; q <= parts; ++q)
      part_begin.push_back(static_cast<int>(static_cast<std::int64_t>(blocks) * q / parts));
    part_out.assign(parts - 1, Eigen::Matrix3Xd::Zero(3, n));
    part_inverted.assign(parts, 0);
    if (parts > 1) pool = std::make_unique<ForkJoin>(parts);

    // one factorization of A_0: kept as the rest factor, and copied (no second factorization)
    // as the first cached factor, which refreshes then overwrite
    rest = std::make_unique<CholmodFactor>();
    rest->Analyze(matrix);
    Assemble(rotated_grad, matrix);
    NSIM_CHECK(rest->Factorize(matrix), "rest system matrix is not positive definite");
    ++factorizations;
    active = std::make_unique<CholmodFactor>();
    active->CopyFrom(*rest);
    factor_is_current = true;
    const bool single = config.single_precision_preconditioner &&
                        config.linear_solver == FemLinearSolver::kPcgCachedFactor;
    if (single) {
      active_single = std::make_unique<SinglePrecisionFactor>();
      active_single->Assign(active->supernodal_view());
    }

    if (config.background_refactor && config.linear_solver == FemLinearSolver::kPcgCachedFactor) {
      spare = std::make_unique<CholmodFactor>();
      spare->Analyze(matrix);
      if (single) spare_single = std::make_unique<SinglePrecisionFactor>();
      background_matrix = matrix;
      background_grad = rotated_grad;
      background_rotations = nodal_rotations;
      cpu_set_t cpus;
      CPU_ZERO(&cpus);
      single_cpu = sched_getaffinity(0, sizeof(cpus), &cpus) == 0 && CPU_COUNT(&cpus) == 1;
      worker = std::thread([this] { WorkerLoop(); });
    }
  }

  ~Impl() {
    if (worker.joinable()) {
      gate.Open();
      {
        std::lock_guard<std::mutex> lock(mutex);
        quit = true;
      }
      wake.notify_all();
      worker.join();
    }
  }

  void WorkerLoop() {
    // the lowest class (SCHED_IDLE, else nice 19): on a core that a step also wants, the step
    // goes first and the factorization takes the time the steps leave (a realtime loop's wait
    // for its next period); on a free core it runs at full speed. A worker that is late only
    // makes its adopting step wait (the schedule does not change). Set explicitly, so that a
    // worker started by a SCHED_FIFO thread does not inherit its class
    // (common/core/thread_priority.h has what the fair class still gives it on one core).
    // A scheduled adoption (and a lockstep run) keeps it in the normal class
    // (FemConfig::RefreshWorkerIdle): there the steps wait for it, and an idle-class worker
    // waits for the whole machine to be idle.
    if (config.RefreshWorkerIdle())
      LowerThisThreadToIdle();
    else
      MoveThisThreadToNormalClass();
    gate.BindToThisThread();
    std::unique_lock<std::mutex> lock(mutex);
    for (;;) {
      wake.wait(lock, [this] { return job_pending || quit; });
      if (quit) {
        WorkerGate::UnbindThisThread();
        return;
      }
      job_pending = false;
      if (hold_worker) wake.wait(lock, [this] { return main_waiting || quit; });
      if (quit) {
        WorkerGate::UnbindThisThread();
        return;
      }
      const std::chrono::microseconds delay = worker_delay;
      lock.unlock();
      if (delay.count() > 0) std::this_thread::sleep_for(delay);
      PassWorkerGate();  // a job requested in a held step starts after it
      // background_grad, background_matrix and spare are owned by the worker until job_done
      Assemble(background_grad, background_matrix);
      const bool ok = spare->Factorize(background_matrix);
      if (ok && spare_single) spare_single->Assign(spare->supernodal_view());
      ++factorizations;
      lock.lock();
      job_ok = ok;
      job_done = true;
      wake.notify_all();
    }
  }

  // A_ff = (1 + h alpha) M + (h beta + h^2) sum_e R_e K_e R_e^T into `target`'s values, from
  // the rotated gradients `grads` (R_e grad_n, per block of TetBlocks); reads only what never changes
  // after construction besides its arguments, so the worker may run it
  void Assemble(const std::vector<TetLanes34>& grads, Eigen::SparseMatrix<double>& target) const {
    double* values = target.valuePtr();
    const int* outer = target.outerIndexPtr();
    std::fill(values, values + target.nonZeros(), 0.0);
    const auto& diag = model.get_diagonal_index();
    for (int d = 0; d < 3 * num_free; ++d) values[diag[d]] = mass_scale * mass_free[d];
    const auto& tets = model.get_mesh().tets;
    const auto& offsets = model.get_block_offsets();
    for (int e = 0; e < model.num_tets(); ++e) {
      if (e % 1024 == 0) PassWorkerGate();  // a safe point of the worker (no-op on others)
      const TetRestShape& rest = model.get_rest_shapes()[e];
      const Matrix34d rg = ElementOfLanes(grads, e);
      const double scale = stiffness_scale * rest.volume;
      for (int bn = 0; bn < 4; ++bn) {
        const int fb = model.get_free_index(tets[e][bn]);
        if (fb < 0) continue;
        for (int an = 0; an < 4; ++an) {
          const int offset = offsets[e][an + 4 * bn];
          if (offset < 0) continue;
          Eigen::Matrix3d block = lame.lambda * rg.col(an) * rg.col(bn).transpose() +
                                  lame.mu * rg.col(bn) * rg.col(an).transpose();
          // r_a . r_b = g_a . g_b for an orthogonal R; with r it is Multiply's operator exactly
          // for the polar factor's stated precision too (kPolarStepTolerance)
          block.diagonal().array() += lame.mu * rg.col(an).dot(rg.col(bn));
          for (int c = 0; c < 3; ++c) {
            double* column = values + outer[3 * fb + c] + offset;
            for (int rr = 0; rr < 3; ++rr) column[rr] += scale * block(rr, c);
          }
        }
      }
    }
  }

  // fn(part) for every element part, in parallel when there are several (the serial path calls
  // fn directly: no std::function on the hot path)
  template <typename Fn>
  void RunParts(Fn&& fn) {
    if (pool) pool->Run(fn);
    else fn(0);
  }

  // out = A_ff in (reduced vectors), matrix-free with the current rotations
  void Multiply(const Eigen::VectorXd& in, Eigen::VectorXd& out) {
    const auto& free_nodes = model.get_free_nodes();
    for (int k = 0; k < num_free; ++k) full_in.col(free_nodes[k]) = in.segment<3>(3 * k);
    full_out.setZero();
    const TetBlocks& blocks = model.get_tet_blocks();
    RunParts([&](int part) {
      Eigen::Matrix3Xd& sum = part == 0 ? full_out : part_out[part - 1];
      if (part > 0) sum.setZero();
      for (int b = part_begin[part]; b < part_begin[part + 1]; ++b) {
        // R K_e R^T p with rotated gradients r = R g: G = sum_a p_a r_a^T, y_a = V (lambda
        // tr(G) I + mu (G + G^T)) r_a (ApplyCorotatedStiffness in fewer flops), kTetLanes
        // elements at once (ApplyStressLanes)
        const TetLanes34 y = ApplyStressLanes(rotated_grad[b], blocks.volume[b], lame, 0.0,
                                              GatherLanes(blocks, b, full_in));
        ScatterAddLanes(blocks, b, y, sum);
      }
    });
    for (const Eigen::Matrix3Xd& sum : part_out) full_out += sum;
    for (int k = 0; k < num_free; ++k)
      out.segment<3>(3 * k) = mass_scale * mass_free.segment<3>(3 * k).cwiseProduct(in.segment<3>(3 * k)) +
                              stiffness_scale * full_out.col(free_nodes[k]);
  }

  // out = Q A_ref^-1 Q^T in for one or more reduced columns (in may alias nothing)
  void ApplyPreconditioner(const Eigen::Ref<const Eigen::MatrixXd>& in, Eigen::MatrixXd& rotated,
                           Eigen::Ref<Eigen::MatrixXd> out) {
    for (Eigen::Index c = 0; c < in.cols(); ++c)
      for (int k = 0; k < num_free; ++k)
        rotated.col(c).segment<3>(3 * k) = warp[k].transpose() * in.col(c).segment<3>(3 * k);
    active->Solve(rotated, out);
    for (Eigen::Index c = 0; c < in.cols(); ++c)
      for (int k = 0; k < num_free; ++k) {
        const Eigen::Vector3d v = out.col(c).segment<3>(3 * k);
        out.col(c).segment<3>(3 * k) = warp[k] * v;
      }
  }
  void ApplyPreconditioner(const Eigen::VectorXd& in, Eigen::VectorXd& out) {
    for (int k = 0; k < num_free; ++k) tmp.segment<3>(3 * k) = warp[k].transpose() * in.segment<3>(3 * k);
    if (active_single) active_single->Solve(tmp, out);
    else active->Solve(tmp, out);
    for (int k = 0; k < num_free; ++k) {
      const Eigen::Vector3d v = out.segment<3>(3 * k);
      out.segment<3>(3 * k) = warp[k] * v;
    }
  }

  // preconditioned conjugate gradient on A_ff x = rhs from the initial x; returns iterations,
  // sets the relative residual; converged when it is <= tolerance. The residual is CG's
  // recursive one, r -= step A p in double precision with the same operator, which equals the
  // true rhs - A x up to round-off (the single-precision preconditioner only chooses the
  // directions); so no Multiply checks it at the end (FemSolverTest.FastPathAgreesWithDirectPath
  // measures the true one). Only a solve that ran out of iterations gets its true residual,
  // for the caller's fallback.
  int Pcg(const Eigen::VectorXd& rhs, Eigen::VectorXd& x, double& relative_residual,
          double& initial_residual) {
    const double rhs_norm = rhs.norm();
    if (!(rhs_norm > 0.0)) {
      x.setZero();
      relative_residual = initial_residual = 0.0;
      return 0;
    }
    const double tolerance = config.cg_relative_tolerance;
    Multiply(x, ap);
    r = rhs - ap;
    relative_residual = initial_residual = r.norm() / rhs_norm;
    if (relative_residual <= tolerance) return 0;
    ApplyPreconditioner(r, z);
    p = z;
    double rz = r.dot(z);
    int iterations = 0;
    while (iterations < config.cg_max_iterations) {
      ++iterations;
      Multiply(p, ap);
      const double step = rz / p.dot(ap);
      x += step * p;
      r -= step * ap;
      relative_residual = r.norm() / rhs_norm;
      if (relative_residual <= tolerance) return iterations;
      ApplyPreconditioner(r, z);
      const double rz_next = r.dot(z);
      p = z + (rz_next / rz) * p;
      rz = rz_next;
    }
    Multiply(x, ap);
    relative_residual = (rhs - ap).norm() / rhs_norm;
    return iterations;
  }

  void UpdateNodalRotations() {
    const auto& offsets = model.get_node_tet_offsets();
    const auto& node_tets = model.get_node_tets();
    // the volume-weighted mean of each node's element rotations, and its polar factor
    for (int k = 0; k < num_free; ++k) {
      Eigen::Matrix3d& mean = nodal_means[k];
      mean.setZero();
      for (int j = offsets[k]; j < offsets[k + 1]; ++j)
        mean += node_tet_weights[j] * rotations[node_tets[j]];
    }
    CalcPolarRotations(nodal_means.data(), nodal_rotations.data(), nodal_svd.get(), num_free);
    for (int k = 0; k < num_free; ++k)
      warp[k] = nodal_rotations[k] * reference_rotations[k].transpose();
  }

  // factorize this step's A on this thread; the factor becomes exact for this step
  void RefactorizeNow() {
    Assemble(rotated_grad, matrix);
    NSIM_CHECK(active->Factorize(matrix), "system matrix is not positive definite");
    if (active_single) active_single->Assign(active->supernodal_view());
    ++factorizations;
    ++factor_version;
    reference_rotations = nodal_rotations;
    for (auto& q : warp) q.setIdentity();
    factor_is_current = true;
  }

  // waits for the job in flight (if any) to finish; returns whether this thread had to wait
  bool WaitForJob(std::unique_lock<std::mutex>& lock) {
    const bool late = !job_done;
    WaitUntilJobDone(lock);
    job_done = false;
    adopt_step = -1;
    return late;
  }

  // blocks until the worker's job is done (job_done stays set); a held step that waits for the
  // worker opens its gate for the wait, and closes it again after, so that a job requested
  // later in the held step waits for its end
  void WaitUntilJobDone(std::unique_lock<std::mutex>& lock) {
    gate.Open();
    main_waiting = true;
    wake.notify_all();
    wake.wait(lock, [this] { return job_done; });
    main_waiting = false;
    if (holding) gate.Close();
  }

  // adopts the background factorization requested refactor_adopt_delay steps ago: at the start
  // of step adopt_step, waiting for it if needed (FactorAdoption::kScheduled), or at the first
  // step from then on at which the worker is done (kWhenReady, never waiting); returns whether
  // one was adopted, and `lag`, the steps since its request
  bool AdoptBackgroundFactor(bool& waited, int& lag) {
    waited = false;
    if (adopt_step < 0 || step_index < adopt_step) return false;
    std::unique_lock<std::mutex> lock(mutex);
    if (config.refactor_adoption == FactorAdoption::kWhenReady && !job_done) return false;
    const int steps_since_request =
        static_cast<int>(step_index - adopt_step) + config.refactor_adopt_delay;
    waited = WaitForJob(lock);
    if (!job_ok) return false;  // a failed factorization is dropped, the old factor stays
    lag = steps_since_request;
    std::swap(active, spare);
    std::swap(active_single, spare_single);
    std::swap(reference_rotations, background_rotations);
    ++factor_version;
    return true;
  }

  // on one CPU, the core for the refresh in flight (FemConfig::refactor_slice): waits until the
  // worker is done or the slice has passed; returns the seconds waited (0 when nothing waits)
  double GiveSliceToWorker() {
    if (!single_cpu || !(config.refactor_slice > 0.0) || adopt_step < 0) return 0.0;
    const auto start = std::chrono::steady_clock::now();
    gate.Open();
    std::unique_lock<std::mutex> lock(mutex);
    if (job_done) return 0.0;
    wake.wait_for(lock, std::chrono::duration<double>(config.refactor_slice),
                  [this] { return job_done; });
    if (holding) gate.Close();  // the slice is over: the rest of the step is held again
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  // closes the worker's gate for the coming step when FemConfig::refactor_hold_steps asks for
  // it: on one CPU, with a worker, unless the refresh in flight was requested more than that
  // many steps before the coming one; returns whether it closed the gate
  bool Hold() {
    if (config.refactor_hold_steps <= 0 || !single_cpu || !worker.joinable()) return false;
    if (adopt_step >= 0) {
      const std::int64_t requested = adopt_step - config.refactor_adopt_delay;
      if (step_index + 1 - requested > config.refactor_hold_steps) return false;
    }
    gate.Close();
    holding = true;
    return true;
  }
  void Release() {
    holding = false;
    gate.Open();
  }

  // drops the job in flight (waiting for the worker): a factor of this step replaces the old one
  void DiscardBackgroundFactor() {
    if (adopt_step < 0) return;
    std::unique_lock<std::mutex> lock(mutex);
    WaitForJob(lock);
  }

  // hands this step's A to the worker, to be adopted at step step_index + delay; returns
  // false (and does nothing) while a job is in flight
  bool RequestBackgroundFactor() {
    if (adopt_step >= 0) return false;
    background_grad = rotated_grad;
    background_rotations = nodal_rotations;
    {
      std::lock_guard<std::mutex> lock(mutex);
      job_pending = true;
    }
    wake.notify_all();
    adopt_step = step_index + config.refactor_adopt_delay;
    return true;
  }

  // gather the free rows of a 3n x k block into multi_in (3 #free x k)
  void GatherFree(const Eigen::Ref<const Eigen::MatrixXd>& rhs) {
    multi_in.resize(3 * num_free, rhs.cols());
    const auto& free_nodes = model.get_free_nodes();
    for (Eigen::Index c = 0; c < rhs.cols(); ++c)
      for (int k = 0; k < num_free; ++k)
        multi_in.col(c).segment<3>(3 * k) = rhs.col(c).segment<3>(3 * free_nodes[k]);
  }

  // out (3n x k) = A^-1 multi_in, scattered to all nodes with zero Dirichlet rows
  void SolveGathered(Eigen::MatrixXd& out, FemInverse which) {
    const Eigen::Index k = multi_in.cols();
    multi_out.resize(3 * num_free, k);
    if (which == FemInverse::kRestFactor) {
      rest->Solve(multi_in, multi_out);
    } else if (which == FemInverse::kReferenceFactor) {
      active->Solve(multi_in, multi_out);
    } else if (which == FemInverse::kCachedFactor || factor_is_current) {
      multi_rotated.resize(3 * num_free, k);
      ApplyPreconditioner(multi_in, multi_rotated, multi_out);
    } else {
      for (Eigen::Index c = 0; c < k; ++c) {
        b = multi_in.col(c);
        dv.setZero();
        double residual = 0.0, initial = 0.0;
        Pcg(b, dv, residual, initial);
        NSIM_CHECK(residual <= config.cg_relative_tolerance,
                   "PCG for A^-1 column did not converge: relative residual ", residual);
        multi_out.col(c) = dv;
      }
    }
    out.setZero(3 * model.num_nodes(), k);
    const auto& free_nodes = model.get_free_nodes();
    for (Eigen::Index c = 0; c < k; ++c)
      for (int j = 0; j < num_free; ++j)
        out.col(c).segment<3>(3 * free_nodes[j]) = multi_out.col(c).segment<3>(3 * j);
  }
};

FemSolver::FemSolver(const FemModel& model) : model_(model), impl_(std::make_unique<Impl>(model)) {}

FemSolver::~FemSolver() = default;

int FemSolver::get_factorization_count() const { return impl_->factorizations.load(); }

std::uint64_t FemSolver::get_factor_version() const { return impl_->factor_version; }

FemStepStats FemSolver::Step(FemState& state) {
  BeginStep(state);
  CommitStep(state);
  return stats_;
}

FemStepStats FemSolver::BeginStep(FemState& state) {
  Impl& s = *impl_;
  const FemModel& model = model_;
  const int n = model.num_nodes();
  NSIM_CHECK(state.num_nodes() == n && state.v.cols() == n &&
                 static_cast<int>(state.rotations.size()) == model.num_tets(),
             "FemState does not belong to this model");
  const auto& prescribed = model.get_prescribed_nodes();
  if (state.prescribed_positions.cols() != static_cast<Eigen::Index>(prescribed.size()))
    throw InputError(Str("FemState::prescribed_positions must have ", prescribed.size(),
                         " columns, got ", state.prescribed_positions.cols()));
  if (!state.prescribed_positions.allFinite())
    throw InputError("FemState::prescribed_positions must be finite");
  if (state.external_forces.cols() != n || !state.external_forces.allFinite())
    throw InputError(Str("FemState::external_forces must be finite, 3 x ", n));
  stats_ = FemStepStats{};
  ++s.step_index;

  // velocity the Dirichlet nodes must have at the end of the step
  s.full_w = state.v;
  for (int i : model.get_fixed_nodes()) s.full_w.col(i).setZero();
  for (size_t k = 0; k < prescribed.size(); ++k)
    s.full_w.col(prescribed[k]) = (state.prescribed_positions.col(k) - state.x.col(prescribed[k])) / s.h;

  // element pass: rotations, and the elastic part of the right-hand side, h f - (h beta + h^2)
  // K w with w = v (free) / v+ (Dirichlet), in one stress evaluation an element
  // (CalcCorotatedStepLoad; the elastic forces alone are needed only at the supports, for the
  // reactions: CommitStep computes them there)
  s.full_out.setZero();
  const TetBlocks& blocks = model.get_tet_blocks();
  s.RunParts([&](int part) {
    Eigen::Matrix3Xd& load = part == 0 ? s.full_out : s.part_out[part - 1];
    if (part > 0) load.setZero();
    int inverted = 0;
    // kTetLanes elements at a time (TetBlocks): their deformation gradients, rotations,
    // rotated gradients and step loads
    for (int b = s.part_begin[part]; b < s.part_begin[part + 1]; ++b) {
      const int begin = kTetLanes * b;
      const int m = std::min(kTetLanes, blocks.num_tets - begin);
      const TetLanes34& grad = blocks.grad[b];
      const TetLanes34 x = GatherLanes(blocks, b, state.x);
      TetLanes34 u = GatherLanes(blocks, b, s.full_w);
      // F = sum_a x_a g_a^T, then its rotation in place
      TetLanes33 rotation = OuterSumLanes(x, grad);
      bool used_svd[kTetLanes];
      CalcPolarRotationLanes(rotation, m, used_svd);
      for (int l = 0; l < m; ++l) {
        for (int i = 0; i < 9; ++i) s.rotations[begin + l](i) = rotation[i][l];
        inverted += used_svd[l];
      }
      s.rotated_grad[b] = RotateLanes(rotation, grad);
      // the step load h f - c R K_e R^T w (CalcCorotatedStepLoad) of u = h x + c w
      for (int i = 0; i < 12; ++i) u[i] = s.h * x[i] + s.stiffness_scale * u[i];
      const TetLanes34 le =
          ApplyStressLanes(s.rotated_grad[b], -blocks.volume[b], s.lame, s.h, u);
      ScatterAddLanes(blocks, b, le, load);
    }
    s.part_inverted[part] = inverted;
  });
  for (const Eigen::Matrix3Xd& load : s.part_out) s.full_out += load;
  for (int inverted : s.part_inverted) stats_.inverted_tets += inverted;
  state.rotations = s.rotations;
  const Eigen::VectorXd& mass = model.get_lumped_mass();
  const Eigen::Vector3d& g = model.get_config().gravity;

  // reduced right-hand side b_f = [h f - h alpha M v - (h beta + h^2) K w]_f, f = elastic +
  // gravity + external
  const double alpha = model.get_config().rayleigh_mass;
  const auto& free_nodes = model.get_free_nodes();
  for (int k = 0; k < s.num_free; ++k) {
    const int i = free_nodes[k];
    s.b.segment<3>(3 * k) = s.full_out.col(i) +
                            s.h * (mass[i] * g + state.external_forces.col(i) -
                                   alpha * mass[i] * state.v.col(i));
    // warm start: the free end velocity extrapolated from the previous steps (warm_start.h),
    // minus v (which carries the last correction: a contact's impulse is not extrapolated)
    const auto& changes = state.free_velocity_changes;
    s.dv.segment<3>(3 * k) =
        state.free_velocity.col(i) - state.v.col(i) +
        ExtrapolateWarmStart(state.warm_start_order, changes[0].col(i), changes[1].col(i),
                             changes[2].col(i));
  }

  // solve A_ff dv_f = b_f
  s.factor_is_current = false;
  if (model.get_config().linear_solver == FemLinearSolver::kDirect) {
    s.RefactorizeNow();
    stats_.refactorized = true;
    s.active->Solve(s.b, s.dv);
    s.Multiply(s.dv, s.ap);
    const double b_norm = s.b.norm();
    stats_.relative_residual = b_norm > 0 ? (s.b - s.ap).norm() / b_norm : 0.0;
  } else {
    stats_.factor_swapped = s.AdoptBackgroundFactor(stats_.waited_for_worker, stats_.adoption_lag);
    s.UpdateNodalRotations();
    stats_.cg_iterations =
        s.Pcg(s.b, s.dv, stats_.relative_residual, stats_.initial_residual);
    if (stats_.relative_residual > model.get_config().cg_relative_tolerance) {
      // never truncated: solve with a fresh factor of this step's A (an older one in flight
      // is dropped)
      s.DiscardBackgroundFactor();
      s.RefactorizeNow();
      stats_.refactorized = true;
      stats_.fell_back_to_direct = true;
      s.active->Solve(s.b, s.dv);
      s.Multiply(s.dv, s.ap);
      stats_.relative_residual = (s.b - s.ap).norm() / s.b.norm();
    } else if (stats_.cg_iterations > model.get_config().refactor_iteration_threshold) {
      if (s.worker.joinable()) {
        stats_.refresh_requested = s.RequestBackgroundFactor();
      } else {
        s.RefactorizeNow();
        stats_.refactorized = true;
      }
    }
    stats_.slice_wait = s.GiveSliceToWorker();
  }

  // free motion
  for (int i = 0; i < n; ++i) state.dv_free.col(i) = s.full_w.col(i) - state.v.col(i);
  for (int k = 0; k < s.num_free; ++k) state.dv_free.col(free_nodes[k]) = s.dv.segment<3>(3 * k);
  // the warm start's history: this step's change of the free end velocity, and the order
  // that would have predicted it best
  auto& changes = state.free_velocity_changes;
  s.velocity_change = state.v + state.dv_free - state.free_velocity;
  WarmStartErrors errors;
  for (int k = 0; k < s.num_free; ++k) {
    const int i = free_nodes[k];
    errors.Add(s.velocity_change.col(i), changes[0].col(i), changes[1].col(i), changes[2].col(i));
  }
  state.warm_start_order = errors.ChooseOrder();
  state.free_velocity += s.velocity_change;
  changes[2].swap(changes[1]);
  changes[1].swap(changes[0]);
  changes[0].swap(s.velocity_change);
  state.x_free = state.x + s.h * (state.v + state.dv_free);
  return stats_;
}

void FemSolver::ApplyInverse(const Eigen::Ref<const Eigen::MatrixXd>& rhs, Eigen::MatrixXd& out,
                             FemInverse which) {
  NSIM_CHECK(rhs.rows() == 3 * model_.num_nodes(), "ApplyInverse needs 3n = ",
             3 * model_.num_nodes(), " rows, got ", rhs.rows());
  impl_->GatherFree(rhs);
  impl_->SolveGathered(out, which);
}

void FemSolver::ApplyInverse(const Eigen::SparseMatrix<double>& rhs, Eigen::MatrixXd& out,
                             FemInverse which) {
  NSIM_CHECK(rhs.rows() == 3 * model_.num_nodes(), "ApplyInverse needs 3n = ",
             3 * model_.num_nodes(), " rows, got ", rhs.rows());
  Impl& s = *impl_;
  s.multi_in.setZero(3 * s.num_free, rhs.cols());
  for (int c = 0; c < rhs.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(rhs, c); it; ++it) {
      const int row = static_cast<int>(it.row());
      const int k = model_.get_free_index(row / 3);
      if (k >= 0) s.multi_in(3 * k + row % 3, c) += it.value();
    }
  s.SolveGathered(out, which);
}

void FemSolver::CommitStep(FemState& state) {
  CommitStep(state, impl_->zero_correction);
}

void FemSolver::CommitStep(FemState& state, const Eigen::Ref<const Eigen::VectorXd>& dv_correction) {
  Impl& s = *impl_;
  const FemModel& model = model_;
  const int n = model.num_nodes();
  if (dv_correction.size() != 3 * n)
    throw InputError(Str("velocity correction must have 3n = ", 3 * n, " entries, got ",
                         dv_correction.size()));
  if (!dv_correction.allFinite())
    throw SolverError("the constraint velocity correction is not finite (the solve diverged)");
  const auto& dirichlet = model.get_dirichlet_nodes();
  for (int i : dirichlet)
    if (dv_correction.segment<3>(3 * i).squaredNorm() != 0.0)
      throw InputError(Str("velocity correction must be zero at Dirichlet node ", i));

  // total dv (full_w) and dv + v (full_out) for the reactions
  for (int i = 0; i < n; ++i) {
    s.full_w.col(i) = state.dv_free.col(i) + dv_correction.segment<3>(3 * i);
    s.full_sum.col(i) = s.full_w.col(i) + state.v.col(i);
  }

  // reactions r_d = [(1 + h alpha) M dv + h alpha M v + (h beta + h^2) K (dv + v)]_d / h - f_d,
  // f_d the forces at the step start (x not yet advanced, this step's rotations): elastic +
  // gravity + external. The elastic part, (h beta + h^2) / h K (dv + v) - f_elastic, is minus
  // the step load of x and dv + v over h (CalcCorotatedStepLoad: h f - c K w), one stress
  // evaluation an element
  const auto& tets = model.get_mesh().tets;
  for (int i : dirichlet) s.support_elastic.col(i).setZero();
  for (int e : model.get_dirichlet_tets()) {
    const Eigen::Vector4i& t = tets[e];
    Matrix34d pe, xe;
    for (int a = 0; a < 4; ++a) {
      pe.col(a) = s.full_sum.col(t[a]);
      xe.col(a) = state.x.col(t[a]);
    }
    const Matrix34d le = CalcCorotatedStepLoad(model.get_rest_shapes()[e], s.lame,
                                               ElementOfLanes(s.rotated_grad, e), xe, pe, s.h,
                                               s.stiffness_scale);
    for (int a = 0; a < 4; ++a)
      if (model.get_free_index(t[a]) < 0) s.support_elastic.col(t[a]) -= le.col(a) / s.h;
  }
  const double alpha = model.get_config().rayleigh_mass;
  const Eigen::VectorXd& mass = model.get_lumped_mass();
  const Eigen::Vector3d& g = model.get_config().gravity;
  for (size_t j = 0; j < dirichlet.size(); ++j) {
    const int i = dirichlet[j];
    state.reaction_forces.col(j) =
        (s.mass_scale * mass[i] * s.full_w.col(i) + s.h * alpha * mass[i] * state.v.col(i)) / s.h +
        s.support_elastic.col(i) - (mass[i] * g + state.external_forces.col(i));
  }

  // advance
  state.v += s.full_w;
  state.x += s.h * state.v;
  const auto& prescribed = model.get_prescribed_nodes();
  for (size_t k = 0; k < prescribed.size(); ++k) state.x.col(prescribed[k]) = state.prescribed_positions.col(k);
  state.time += s.h;
}

void FemSolver::WaitForBackgroundFactorization() {
  Impl& s = *impl_;
  if (!s.worker.joinable() || s.adopt_step < 0) return;
  std::unique_lock<std::mutex> lock(s.mutex);
  s.WaitUntilJobDone(lock);  // job_done stays set: adopted on schedule
}

FemSolver::RefreshHold FemSolver::HoldRefresh() {
  return RefreshHold(impl_->Hold() ? impl_.get() : nullptr);
}

FemSolver::RefreshHold::~RefreshHold() {
  if (impl_) impl_->Release();
}

FemSolver::RefreshHold::RefreshHold(RefreshHold&& other) noexcept
    : impl_(std::exchange(other.impl_, nullptr)) {}

long FemSolver::get_refresh_gate_waits() const { return impl_->gate.waits(); }

void FemSolver::AssumeOneCpuForTesting(bool one_cpu) { impl_->single_cpu = one_cpu; }

void FemSolver::HoldWorkerForTesting(bool hold) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->hold_worker = hold;
}

void FemSolver::SetWorkerDelayForTesting(std::chrono::microseconds delay) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->worker_delay = delay;
}

const Eigen::SparseMatrix<double>& FemSolver::CalcSystemMatrix() {
  impl_->Assemble(impl_->rotated_grad, impl_->matrix);
  // the assembled values no longer match a factor made from a different A; the factor itself
  // is untouched, so nothing else changes
  return impl_->matrix;
}

const std::vector<std::string>& ConstraintComplianceNames() {
  static const std::vector<std::string> names = {"rest", "last_factor"};
  return names;
}

FemInverse SelectConstraintCompliance(bool rest) {
  return rest ? FemInverse::kRestFactor : FemInverse::kReferenceFactor;
}

}  // namespace nsim
