// The file an output is written to: every write checked, the first failure kept. Header-only so
// that lancer's image module (src/image_oiio.cpp, loaded with dlopen) writes through it too.
#pragma once

#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <stdexcept>

namespace lancer {

// Output lost: the work was done but its file could not be written (a full disk, an I/O error).
// The old file, if any, is intact and no temporary file is left. Exit status 4.
struct OutputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The writers (ours, cairo's, OpenImageIO's) all write through here, so that no library can lose
// a failed write: libpng, cairo's PDF stream and OpenImageIO's BMP and Targa writers ignore some
// of the write errors they meet and report success with a truncated file. A failure is kept and
// the writer is told the bytes went, so that no library's own error path (libjpeg's calls exit())
// runs; the caller asks error() when the writer is done, and compares the file's size with
// end() as a last check that every byte came through here.
class OutputFile {
 public:
  explicit OutputFile(int fd) : fd_(fd) {}

  // Writes at the current position and moves it on.
  void write(const void* data, std::size_t n) {
    pwrite(data, n, pos_);
    pos_ += n;
  }
  void pwrite(const void* data, std::size_t n, std::uint64_t offset) {
    if (error_ != 0) return;  // the file is lost already
    const char* p = static_cast<const char*>(data);
    while (n > 0) {
      const ssize_t w = ::pwrite(fd_, p, n, static_cast<off_t>(offset));
      if (w < 0 && errno == EINTR) continue;
      if (w <= 0) {
        error_ = w < 0 ? errno : EIO;  // no progress is a failure too (never a busy loop)
        return;
      }
      p += w, n -= std::size_t(w), offset += std::uint64_t(w);
      if (offset > end_) end_ = offset;
    }
  }
  // Reads back what was written (TIFF's writer rereads its directory); 0 bytes on failure.
  std::size_t pread(void* data, std::size_t n, std::uint64_t offset) const {
    const ssize_t r = ::pread(fd_, data, n, static_cast<off_t>(offset));
    return r < 0 ? 0 : std::size_t(r);
  }
  void seek(std::uint64_t pos) { pos_ = pos; }
  std::uint64_t tell() const { return pos_; }
  // One past the last byte written: the size the file must have.
  std::uint64_t end() const { return end_; }
  // The errno of the first failed write, or 0.
  int error() const { return error_; }
  // A failure found by the writer itself (its own check, an encoder's error).
  void fail(int err) {
    if (error_ == 0) error_ = err;
  }

 private:
  int fd_;
  std::uint64_t pos_ = 0, end_ = 0;
  int error_ = 0;
};

}  // namespace lancer
