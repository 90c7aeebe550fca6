#pragma once
// SIGINT/SIGTERM turned into a flag that long-running loops poll, so they stop cleanly
// (flush files, publish a final status) instead of dying mid-write.

namespace nsim {

/// Installs handlers for SIGINT and SIGTERM that set the interrupt flag. Idempotent.
void InstallInterruptHandler();

/// True once SIGINT or SIGTERM was received.
bool InterruptRequested();

}  // namespace nsim
