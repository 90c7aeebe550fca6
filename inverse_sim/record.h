#pragma once

namespace nsim {

/// `inverse_sim record --out OUT.csv`: writes every received MarkerFrame to a marker CSV, exits
/// at the end of the stream, and reports received, missing (sequence gaps), out-of-order and
/// invalid frames. Notices a dead publisher through its liveliness lease.
int RunRecord(int argc, char** argv);

}  // namespace nsim
