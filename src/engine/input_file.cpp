// The bounded reader behind every input file (include/lancer/input_file.hpp).
#include "lancer/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <new>

#include "lancer/error.hpp"
#include "lancer/text.hpp"

namespace lancer {

namespace {
struct Fd {
  int fd;
  ~Fd() {
    if (fd >= 0) close(fd);
  }
};
}  // namespace

std::string read_input_file(const std::string& path, std::size_t max_bytes, const char* what,
                            const char* limit) {
  // O_NONBLOCK: opening a FIFO for reading otherwise waits for a writer, for ever if none comes.
  // fstat on what was opened, not stat on the name, so that the checks and the read see one file.
  const Fd f{open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
  if (f.fd < 0) {
    const int err = errno;
    if (err == EISDIR) throw InputError(shown_path(path) + ": is a folder, not a " + what);
    throw InputError(shown_path(path) + ": cannot open " + what +
                     (err == ENOENT ? std::string() : std::string(": ") + std::strerror(err)));
  }
  struct stat st;
  if (fstat(f.fd, &st) != 0)
    throw InputError(shown_path(path) + ": cannot read " + what + ": " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw InputError(shown_path(path) + ": is a folder, not a " + what);
  // A pipe, a device or a socket could block or never end (/dev/zero): only regular files.
  if (!S_ISREG(st.st_mode))
    throw InputError(shown_path(path) +
                     ": is not a regular file (a pipe, a device or a socket); lancer reads " +
                     what + "s from regular files only");
  if (std::size_t(st.st_size) > max_bytes)
    throw InputError(shown_path(path) + ": file larger than " + limit);
  std::string text;
  // The size fstat gave in one allocation (no copy of a large scene on the way), then what a
  // growing file adds, up to the limit.
  auto read_some = [&](char* into, std::size_t n) {
    for (;;) {
      const ssize_t got = read(f.fd, into, n);
      if (got >= 0) return std::size_t(got);
      if (errno != EINTR)
        throw InputError(shown_path(path) + ": cannot read " + what + ": " + std::strerror(errno));
    }
  };
  try {
    text.resize(std::size_t(st.st_size));
    std::size_t got = 0;
    while (got < text.size()) {
      const std::size_t n = read_some(text.data() + got, text.size() - got);
      if (n == 0) break;
      got += n;
    }
    text.resize(got);
    char more[1 << 14];
    while (const std::size_t n = read_some(more, sizeof more)) {
      if (text.size() + n > max_bytes)
        throw InputError(shown_path(path) + ": file larger than " + limit);
      text.append(more, n);
    }
  } catch (const std::bad_alloc&) {
    throw InputError(shown_path(path) + ": out of memory while reading the " + what);
  }
  return text;
}

}  // namespace lancer
