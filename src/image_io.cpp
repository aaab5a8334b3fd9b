// Image files. PFM by our own writer (OpenImageIO 2.4 reads PFM but cannot write it); every other
// format through OpenImageIO. Files appear whole or not at all.
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>

#include "lancer/error.hpp"
#include "lancer/image.hpp"

namespace lancer {

namespace fs = std::filesystem;

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// Formats that keep radiance as floats, unclamped; the rest are 8-bit, clamped and rounded.
bool is_float_format(const std::string& ext) {
  return ext == ".pfm" || ext == ".exr" || ext == ".hdr" || ext == ".tif" || ext == ".tiff";
}

// The temporary file being written, so that a signal handler can remove it. One write at a time
// per process is all lancer does.
char g_pending[4096];
std::atomic<bool> g_has_pending{false};

void set_pending(const std::string& path) {
  std::snprintf(g_pending, sizeof g_pending, "%s", path.c_str());
  g_has_pending = true;
}
void clear_pending() { g_has_pending = false; }

// The signals whose handler (src/cli/main.cpp) removes the pending file. Held back while a
// temporary file is created and registered, so that no signal finds it created but unknown.
class HoldTerminationSignals {
 public:
  HoldTerminationSignals() {
    sigset_t hold;
    sigemptyset(&hold);
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&hold, sig);
    pthread_sigmask(SIG_BLOCK, &hold, &previous_);
  }
  ~HoldTerminationSignals() { pthread_sigmask(SIG_SETMASK, &previous_, nullptr); }
  HoldTerminationSignals(const HoldTerminationSignals&) = delete;
  HoldTerminationSignals& operator=(const HoldTerminationSignals&) = delete;

 private:
  sigset_t previous_;
};

// A fresh temporary file beside `target`, so that the final rename stays on one file system:
// `.<name>.lancer-XXXXXX` (`.<name>.lancer-probe-XXXXXX` for the writability probe). It is the
// pending file from the moment it exists.
std::string make_pending_beside(const std::string& target, const char* kind = "lancer-") {
  fs::path t(target);
  fs::path dir = t.parent_path().empty() ? fs::path(".") : t.parent_path();
  std::string pattern = (dir / ("." + t.filename().string() + "." + kind + "XXXXXX")).string();
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  const HoldTerminationSignals hold;
  int fd = mkstemp(buf.data());
  if (fd < 0)
    throw InputError(target + ": cannot create a file in " + dir.string() + ": " +
                     std::strerror(errno));
  close(fd);
  set_pending(buf.data());
  return buf.data();
}

void write_pfm(const Image& im, const std::string& path) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) throw InputError(path + ": cannot open for writing: " + std::strerror(errno));
  // A negative scale means little-endian; rows go bottom to top.
  std::fprintf(f.get(), "PF\n%d %d\n-1.0\n", im.nx, im.ny);
  static_assert(sizeof(float) == 4, "PFM stores 32-bit floats");
  for (int j = im.ny - 1; j >= 0; --j) {
    if (std::fwrite(im.pixel(0, j), sizeof(float), std::size_t(im.nx) * 3, f.get()) !=
        std::size_t(im.nx) * 3)
      throw InputError(path + ": write failed: " + std::strerror(errno));
  }
  if (std::fflush(f.get()) != 0) throw InputError(path + ": write failed: " + std::strerror(errno));
}

