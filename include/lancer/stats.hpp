#pragma once

#include <cstdint>

namespace lancer {

struct StageProfile;

// Rays traced, by kind. Every path counts the same rays, so counts are compared in tests.
struct RayCounts {
  // refracted: the rays of contract step 7, totally reflected ones included.
  std::uint64_t camera = 0, shadow = 0, reflected = 0, refracted = 0;
  StageProfile* profile = nullptr;  // filled by profiled kernels only; not summed

  std::uint64_t total() const { return camera + shadow + reflected + refracted; }
  RayCounts& operator+=(const RayCounts& o) {
    camera += o.camera, shadow += o.shadow, reflected += o.reflected, refracted += o.refracted;
    return *this;
  }
  bool operator==(const RayCounts& o) const {
    return camera == o.camera && shadow == o.shadow && reflected == o.reflected &&
           refracted == o.refracted;
  }
};

}  // namespace lancer
