// Ray sets straight into the packet kernels (rays::KernelPackets, include/lancer/ray_sets.hpp).
#include <algorithm>
#include <chrono>
#include <limits>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/ray_sets.hpp"
#include "lancer/tiles.hpp"

namespace lancer::rays {

struct KernelPackets::Prepared {
  PreparedScene<float> scene;
  Precision precision = Precision::exact;
};

std::shared_ptr<const KernelPackets::Prepared> KernelPackets::prepare(const Scene& scene,
                                                                      Precision precision) {
  if (precision != Precision::exact && precision != Precision::fast)
    throw InputError("ray set kernels: float packets only (exact or fast)");
  auto p = std::make_shared<Prepared>();
  // The frame the library API traces its queries in: the same numbers as its calls.
  p->scene = lancer::prepare<float>(scene, Accel::automatic, FrameKind::query);
  p->precision = precision;
  return p;
}

struct KernelPackets::Impl {
  std::shared_ptr<const Prepared> prepared;
  const packet::KernelTable<float>* kernels = nullptr;
  int width = 4;
  bool occlusion = true;
  std::size_t count = 0, packets = 0;
  std::vector<float> rays, tfar;  // per packet: 6 x width lanes, width
  std::unique_ptr<bool[]> valid;  // per packet: width

  // Packets [p0, p1): answers into `out` when given.
  void trace(std::size_t p0, std::size_t p1, Answers* out) const {
    const PreparedScene<float>& s = prepared->scene;
    const int w = width;
    alignas(64) float t[kMaxLanes];
    alignas(64) std::int32_t id[kMaxLanes];
    bool hit[kMaxLanes];
    for (std::size_t p = p0; p < p1; ++p) {
      const bool* v = valid.get() + p * w;
      const float* r = &rays[p * 6 * w];
      if (occlusion) {
        kernels->occluded_packet(s, v, r, &tfar[p * w], hit);
      } else {
        std::copy_n(&tfar[p * w], w, t);
        std::fill_n(id, w, -1);
        kernels->closest_hit_packet(s, v, r, t, id, hit, nullptr);
      }
      if (!out) continue;
      for (int k = 0; k < w && p * w + k < count; ++k) {
        const std::size_t at = p * w + k;
        if (occlusion) {
          out->occluded[at] = hit[k] ? 1 : 0;
        } else {
          out->id[at] = hit[k] ? id[k] : -1;
          out->t[at] = hit[k] ? t[k] : std::numeric_limits<float>::infinity();
        }
      }
    }
  }
};

KernelPackets::KernelPackets(std::shared_ptr<const Prepared> scene, const RaySet& set, int width)
    : impl_(std::make_unique<Impl>()) {
  Impl& im = *impl_;
  im.kernels = width > 1
                   ? packet::float_kernels(width, scene->precision, scene->scene.features.shapes)
                   : nullptr;
  if (!im.kernels)
    throw InputError("ray set kernels: no float kernel of width " + std::to_string(width) +
                     " on this machine");
  im.prepared = std::move(scene);
  im.width = width;
  im.occlusion = set.occlusion();
  im.count = set.size();
  im.packets = (im.count + width - 1) / width;
  im.rays.assign(im.packets * 6 * width, 0.0f);
  im.tfar.assign(im.packets * width, set.tfar);
  im.valid = std::make_unique<bool[]>(im.packets * width);  // false
  const Frame& frame = im.prepared->scene.frame;
  for (std::size_t k = 0; k < im.count; ++k) {
    // As the library API's fill() moves a caller's ray (src/engine/api.cpp).
    const Vec3<double> o = frame.point({set.ox[k], set.oy[k], set.oz[k]});
    const Vec3<double> d = frame.direction({set.dx[k], set.dy[k], set.dz[k]});
    const double lanes[6] = {o.x, o.y, o.z, d.x, d.y, d.z};
    float* r = &im.rays[(k / width) * 6 * width] + k % width;
    for (int a = 0; a < 6; ++a) r[a * width] = float(lanes[a]);
    im.valid[k] = true;
  }
  // Lanes past the end: a harmless ray (along z from the origin), invalid.
  for (std::size_t k = im.count; k < im.packets * width; ++k)
    im.rays[(k / width) * 6 * width + 5 * width + k % width] = 1.0f;
}

KernelPackets::~KernelPackets() = default;
std::size_t KernelPackets::rays() const { return impl_->count; }

double KernelPackets::trace(int threads, Answers* answers) const {
  const Impl& im = *impl_;
  if (answers) {
    answers->occluded.assign(im.occlusion ? im.count : 0, 0);
    answers->id.assign(im.occlusion ? 0 : im.count, -1);
    answers->t.assign(im.occlusion ? 0 : im.count, 0.0f);
  }
  constexpr std::size_t kPacketsPerRow = 16;
  const int rows = int((im.packets + kPacketsPerRow - 1) / kPacketsPerRow);
  const auto start = std::chrono::steady_clock::now();
  run_tiles(rows, threads, [&](int r0, int r1, RayCounts&) {
    im.trace(std::size_t(r0) * kPacketsPerRow,
             std::min(im.packets, std::size_t(r1) * kPacketsPerRow), answers);
  });
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace lancer::rays
