// Fault injection for the output writers (tests/fuzz/test_writers.cpp), loaded with LD_PRELOAD
// into the CLI. LANCER_FAULT=<call>:<n> makes the n-th call (from 1) of pwrite, fsync, close or
// rename on a temporary output file (`.<name>.lancer-XXXXXX`, not the path probe) fail: pwrite
// with ENOSPC (a full disk), fsync and close with EIO, rename with EIO. When it fires it appends
// "<call>:<n>" to the file LANCER_FAULT_LOG, so that the test knows the call was reached.
// LANCER_SLOW_CREATE=<ms> keeps mkostemp from returning for that long after it has created a
// temporary output file: a writer descheduled right after the creation, when a signal comes
// (tests/fuzz/test_output.cpp).
#include <dlfcn.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>

namespace {

int is_output_name(const char* path) {
  return path && strstr(path, ".lancer-") && !strstr(path, ".lancer-probe-");
}

int is_output_fd(int fd) {
  char link[64], target[4096];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, target, sizeof target - 1);
  if (n <= 0) return 0;
  target[n] = '\0';
  return is_output_name(target);
}

// Whether this call (the count-th of `call` on an output file) is the one to fail.
int should_fail(const char* call) {
  static int counts[4];
  static const char* const calls[4] = {"pwrite", "fsync", "close", "rename"};
  const char* spec = getenv("LANCER_FAULT");
  if (!spec) return 0;
  int k = 0;
  while (k < 4 && strcmp(calls[k], call) != 0) ++k;
  if (k == 4) return 0;
  const int count = ++counts[k];
  const size_t len = strlen(call);
  if (strncmp(spec, call, len) != 0 || spec[len] != ':' || atoi(spec + len + 1) != count) return 0;
  const char* log = getenv("LANCER_FAULT_LOG");
  if (log) {
    FILE* f = fopen(log, "a");
    if (f) {
      fprintf(f, "%s:%d\n", call, count);
      fclose(f);
    }
  }
  return 1;
}

template <class F>
F real(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

}  // namespace

extern "C" {

ssize_t pwrite64(int fd, const void* buf, size_t n, off64_t offset) {
  if (is_output_fd(fd) && should_fail("pwrite")) {
    errno = ENOSPC;
    return -1;
  }
  return real<ssize_t (*)(int, const void*, size_t, off64_t)>("pwrite64")(fd, buf, n, offset);
}

ssize_t pwrite(int fd, const void* buf, size_t n, off_t offset) {
  return pwrite64(fd, buf, n, offset);
}

int fsync(int fd) {
  if (is_output_fd(fd) && should_fail("fsync")) {
    errno = EIO;
    return -1;
  }
  return real<int (*)(int)>("fsync")(fd);
}

int close(int fd) {
  // The descriptor is closed whatever close() reports (Linux), so close it and then fail.
  const int fail = is_output_fd(fd) && should_fail("close");
  const int r = real<int (*)(int)>("close")(fd);
  if (fail) {
    errno = EIO;
    return -1;
  }
  return r;
}

int mkostemp(char* pattern, int flags) {
  const int fd = real<int (*)(char*, int)>("mkostemp")(pattern, flags);
  const char* ms = getenv("LANCER_SLOW_CREATE");
  if (fd >= 0 && ms && strstr(pattern, ".lancer-") && !strstr(pattern, ".lancer-probe-")) {
    const long n = atol(ms);
    timespec t{n / 1000, (n % 1000) * 1000000L};
    while (nanosleep(&t, &t) != 0 && errno == EINTR) {
    }
  }
  return fd;
}

int rename(const char* from, const char* to) noexcept {
  if (is_output_name(from) && should_fail("rename")) {
    errno = EIO;
    return -1;
  }
  return real<int (*)(const char*, const char*)>("rename")(from, to);
}

}  // extern "C"
