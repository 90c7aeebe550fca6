#include "common/core/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "common/core/error.h"

namespace nsim {
namespace {

// closes the descriptor on every path out
class Descriptor {
 public:
  explicit Descriptor(int fd) : fd_(fd) {}
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

std::string KindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a fifo";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

std::string ReadInputFile(const std::string& path, const std::string& what, uint64_t max_bytes) {
  if (path.empty()) throw InputError(Str("empty path: expected a ", what));
  // O_NONBLOCK: opening a fifo for reading would wait for a writer; it is refused below anyway
  const Descriptor fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC));
  if (fd.get() < 0) {
    const int error = errno;
    // a missing file is the common case: "cannot open the file" says it; others say why
    throw InputError(Str(path, ": cannot open the ", what,
                         error == ENOENT ? std::string() : Str(": ", std::strerror(error))));
  }
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0)
    throw InputError(Str(path, ": cannot read the ", what, ": ", std::strerror(errno)));
  if (!S_ISREG(st.st_mode))
    throw InputError(Str(path, ": expected a regular file as the ", what, ", got ",
                         KindOf(st.st_mode)));
  const uint64_t size = static_cast<uint64_t>(st.st_size);
  if (size > max_bytes)
    throw InputError(Str(path, ": the ", what, " is ", size, " bytes, more than the limit of ",
                         max_bytes, " bytes"));
  std::string text(size, '\0');
  size_t done = 0;
  while (done < size) {
    const ssize_t n = ::read(fd.get(), &text[done], size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0)
      throw InputError(Str(path, ": cannot read the ", what, ": ", std::strerror(errno)));
    if (n == 0) break;  // the file shrank while being read: parse what is there
    done += static_cast<size_t>(n);
  }
  text.resize(done);
  return text;
}

}  // namespace nsim
