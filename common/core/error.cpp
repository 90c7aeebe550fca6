#include "common/core/error.h"

#include <cstdio>
#include <cstdlib>

namespace nsim {

void AbortCheck(const char* condition, const char* file, int line, const std::string& message) {
  std::fprintf(stderr, "internal error: check '%s' failed at %s:%d%s%s\n", condition, file, line,
               message.empty() ? "" : ": ", message.c_str());
  std::fflush(stderr);
  std::abort();
}

}  // namespace nsim
