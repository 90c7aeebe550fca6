// The scheduling classes of common/core/thread_priority.h, each checked in a thread of its own
// (the test process keeps its class) by reading the class back from the kernel.

#include "common/core/thread_priority.h"

#include <gtest/gtest.h>
#include <sched.h>

#include <string>
#include <thread>

namespace nsim {
namespace {

// runs f on a new thread and waits for it
template <typename F>
void OnAThread(F&& f) {
  std::thread t(std::forward<F>(f));
  t.join();
}

TEST(ThreadPriorityTest, PrioritiesOutsideTheRangeAreRefusedAndChangeNothing) {
  OnAThread([] {
    for (int priority : {-1, 100, 1000}) {
      const std::string error = RaiseThisThreadToFifo(priority);
      EXPECT_NE(error.find("must be in [1, 99]"), std::string::npos) << error;
      EXPECT_NE(error.find(std::to_string(priority)), std::string::npos) << error;
      EXPECT_EQ(ThisThreadPolicyName(), "other");
    }
  });
}

TEST(ThreadPriorityTest, FifoScopeRaisesForItsLifetimeOrSaysWhyNot) {
  OnAThread([] {
    {
      const FifoScope none(0);  // 0: nothing asked, nothing changed
      EXPECT_FALSE(none.raised());
      EXPECT_TRUE(none.error().empty());
      EXPECT_EQ(ThisThreadPolicyName(), "other");
    }
    {
      const FifoScope fifo(5);
      if (fifo.raised()) {
        EXPECT_TRUE(fifo.error().empty());
        EXPECT_EQ(ThisThreadPolicyName(), "fifo");
        sched_param param{};
        ASSERT_EQ(sched_getparam(0, &param), 0);
        EXPECT_EQ(param.sched_priority, 5);
      } else {
        // without CAP_SYS_NICE or RLIMIT_RTPRIO: the reason, and the class unchanged
        EXPECT_NE(fifo.error().find("not permitted"), std::string::npos) << fifo.error();
        EXPECT_EQ(ThisThreadPolicyName(), "other");
      }
    }
    EXPECT_EQ(ThisThreadPolicyName(), "other");  // back in the normal class
  });
}

TEST(ThreadPriorityTest, IdleIsTheLowestClassAndAnyThreadMayTakeIt) {
  OnAThread([] {
    EXPECT_TRUE(LowerThisThreadToIdle());
    EXPECT_EQ(ThisThreadPolicyName(), "idle");
  });
  EXPECT_EQ(ThisThreadPolicyName(), "other");  // only the thread that asked
}

}  // namespace
}  // namespace nsim
