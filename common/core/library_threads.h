#pragma once
// One thread for the numerical libraries unless the user chose otherwise.
//
// CHOLMOD (Debian's SuiteSparse 5) runs parts of its supernodal factorization with
// `omp parallel num_threads(4)`, whatever OMP_NUM_THREADS says (CholmodFactor now also keeps
// them on its calling thread itself, common/fem/cholmod_factor.cpp), and OpenBLAS starts one
// thread per core. The two simulation processes already share the cores, so these threads only wait
// for each other: measured on 2 cores, a factor refresh of the 2660-node liver took 135-150 ms
// inside direct_sim instead of 55-67 ms with one thread, and a closed-loop run spent 33 s of a
// 40 s run in the kernel. The libraries read their settings from the environment when they are
// loaded, before main, so they can only be changed by starting the program again.

namespace nsim {

/// The variables that set the libraries' thread counts.
inline constexpr const char* kLibraryThreadVariables[] = {"OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                                                          "OMP_THREAD_LIMIT"};

/// Sets each of kLibraryThreadVariables that is unset to 1 in this process's environment;
/// returns whether one was unset. Values the user set are kept.
bool SetOneLibraryThreadWhereUnset();

/// SetOneLibraryThreadWhereUnset(), and when it changed something, re-executes the program with
/// the same arguments (same PID) so that the libraries load with the new settings. Call first
/// thing in main. Does nothing when all three are set (a user who wants threads sets them, e.g.
/// all to 4), and returns without a change if the program cannot be re-executed.
void UseOneLibraryThreadUnlessSet(char** argv);

}  // namespace nsim
