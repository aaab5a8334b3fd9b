// Image files. PFM by our own writer (OpenImageIO 2.4 reads PFM but cannot write it); PNG, JPEG,
// TIFF, OpenEXR and PPM by their own libraries (src/image_formats.cpp); the other formats through
// OpenImageIO, in lancer's image module (src/image_oiio.cpp), loaded on first use.
// Files appear whole or not at all.
#include <dlfcn.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <new>
#include <stdexcept>

#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/image_formats.hpp"
#include "lancer/image_module.hpp"

namespace lancer {

namespace fs = std::filesystem;

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// The formats lancer writes: each one checked to write a real file of its kind that reads back
// (tests/test_image.cpp). OpenImageIO offers more, but some of them write nothing (.jp2 leaves 0
// bytes, .term prints to the terminal, .null writes no file), and .pgm/.pbm would get colour.
constexpr ImageFormat kFormats[] = {
    {".png", "png", false},    {".jpg", "jpeg", false}, {".jpeg", "jpeg", false},
    {".ppm", "pnm", false},    {".bmp", "bmp", false},  {".tga", "targa", false},
    {".exr", "openexr", true}, {".tif", "tiff", true},  {".tiff", "tiff", true},
    {".hdr", "hdr", true},     {".pfm", "pnm", true},
};

const ImageFormat* find_format(const std::string& ext) {
  for (const ImageFormat& f : kFormats)
    if (ext == f.extension) return &f;
  return nullptr;
}

std::string known_extensions() {
  std::string out;
  for (const ImageFormat& f : kFormats) out += (out.empty() ? "" : " ") + std::string(f.extension);
  return out;
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
// `.<name>.lancer-XXXXXX` (`.<name>.lancer-probe-XXXXXX` for the writability probe), <name> cut
// short where the whole would exceed NAME_MAX, so that every legal target name has one. It is the
// pending file from the moment it exists.
std::string make_pending_beside(const std::string& target, const char* kind = "lancer-") {
  fs::path t(target);
  fs::path dir = t.parent_path().empty() ? fs::path(".") : t.parent_path();
  std::string name = t.filename().string();
  const std::size_t room = NAME_MAX - (2 + std::strlen(kind) + 6);  // "." "." kind "XXXXXX"
  if (name.size() > room) name.resize(room);
  std::string pattern = (dir / ("." + name + "." + kind + "XXXXXX")).string();
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

// The image module, loaded once: where `cmake --install` puts it relative to the executable
// (<bindir>/../<libdir>/lancer/), else where this build made it. OpenImageIO and the 260
// libraries it needs come with it, so commands that write no such image start without them.
struct ImageModule {
  ImageModuleWriteFn write = nullptr;
  ImageModuleReadFn read = nullptr;
};
const ImageModule& image_module() {
  static const ImageModule module = [] {
    std::vector<std::string> tried;
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec)
      tried.push_back(
          (exe.parent_path() / LANCER_IMAGE_MODULE_INSTALLED).lexically_normal().string());
    tried.push_back(LANCER_IMAGE_MODULE_BUILT);
    std::string why;
    for (const std::string& path : tried) {
      if (!fs::exists(path, ec)) continue;
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) {
        why = dlerror();
        continue;
      }
      ImageModule m;
      m.write = reinterpret_cast<ImageModuleWriteFn>(dlsym(handle, "lancer_oiio_write"));
      m.read = reinterpret_cast<ImageModuleReadFn>(dlsym(handle, "lancer_oiio_read"));
      if (m.write && m.read) return m;
      why = path + " lacks lancer_oiio_write or lancer_oiio_read";
    }
    std::string where;
    for (const std::string& path : tried) where += (where.empty() ? "" : ", ") + path;
    throw std::runtime_error("lancer's image module (OpenImageIO) is not installed: looked for " +
                             where + (why.empty() ? "" : " (" + why + ")"));
  }();
  return module;
}

void check_status(int status, const std::string& path, const std::string& error) {
  if (status == kImageOutOfMemory) throw std::bad_alloc();
  if (status != kImageOk) throw InputError(path + ": " + error);
}

void write_oiio(const Image& im, const std::string& format_path, const std::string& path) {
  const ImageFormat* format = find_format(lower_extension(format_path));
  ImageModuleWrite w{format->oiio_name, format->is_float, im.nx, im.ny,
                     im.rgb.data(),     path.c_str()};
  // Clamp to [0, 1] and round to the nearest of 256 levels ourselves, so every format agrees.
  std::vector<unsigned char> bytes;
  if (!format->is_float) {
    bytes.resize(im.rgb.size());
    for (std::size_t k = 0; k < bytes.size(); ++k) {
      const float v = im.rgb[k];
      const float c = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;  // NaN -> 0
      bytes[k] = static_cast<unsigned char>(std::lround(c * 255.0f));
    }
    w.pixels = bytes.data();
  }
  std::string error;
  check_status(image_module().write(&w, &error), format_path, error);
}

}  // namespace

void remove_pending_outputs() noexcept {
  if (g_has_pending.exchange(false)) unlink(g_pending);  // async-signal-safe
}

