#include "common/core/line_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "common/core/error.h"

namespace nsim {

LineFile::LineFile(const std::string& path, Mode mode) : path_(path), mode_(mode) {
  fd_ = ::open(partial_path().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw InputError(Str(partial_path(), ": cannot open for writing: ", std::strerror(errno)));
}

LineFile::~LineFile() {
  if (fd_ >= 0) ::close(fd_);
}

void LineFile::WriteLine(const std::string& line) {
  if (fd_ < 0) throw std::runtime_error(Str(path_, ": write after the file was committed"));
  const std::string text = line + "\n";
  size_t done = 0;
  // a regular file takes the whole line in one write unless the disk is full; the loop only
  // finishes such a short write or one interrupted before any byte was written
  while (done < text.size()) {
    const ssize_t n = ::write(fd_, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      throw std::runtime_error(Str(partial_path(), ": write failed: ", std::strerror(errno)));
    done += static_cast<size_t>(n);
  }
}

void LineFile::Commit() {
  if (fd_ < 0) return;
  const int fd = fd_;
  fd_ = -1;
  if (::fsync(fd) != 0 || ::close(fd) != 0)
    throw std::runtime_error(Str(partial_path(), ": cannot flush: ", std::strerror(errno)));
  if (mode_ == Mode::kPartial && std::rename(partial_path().c_str(), path_.c_str()) != 0)
    throw std::runtime_error(
        Str(partial_path(), ": cannot rename to ", path_, ": ", std::strerror(errno)));
}

}  // namespace nsim
