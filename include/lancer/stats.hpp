#pragma once

#include <cstdint>

namespace lancer {

struct StageProfile;

// Rays traced, by kind. Every path counts the same rays, so counts are compared in tests.
struct RayCounts {
  std::uint64_t camera = 0, shadow = 0, reflected = 0;
  StageProfile* profile = nullptr;  // filled by profiled kernels only; not summed

  std::uint64_t total() const { return camera + shadow + reflected; }
  RayCounts& operator+=(const RayCounts& o) {
    camera += o.camera, shadow += o.shadow, reflected += o.reflected;
    return *this;
  }
  bool operator==(const RayCounts& o) const {
    return camera == o.camera && shadow == o.shadow && reflected == o.reflected;
  }
};

}  // namespace lancer
