// Image files. PFM by our own writer (OpenImageIO 2.4 reads PFM but cannot write it); PNG, JPEG,
// TIFF, OpenEXR and PPM by their own libraries (src/tools/image_formats.cpp); the other formats
// through OpenImageIO, in lancer's image module (src/tools/image_oiio.cpp), loaded on first use.
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
#include "lancer/input_file.hpp"
#include "lancer/output_file.hpp"
#include "lancer/scene.hpp"

namespace lancer {

namespace fs = std::filesystem;

namespace {

// An image file given to compare is read whole before decoding: a 16384 x 16384 float RGB PFM
// is 3 GiB. Larger is refused rather than read (docs/limits.md).
constexpr std::size_t kMaxImageFileBytes = std::size_t(1) << 32;

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
// A process-directed signal may run its handler on any thread that does not block it (a thread
// pool's worker), while the writing thread, which holds the signals back, is between creating
// its temporary file and naming it in g_pending. The writer says it is creating one, the handler
// that it is ending the process (both sequentially consistent, so at least one sees the other):
// a writer that sees the ending creates nothing, a handler that sees a creation waits for its
// name (remove_pending_outputs).
std::atomic<bool> g_creating{false};
std::atomic<bool> g_ending{false};

// Removes the pending file (async-signal-safe).
void drop_pending() noexcept {
  if (g_has_pending.exchange(false)) unlink(g_pending);
}

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
// Failing to create it while checking the path is bad input (status 2, before any work); failing
// when the work is done (a disk filled meanwhile) is output lost (status 4).
struct Pending {
  std::string path;
  int fd = -1;
};
Pending make_pending_beside(const std::string& target, const std::string& given,
                            const char* kind = "lancer-") {
  fs::path t(target);
  fs::path dir = t.parent_path().empty() ? fs::path(".") : t.parent_path();
  std::string name = t.filename().string();
  const std::size_t room = NAME_MAX - (2 + std::strlen(kind) + 6);  // "." "." kind "XXXXXX"
  if (name.size() > room) name.resize(room);
  std::string pattern = (dir / ("." + name + "." + kind + "XXXXXX")).string();
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  const HoldTerminationSignals hold;
  g_creating = true;
  int fd = -1, err = EINTR;  // EINTR: a termination signal is ending the process
  if (!g_ending) {
    fd = mkostemp(buf.data(), O_CLOEXEC);
    err = errno;
    if (fd >= 0) set_pending(buf.data());
  }
  g_creating = false;
  if (fd < 0) {
    const std::string why =
        given + ": cannot create a file in " + dir.string() + ": " + std::strerror(err);
    if (std::strcmp(kind, "lancer-") == 0) throw OutputError(why);
    throw InputError(why);
  }
  return {buf.data(), fd};
}

void write_pfm(const Image& im, OutputFile& out) {
  // A negative scale means little-endian; rows go bottom to top.
  const std::string header =
      "PF\n" + std::to_string(im.nx) + " " + std::to_string(im.ny) + "\n-1.0\n";
  out.write(header.data(), header.size());
  static_assert(sizeof(float) == 4, "PFM stores 32-bit floats");
  for (int j = im.ny - 1; j >= 0; --j) out.write(im.pixel(0, j), sizeof(float) * 3 * im.nx);
}

// dlopen's failures under a memory limit (`ulimit -v`) read "failed to map segment from shared
// object" or "cannot allocate memory": out of memory (status 3), not a missing module.
struct ModuleOutOfMemory : std::bad_alloc {
  std::string why;
  explicit ModuleOutOfMemory(std::string w) : why(std::move(w)) {}
  const char* what() const noexcept override { return why.c_str(); }
};
bool is_out_of_memory(const std::string& dl_error) {
  std::string e = dl_error;
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e.find("failed to map segment") != std::string::npos ||
         e.find("cannot allocate memory") != std::string::npos ||
         e.find("out of memory") != std::string::npos;
}

// The image module, loaded once: where `cmake --install` puts it relative to the executable
// (<bindir>/../<libdir>/lancer/), else where this build made it. OpenImageIO and the 260
// libraries it needs come with it, so commands that write no such image start without them.
struct ImageModule {
  ImageModuleWriteFn write = nullptr;
  ImageModuleReadFn read = nullptr;
};
const ImageModule& image_module() {
#if defined(LANCER_WITHOUT_IMAGE_MODULES)
  throw InputError(
      "BMP, Targa and HDR: this lancer was built without its image modules "
      "(LANCER_WITH_IMAGE_MODULES=OFF); it writes .pfm, .ppm, .png and .jpg");
#endif
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
        if (is_out_of_memory(why))
          throw ModuleOutOfMemory("cannot load lancer's image module (OpenImageIO and the " +
                                  std::string("libraries it needs): ") + why);
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

// OpenImageIO's messages can run to several lines (libpng's, then its own): the first says it.
std::string first_line(const std::string& text, const char* if_empty) {
  std::size_t b = 0;
  while (b < text.size()) {
    const std::size_t e = std::min(text.find('\n', b), text.size());
    if (e > b) return text.substr(b, std::min<std::size_t>(e - b, 300));
    b = e + 1;
  }
  return if_empty;
}

void check_status(int status, const std::string& path, const std::string& error) {
  if (status == kImageOutOfMemory) throw std::bad_alloc();
  if (status != kImageOk) throw InputError(path + ": " + error);
}

void write_oiio(const Image& im, const std::string& format_path, OutputFile& out) {
  const ImageFormat* format = find_format(lower_extension(format_path));
  ImageModuleWrite w{format->oiio_name, format->is_float, im.nx, im.ny, im.rgb.data(), &out};
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
  const int status = image_module().write(&w, &error);
  if (out.error() != 0) return;  // the write's own failure is what the caller reports
  check_status(status, format_path, first_line(error, "cannot encode the image"));
}

}  // namespace

void remove_pending_outputs() noexcept {
  g_ending = true;
  while (g_creating) {  // another thread's mkostemp and its naming: a few system calls
  }
  drop_pending();
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
  // Checked here, before the work: the write would fail at the end, when the file is renamed.
  const long name_max = pathconf(dir.c_str(), _PC_NAME_MAX);
  const std::size_t name_bytes = p.filename().string().size();
  if (name_bytes > std::size_t(name_max > 0 ? name_max : NAME_MAX))
    throw InputError(given + ": the file name is " + std::to_string(name_bytes) +
                     " bytes, longer than the folder's file system allows (" +
                     std::to_string(name_max > 0 ? name_max : NAME_MAX) + ")");
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
  const Pending probe = make_pending_beside(path, given, "lancer-probe-");
  close(probe.fd);
  drop_pending();
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
                           const std::function<void(OutputFile&)>& write) {
  const std::string path = output_target(given);
  struct stat old;
  const bool replacing = stat(path.c_str(), &old) == 0 && S_ISREG(old.st_mode);
  const Pending tmp = make_pending_beside(path, given);
  int fd = tmp.fd;
  // Each step checked, and a failure names the user's path (the temporary name means nothing to
  // them): the temporary file is removed and the old file, untouched until the rename, stays.
  auto lost = [&](const char* what, int err) {
    throw OutputError(given + ": " + what + ": " + std::strerror(err) +
                      " (nothing written; any old file is kept)");
  };
  try {
    OutputFile out(fd);
    write(out);
    if (out.error() != 0) lost("cannot write", out.error());
    // A last check that every byte went through `out`: the file has the size written.
    struct stat st;
    if (fstat(fd, &st) != 0) lost("cannot write", errno);
    if (std::uint64_t(st.st_size) != out.end()) lost("cannot write", EIO);
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
    // On disk before the rename, so that a crash leaves the old file or the new one, whole. Some
    // file systems (NFS) report a failed write only at fsync or close: both are checked.
    if (fsync(fd) != 0) lost("cannot write to disk", errno);
    const int closed = close(fd);
    fd = -1;
    if (closed != 0) lost("cannot write to disk", errno);
    if (std::rename(tmp.path.c_str(), path.c_str()) != 0) lost("cannot rename into place", errno);
    clear_pending();
  } catch (...) {
    if (fd >= 0) close(fd);
    drop_pending();
    throw;
  }
  // And the rename itself on disk. The new file is in place whatever happens here; a failure is
  // still reported (status 4): the new file may not survive a crash.
  const fs::path dir =
      fs::path(path).parent_path().empty() ? fs::path(".") : fs::path(path).parent_path();
  const int dfd = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    const bool synced = fsync(dfd) == 0 || errno == EINVAL;  // EINVAL: folders not syncable
    const int err = errno;
    close(dfd);
    if (!synced)
      throw OutputError(
          given + ": written, but its folder cannot be written to disk: " + std::strerror(err));
  }
}

void write_image(const Image& image, const std::string& path) {
  check_output_path(path);
  // Direct encoders (src/tools/image_formats.cpp): the whole file in memory first, then the
  // bytes through the checked output file.
  const std::string ext = lower_extension(path);
  if (has_direct_encoder(ext)) {
    const std::vector<unsigned char> bytes = encode_image(image, ext, path);
    return write_file_atomically(path,
                                 [&](OutputFile& out) { out.write(bytes.data(), bytes.size()); });
  }
  // The rest: PFM by write_pfm, other formats through the image module.
  write_file_atomically(path, [&](OutputFile& out) {
    if (lower_extension(path) == ".pfm")
      write_pfm(image, out);
    else
      write_oiio(image, path, out);
  });
}

Image read_image(const std::string& path) {
  return decode_image(read_input_file(path, kMaxImageFileBytes, "image", "4 GiB"), path);
}

Image decode_image(const std::string& bytes, const std::string& path) {
  Image im;
  // Direct decoders (src/tools/image_formats.cpp), by the file's first bytes.
  if (decode_image_bytes(std::vector<unsigned char>(bytes.begin(), bytes.end()), path, &im))
    return im;
  std::string error;
  const int status = image_module().read(path.c_str(), bytes.data(), bytes.size(), kMaxResolution,
                                         &im.nx, &im.ny, &im.rgb, &error);
  check_status(status, path, first_line(error, "the image data are missing or cut short"));
  return im;
}

}  // namespace lancer
