#include "common/core/thread_priority.h"

#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "common/core/error.h"

namespace nsim {

bool LowerThisThreadToIdle() {
  sched_param param{};
  param.sched_priority = 0;
  // pid 0: the calling thread (Linux schedules threads, not processes)
  if (sched_setscheduler(0, SCHED_IDLE, &param) == 0) return true;
  return setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 19) == 0;
}

bool MoveThisThreadToNormalClass() {
  if (sched_getscheduler(0) == SCHED_OTHER) return true;
  sched_param param{};
  param.sched_priority = 0;
  return sched_setscheduler(0, SCHED_OTHER, &param) == 0;
}

std::string RaiseThisThreadToFifo(int priority) {
  const int lowest = sched_get_priority_min(SCHED_FIFO),
            highest = sched_get_priority_max(SCHED_FIFO);
  if (priority < lowest || priority > highest)
    return Str("the realtime priority must be in [", lowest, ", ", highest, "], got ", priority);
  sched_param param{};
  param.sched_priority = priority;
  if (sched_setscheduler(0, SCHED_FIFO, &param) == 0) return "";
  const int error = errno;
  if (error == EPERM) {
    rlimit limit{};
    getrlimit(RLIMIT_RTPRIO, &limit);
    return Str(
        "SCHED_FIFO at priority ", priority,
        " is not permitted: needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least ", priority,
        " (this process has ",
        limit.rlim_cur == RLIM_INFINITY ? std::string("unlimited") : std::to_string(limit.rlim_cur),
        "; `ulimit -r`, limits.conf rtprio)");
  }
  return Str("SCHED_FIFO at priority ", priority, ": ", std::strerror(error));
}

FifoScope::FifoScope(int priority) {
  if (priority == 0) return;
  error_ = RaiseThisThreadToFifo(priority);
  raised_ = error_.empty();
}

FifoScope::~FifoScope() {
  if (raised_) MoveThisThreadToNormalClass();  // lowering the class is always permitted
}

std::string ThisThreadPolicyName() {
  const int policy = sched_getscheduler(0);
  switch (policy) {
    case SCHED_FIFO:
      return "fifo";
    case SCHED_RR:
      return "rr";
    case SCHED_IDLE:
      return "idle";
    case SCHED_BATCH:
      return "batch";
    case SCHED_OTHER:
      return "other";
    default:
      return Str("policy ", policy);
  }
}

}  // namespace nsim
