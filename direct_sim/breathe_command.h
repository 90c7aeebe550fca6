#pragma once
// `direct_sim breathe`: writes a synthetic breathing marker stream (CSV) for offline prediction
// studies and replay.

namespace nsim {

/// Runs the `breathe` subcommand; argv[0] is "breathe". Options: --out OUT.csv (required),
/// --duration, --rate, --markers, --seed, breathing shape and placement options (see --help).
/// Returns 0 on success (also after --help). Throws InputError on bad options or values.
int RunBreathe(int argc, char** argv);

}  // namespace nsim
