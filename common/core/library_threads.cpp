#include "common/core/library_threads.h"

#include <unistd.h>

#include <cstdlib>

namespace nsim {

bool SetOneLibraryThreadWhereUnset() {
  bool changed = false;
  for (const char* name : kLibraryThreadVariables) {
    if (std::getenv(name) != nullptr) continue;
    setenv(name, "1", /*overwrite=*/0);
    changed = true;
  }
  return changed;
}

void UseOneLibraryThreadUnlessSet(char** argv) {
  if (!SetOneLibraryThreadWhereUnset()) return;
  execv("/proc/self/exe", argv);  // returns only on failure: keep running as we are
}

}  // namespace nsim
