// Linear RGB radiance images, row 0 at the top, and writing them to files.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace lancer {

struct Image {
  int nx = 0, ny = 0;
  std::vector<float> rgb;  // nx * ny * 3, row-major from the top
  // The image row that rgb's first row holds: a band of rows [first_row, first_row + ny) of a
  // taller image, which renderers address by that image's row numbers (the library API renders
  // row ranges into bands). 0 for a whole image.
  int first_row = 0;

  Image() = default;
  Image(int nx_, int ny_) : nx(nx_), ny(ny_), rgb(std::size_t(nx_) * ny_ * 3, 0.0f) {}
  float* pixel(int i, int j) { return rgb.data() + (std::size_t(j - first_row) * nx + i) * 3; }
  const float* pixel(int i, int j) const {
    return rgb.data() + (std::size_t(j - first_row) * nx + i) * 3;
  }
};

// A format lancer writes: its extension (lower case, with the dot), OpenImageIO's name for it
// (what reading the file back reports), and whether it keeps floats.
struct ImageFormat {
  const char* extension;
  const char* oiio_name;
  bool is_float;
};
// Every format write_image accepts; each is tested to write a file of its kind that reads back.
const std::vector<ImageFormat>& image_formats();

// The file a write to `path` replaces: `path` itself, or where its symbolic links lead.
std::string output_target(const std::string& path);

// Checks before rendering that `path` can be written: a known extension, an existing folder we
// may write to, and not the scene file itself. Throws InputError naming the path.
void check_output_path(const std::string& path, const std::string& scene_path = "");

// The checks of check_output_path but the format: an existing folder we may write to (probed by
// creating a file, since root passes access() on read-only places), not a folder, not the scene.
void check_writable_target(const std::string& path, const std::string& scene_path = "");

// Runs write(out) on a temporary file beside `path`, then renames it into place: the file appears
// whole or not at all, and a SIGINT/SIGTERM/SIGHUP meanwhile removes the temporary file. Every
// write, the fsync, the close and the rename are checked: a failure throws OutputError (exit
// status 4) naming `path`, with the temporary file removed and any old file intact.
// Replacing an existing file (docs/limits.md, "Output files"): a symbolic link is followed and
// its target replaced; the replaced file's mode (and owner and group, where permitted) carry
// over; the file is fsynced before the rename and the folder after it. check_writable_target
// refuses a target with other hard links, which a rename would split.
class OutputFile;
void write_file_atomically(const std::string& path, const std::function<void(OutputFile&)>& write);

// Writes by extension: .pfm by lancer's own writer, anything else through OpenImageIO. Float
// formats keep radiance unclamped; integer formats clamp to [0, 1] and round to nearest. The
// file appears complete or not at all: a temporary file beside it, renamed when written.
void write_image(const Image& image, const std::string& path);

// Reads any format OpenImageIO reads (PFM included) as float RGB, through the bounded reader
// (include/lancer/input_file.hpp): regular files only. Throws InputError naming the path, one line.
Image read_image(const std::string& path);

// What read_image does with the file's bytes: decodes them (`path` names the file in messages and
// picks the format tried first). Throws InputError naming the path, one line.
Image decode_image(const std::string& bytes, const std::string& path);

// Removes any temporary file a write in progress left, and keeps any thread from creating
// another: the process is ending (called from termination signals' handlers, on any thread).
void remove_pending_outputs() noexcept;

}  // namespace lancer
