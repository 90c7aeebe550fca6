#pragma once
// Reading user-supplied files safely (DESIGN.md "Bad input and faults"): every reader of a
// scenario, a mesh or a marker CSV goes through ReadInputFile, which accepts only a regular
// file of bounded size. A device (/dev/zero never ends), a fifo (blocks, or never ends), a
// directory or a file larger than the limit is an InputError naming the path, before anything
// is allocated for its contents.

#include <cstdint>
#include <string>

namespace nsim {

/// The largest input file read (bytes): 512 MiB. The finest committed liver mesh (9991 nodes)
/// is about 3 MB and an hour of 30 Hz marker CSV with 64 markers is about 0.4 GB at 17
/// significant digits, so this refuses nothing real while bounding the memory a reader takes.
constexpr uint64_t kMaxInputFileBytes = uint64_t{512} << 20;

/// Opens `path` (without blocking on a fifo), checks it is a regular file of at most
/// `max_bytes` and returns its whole contents. InputError "<path>: <what> ..." when it does
/// not exist, cannot be read, is not a regular file or is too large; `what` says what the file
/// was meant to be ("mesh file", "marker CSV").
std::string ReadInputFile(const std::string& path, const std::string& what,
                          uint64_t max_bytes = kMaxInputFileBytes);

}  // namespace nsim
