// Linear RGB radiance images, row 0 at the top, and writing them to files.
#pragma once

#include <string>
#include <vector>

namespace lancer {

struct Image {
  int nx = 0, ny = 0;
  std::vector<float> rgb;  // nx * ny * 3, row-major from the top

  Image() = default;
  Image(int nx_, int ny_) : nx(nx_), ny(ny_), rgb(std::size_t(nx_) * ny_ * 3, 0.0f) {}
  float* pixel(int i, int j) { return rgb.data() + (std::size_t(j) * nx + i) * 3; }
  const float* pixel(int i, int j) const { return rgb.data() + (std::size_t(j) * nx + i) * 3; }
};

// Checks before rendering that `path` can be written: a known extension, an existing folder we
// may write to, and not the scene file itself. Throws InputError naming the path.
void check_output_path(const std::string& path, const std::string& scene_path = "");

// Writes by extension: .pfm by lancer's own writer, anything else through OpenImageIO. Float
// formats keep radiance unclamped; integer formats clamp to [0, 1] and round to nearest. The
// file appears complete or not at all: a temporary file beside it, renamed when written.
void write_image(const Image& image, const std::string& path);

// Reads any format OpenImageIO reads (PFM included) as float RGB. Throws InputError.
Image read_image(const std::string& path);

// Removes any temporary file a write in progress left (called from signal handlers).
void remove_pending_outputs() noexcept;

}  // namespace lancer