std::string output_target(const std::string& path) {
  fs::path p(path);
  for (int hops = 0; hops < 40; ++hops) {  // Linux's own limit on links followed
    struct stat st;
    if (lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p.string();
    std::error_code ec;
    const fs::path link = fs::read_symlink(p, ec);
    if (ec) throw InputError(path + ": cannot read the symbolic link: " + ec.message());
    p = link.is_absolute() ? link : p.parent_path() / link;
  }
  throw InputError(path + ": too many levels of symbolic links");
}

void check_writable_target(const std::string& given, const std::string& scene_path) {
  if (given.empty()) throw InputError("output path is empty");
  if (given == "-") throw InputError("-: this output is a file, not stdout: give a file name");
  std::error_code ec;
  if (!scene_path.empty() && fs::exists(given, ec) && fs::equivalent(given, scene_path, ec))
    throw InputError(given + ": would overwrite the scene file");
  const std::string path = output_target(given);  // a symbolic link: its target is written
  fs::path p(path);
  fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  if (!fs::is_directory(dir, ec))
    throw InputError(given + ": folder " + dir.string() + " does not exist");
  if (access(dir.c_str(), W_OK) != 0)
    throw InputError(given + ": folder " + dir.string() + " is not writable");
  if (fs::is_directory(p, ec)) throw InputError(given + ": is a folder");
  struct stat st;
  if (stat(path.c_str(), &st) == 0) {
    if (!S_ISREG(st.st_mode))
      throw InputError(given + ": exists and is not a regular file (a device, pipe or socket)");
    if (access(path.c_str(), W_OK) != 0) throw InputError(given + ": exists and is not writable");
    // The new file replaces this name only: the other names would keep the old contents.
    if (st.st_nlink > 1)
      throw InputError(given + ": has " + std::to_string(st.st_nlink) +
                       " hard links, which replacing it would split (the others keeping the old "
                       "contents): remove it first or write elsewhere");
  }
  // access() is no answer for root, who passes it for /proc, /sys or a read-only mount: create the
  // file the write will create (and remove it), so that the failure comes before the work.
  make_pending_beside(path, "lancer-probe-");
  remove_pending_outputs();
}

const std::vector<ImageFormat>& image_formats() {
  static const std::vector<ImageFormat> all(std::begin(kFormats), std::end(kFormats));
  return all;
}

void check_output_path(const std::string& path, const std::string& scene_path) {
  if (path.empty()) throw InputError("-o: output path is empty");
  if (path == "-") throw InputError("-: images are written to files, not stdout: give a file name");
  std::error_code ec;
  // First, so that `-o scene.json` says what is wrong rather than that .json is no image format.
  if (!scene_path.empty() && fs::exists(path, ec) && fs::equivalent(path, scene_path, ec))
    throw InputError(path + ": would overwrite the scene file");
  const std::string ext = lower_extension(path);
  if (ext.empty())
    throw InputError(path + ": no extension to choose an image format from (" + known_extensions() +
                     ")");
  if (ext == ".pgm" || ext == ".pbm")
    throw InputError(path + ": " + ext + " holds grey or black and white, and lancer renders " +
                     "colour: use .ppm");
  if (!find_format(ext))
    throw InputError(path + ": lancer does not write '" + ext + "' images (it writes " +
                     known_extensions() + ")");
  // A missing module says so before any work.
  if (has_direct_encoder(ext))
    load_direct_encoder(ext);  // TIFF and OpenEXR: their module
  else if (ext != ".pfm")
    image_module();
  check_writable_target(path, scene_path);
}

void write_file_atomically(const std::string& given,
                           const std::function<void(const std::string&)>& write) {
  const std::string path = output_target(given);
  struct stat old;
  const bool replacing = stat(path.c_str(), &old) == 0 && S_ISREG(old.st_mode);
  const std::string tmp = make_pending_beside(path);
  try {
    write(tmp);
    const int fd = open(tmp.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0)
      throw InputError(given + ": cannot reopen the written file: " + std::strerror(errno));
    if (replacing) {
      // The replaced file's owner and group where the system lets us (root; a group we are in),
      // then its mode (chown clears set-id bits, so the mode comes second).
      if (fchown(fd, old.st_uid, old.st_gid) != 0) (void)!fchown(fd, -1, old.st_gid);
      fchmod(fd, old.st_mode & 07777);
    } else {
      // mkstemp makes the file 0600; give it the permissions an ordinary new file would get.
      const mode_t mask = umask(0);
      umask(mask);
      fchmod(fd, 0666 & ~mask);
    }
    // On disk before the rename, so that a crash leaves the old file or the new one, whole.
    const bool synced = fsync(fd) == 0;
    const int sync_errno = errno;
    close(fd);
    if (!synced) throw InputError(given + ": cannot write to disk: " + std::strerror(sync_errno));
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw InputError(given + ": cannot rename into place: " + std::strerror(errno));
    clear_pending();
  } catch (...) {
    remove_pending_outputs();
    throw;
  }
  // And the rename itself on disk.
  const fs::path dir =
      fs::path(path).parent_path().empty() ? fs::path(".") : fs::path(path).parent_path();
  const int dfd = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    fsync(dfd);
    close(dfd);
  }
}

void write_image(const Image& image, const std::string& path) {
  check_output_path(path);
  // Direct encoders (src/image_formats.cpp): the whole file in memory first, then the bytes.
  const std::string ext = lower_extension(path);
  if (has_direct_encoder(ext)) {
    const std::vector<unsigned char> bytes = encode_image(image, ext, path);
    return write_file_atomically(path,
                                 [&](const std::string& tmp) { write_bytes(tmp, bytes, path); });
  }
  // The rest: PFM by write_pfm, other formats through the image module.
  write_file_atomically(path, [&](const std::string& tmp) {
    if (lower_extension(path) == ".pfm")
      write_pfm(image, tmp);
    else
      write_oiio(image, path, tmp);
  });
}

Image read_image(const std::string& path) {
  Image im;
  if (decode_image_file(path, &im)) return im;  // direct decoders (src/image_formats.cpp)
  std::string error;
  check_status(image_module().read(path.c_str(), &im.nx, &im.ny, &im.rgb, &error), path, error);
  return im;
}

}  // namespace lancer
