#pragma once

namespace nsim {

/// `direct_sim replay --markers IN.csv`: publishes a recorded marker stream over DDS at its
/// recorded timing (scaled by --rate-scale), numbered from 0, then signals the end of the stream
/// with a SimStatus "finished" carrying the last sequence number.
int RunReplay(int argc, char** argv);

}  // namespace nsim
