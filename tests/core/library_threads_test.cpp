#include "common/core/library_threads.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace nsim {
namespace {

TEST(LibraryThreadsTest, UnsetVariablesBecomeOneAndUserValuesStay) {
  unsetenv("OPENBLAS_NUM_THREADS");
  setenv("OMP_NUM_THREADS", "4", 1);  // the user asked for threads
  unsetenv("OMP_THREAD_LIMIT");
  EXPECT_TRUE(SetOneLibraryThreadWhereUnset());
  EXPECT_EQ(std::string(std::getenv("OPENBLAS_NUM_THREADS")), "1");
  EXPECT_EQ(std::string(std::getenv("OMP_NUM_THREADS")), "4");
  EXPECT_EQ(std::string(std::getenv("OMP_THREAD_LIMIT")), "1");
  // all set now: nothing to change, so main would not re-execute
  EXPECT_FALSE(SetOneLibraryThreadWhereUnset());
}

}  // namespace
}  // namespace nsim