void write_oiio(const Image& im, const std::string& format_path, const std::string& path) {
  auto out = OIIO::ImageOutput::create(format_path);
  if (!out) throw InputError(format_path + ": unknown image format");
  const std::string ext = lower_extension(format_path);
  if (is_float_format(ext)) {
    OIIO::ImageSpec spec(im.nx, im.ny, 3, OIIO::TypeDesc::FLOAT);
    if (!out->open(path, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, im.rgb.data()) ||
        !out->close())
      throw InputError(format_path + ": " + out->geterror());
    return;
  }
  // Clamp to [0, 1] and round to the nearest of 256 levels ourselves, so every format agrees.
  std::vector<unsigned char> bytes(im.rgb.size());
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    const float v = im.rgb[k];
    const float c = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;  // NaN -> 0
    bytes[k] = static_cast<unsigned char>(std::lround(c * 255.0f));
  }
  OIIO::ImageSpec spec(im.nx, im.ny, 3, OIIO::TypeDesc::UINT8);
  if (!out->open(path, spec) || !out->write_image(OIIO::TypeDesc::UINT8, bytes.data()) ||
      !out->close())
    throw InputError(format_path + ": " + out->geterror());
}

}  // namespace

void remove_pending_outputs() noexcept {
  if (g_has_pending.exchange(false)) unlink(g_pending);  // async-signal-safe
}

void check_writable_target(const std::string& path, const std::string& scene_path) {
  if (path.empty()) throw InputError("output path is empty");
  std::error_code ec;
  if (!scene_path.empty() && fs::exists(path, ec) && fs::equivalent(path, scene_path, ec))
    throw InputError(path + ": would overwrite the scene file");
  fs::path p(path);
  fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  if (!fs::is_directory(dir, ec))
    throw InputError(path + ": folder " + dir.string() + " does not exist");
  if (access(dir.c_str(), W_OK) != 0)
    throw InputError(path + ": folder " + dir.string() + " is not writable");
  if (fs::is_directory(p, ec)) throw InputError(path + ": is a folder");
  if (fs::exists(p, ec) && access(path.c_str(), W_OK) != 0)
    throw InputError(path + ": exists and is not writable");
  // access() is no answer for root, who passes it for /proc, /sys or a read-only mount: create the
  // file the write will create (and remove it), so that the failure comes before the work.
  make_pending_beside(path, "lancer-probe-");
  remove_pending_outputs();
}

void check_output_path(const std::string& path, const std::string& scene_path) {
  if (path.empty()) throw InputError("-o: output path is empty");
  std::error_code ec;
  // First, so that `-o scene.json` says what is wrong rather than that .json is no image format.
  if (!scene_path.empty() && fs::exists(path, ec) && fs::equivalent(path, scene_path, ec))
    throw InputError(path + ": would overwrite the scene file");
  const std::string ext = lower_extension(path);
  if (ext.empty()) throw InputError(path + ": no extension to choose an image format from");
  if (ext != ".pfm") {
    auto probe = OIIO::ImageOutput::create(path);
    if (!probe) throw InputError(path + ": unknown image format '" + ext + "'");
  }
  check_writable_target(path, scene_path);
}

void write_file_atomically(const std::string& path,
                           const std::function<void(const std::string&)>& write) {
  const std::string tmp = make_pending_beside(path);
  try {
    write(tmp);
    // mkstemp makes the file 0600; give it the permissions an ordinary new file would get.
    const mode_t mask = umask(0);
    umask(mask);
    chmod(tmp.c_str(), 0666 & ~mask);
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw InputError(path + ": cannot rename into place: " + std::strerror(errno));
    clear_pending();
  } catch (...) {
    remove_pending_outputs();
    throw;
  }
}

void write_image(const Image& image, const std::string& path) {
  check_output_path(path);
  write_file_atomically(path, [&](const std::string& tmp) {
    if (lower_extension(path) == ".pfm")
      write_pfm(image, tmp);
    else
      write_oiio(image, path, tmp);
  });
}

Image read_image(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw InputError(path + ": cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  Image im(spec.width, spec.height);
  std::vector<float> all(std::size_t(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, -1, OIIO::TypeDesc::FLOAT, all.data()))
    throw InputError(path + ": " + in->geterror());
  for (std::size_t p = 0; p < std::size_t(spec.width) * spec.height; ++p)
    for (int c = 0; c < 3; ++c)
      im.rgb[p * 3 + c] = all[p * spec.nchannels + std::min(c, spec.nchannels - 1)];
  return im;
}

}  // namespace lancer
