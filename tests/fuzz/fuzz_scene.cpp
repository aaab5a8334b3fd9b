// libFuzzer target for the scene loader (issue 7, "Hostile input and faults").
//
// The property under test: for ANY byte string, lancer::parse_scene either returns a Scene or
// throws lancer::InputError whose message is one non-empty line naming the scene. Any other
// exception, crash, hang or sanitizer report is a finding. A scene that loads must also prepare
// and render (reference path, at most 8 x 8 pixels, one sample, max_depth <= 3) without a NaN or
// an infinity in the image.
//
// Build and run with .ci/fuzz.sh; every finding becomes a case in test_regressions.cpp.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/scene.hpp"

namespace {

[[noreturn]] void finding(const std::string& what, const std::string& input) {
  std::fprintf(stderr, "\nlancer fuzz finding: %s\ninput (%zu bytes):\n%s\n", what.c_str(),
               input.size(), input.c_str());
  std::abort();  // libFuzzer saves the input as a crash artifact
}

void check_message(const std::string& message, const std::string& name, const std::string& input) {
  if (message.empty()) finding("InputError with an empty message", input);
  if (message.find('\n') != std::string::npos || message.find('\r') != std::string::npos)
    finding("InputError message is not one line: " + message, input);
  if (message.compare(0, name.size() + 1, name + ":") != 0)
    finding("InputError message does not start with the scene name: " + message, input);
}

// Renders `scene` with the float reference; false and the first non-finite pixel if any.
bool render_is_finite(const lancer::Scene& scene, int& i, int& j, int& c) {
  const lancer::PreparedScene<float> prepared = lancer::prepare<float>(scene);
  lancer::Image image(scene.camera.nx, scene.camera.ny);
  lancer::RayCounts counts;
  lancer::reference::render_rows(prepared, image, 0, scene.camera.ny, counts);
  for (j = 0; j < image.ny; ++j)
    for (i = 0; i < image.nx; ++i)
      for (c = 0; c < 3; ++c)
        if (!std::isfinite(image.pixel(i, j)[c])) return false;
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string name = "fuzz.json";
  lancer::Scene scene;
  try {
    scene = lancer::parse_scene(text, name);
  } catch (const lancer::InputError& e) {
    check_message(e.what(), name, text);
    return 0;
  } catch (const std::exception& e) {
    finding(std::string("parse_scene threw a non-InputError exception: ") + e.what(), text);
  } catch (...) {
    finding("parse_scene threw a non-std exception", text);
  }

  // A tiny render of what loaded: the reference path in float, as `lancer render --width 1`.
  scene.camera.nx = std::min(scene.camera.nx, 8);
  scene.camera.ny = std::min(scene.camera.ny, 8);
  scene.supersample = 1;
  scene.max_depth = std::min(scene.max_depth, 3);
  int i, j, c;
  if (render_is_finite(scene, i, j, c)) return 0;
  char where[128];
  std::snprintf(where, sizeof where, "pixel (%d, %d) channel %d is not finite", i, j, c);
  finding(std::string("non-finite radiance in a loaded scene: ") + where, text);
  return 0;
}
