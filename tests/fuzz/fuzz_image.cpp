// libFuzzer target for the image reader of `lancer compare`: lancer::decode_image, what
// read_image does with a file's bytes once the bounded reader has them (OpenImageIO in lancer's
// image module, loaded as the CLI loads it). The seeds are PFM and PNG files, the formats lancer
// writes and compares most.
//
// The property under test: for ANY byte string, decode_image either returns an image of 1 to
// 65536 pixels a side holding nx * ny * 3 values, or throws lancer::InputError whose message is
// one non-empty line naming the file, or (the decoder's allocation failing) std::bad_alloc. Any
// other exception, crash, hang or sanitizer report in lancer's code is a finding.
//
// OpenImageIO and libpng come from Debian, uninstrumented: coverage guides only lancer's own code
// around them, so this is mostly mutation of the seeds, with crashes, hangs, sanitizer reports in
// lancer's code and the message property as the findings. stderr is silenced while a file is
// decoded (src/image_oiio.cpp): a crash there leaves its artifact but not its report; rerun the
// artifact under gdb, or `lancer compare` it.
//
// Build and run with .ci/fuzz.sh; every finding becomes a case in test_regressions.cpp.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>

#include "lancer/error.hpp"
#include "lancer/image.hpp"

namespace {

[[noreturn]] void finding(const std::string& what, std::size_t size) {
  std::fprintf(stderr, "\nlancer fuzz finding: %s (input of %zu bytes)\n", what.c_str(), size);
  std::abort();  // libFuzzer saves the input as a crash artifact
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  // The name picks the format tried first: alternate between the two seeds' formats.
  const std::string name = size % 2 ? "fuzz.pfm" : "fuzz.png";
  try {
    const lancer::Image im = lancer::decode_image(bytes, name);
    if (im.nx < 1 || im.ny < 1 || im.nx > 65536 || im.ny > 65536 ||
        im.rgb.size() != std::size_t(im.nx) * im.ny * 3)
      finding("decode_image returned an image of the wrong size", size);
  } catch (const lancer::InputError& e) {
    const std::string m = e.what();
    if (m.find('\n') != std::string::npos) finding("message is not one line: " + m, size);
    if (m.compare(0, name.size() + 2, name + ": ") != 0 || m.size() == name.size() + 2)
      finding("message does not name the file and say why: " + m, size);
  } catch (const std::bad_alloc&) {
  } catch (const std::exception& e) {
    finding(std::string("decode_image threw a non-InputError exception: ") + e.what(), size);
  } catch (...) {
    finding("decode_image threw a non-std exception", size);
  }
  return 0;
}
