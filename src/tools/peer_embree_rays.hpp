// The Embree peer on incoherent ray sets (lancer/ray_sets.hpp): the rays moved into the peer's
// frame once, then traced in packets of consecutive rays or in rtcIntersect1M / rtcOccluded1M
// streams. Included by peer_embree.cpp alone, after peer_embree_impl.hpp.
#pragma once

#include <cstring>

#include "peer_embree_impl.hpp"

namespace lancer::peer {

struct EmbreeScene::Rays {
  bool occlusion = true;
  float tnear = 0, tfar = 0;
  std::vector<float> ox, oy, oz, dx, dy, dz;  // in the peer's (prepared) frame
  std::size_t size() const { return ox.size(); }
};

namespace {

// Rays per unit of work handed to a thread, and per stream call.
constexpr std::size_t kRaysPerRow = 256;
constexpr int kStream = 64;

// The Impl is the peer's private type: taken as a template parameter.
template <int W, class Impl>
void trace_ray_packets(const Impl& im, const EmbreeScene::Rays& r, std::size_t r0, std::size_t r1,
                       rays::Answers* out) {
  alignas(64) typename Api<W>::RayHit rh;
  alignas(64) int valid[W];
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  RTCRayHitN* rhn = reinterpret_cast<RTCRayHitN*>(&rh);
  RTCRayN* ray = RTCRayHitN_RayN(rhn, W);
  RTCHitN* hit = RTCRayHitN_HitN(rhn, W);
  for (std::size_t p = r0; p < r1; p += W) {
    const int lanes = int(std::min<std::size_t>(W, r1 - p));
    for (int k = 0; k < W; ++k) {
      const std::size_t at = p + std::size_t(std::min(k, lanes - 1));
      valid[k] = k < lanes ? -1 : 0;
      set_ray<W>(ray, k, {r.ox[at], r.oy[at], r.oz[at]}, {r.dx[at], r.dy[at], r.dz[at]}, r.tnear,
                 r.tfar);
      if (!r.occlusion) clear_hit<W>(hit, k);
    }
    if (r.occlusion) {
      // An RTCRayHitN starts with its RTCRayN: the occlusion call takes the same memory.
      Api<W>::occluded(valid, im.scene, &ctx, *reinterpret_cast<typename Api<W>::Ray*>(&rh));
      if (out)
        for (int k = 0; k < lanes; ++k)
          out->occluded[p + k] = RTCRayN_tfar(ray, W, k) == -kInf ? 1 : 0;
    } else {
      Api<W>::intersect(valid, im.scene, &ctx, rh);
      if (out)
        for (int k = 0; k < lanes; ++k) {
          const int id = im.object_id(RTCHitN_geomID(hit, W, k), RTCHitN_primID(hit, W, k));
          out->id[p + k] = id;
          out->t[p + k] = id < 0 ? kInf : RTCRayN_tfar(ray, W, k);
        }
    }
  }
}

template <class Impl>
void trace_ray_streams(const Impl& im, const EmbreeScene::Rays& r, std::size_t r0, std::size_t r1,
                       rays::Answers* out) {
  alignas(64) RTCRayHit rh[kStream];
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  for (std::size_t p = r0; p < r1; p += kStream) {
    const int n = int(std::min<std::size_t>(kStream, r1 - p));
    for (int m = 0; m < n; ++m) {
      const std::size_t at = p + std::size_t(m);
      set_ray<1>(reinterpret_cast<RTCRayN*>(&rh[m].ray), 0, {r.ox[at], r.oy[at], r.oz[at]},
                 {r.dx[at], r.dy[at], r.dz[at]}, r.tnear, r.tfar);
      if (!r.occlusion) clear_hit<1>(reinterpret_cast<RTCHitN*>(&rh[m].hit), 0);
    }
    if (r.occlusion) {
      rtcOccluded1M(im.scene, &ctx, &rh[0].ray, unsigned(n), sizeof(RTCRayHit));
      if (out)
        for (int m = 0; m < n; ++m) out->occluded[p + m] = rh[m].ray.tfar == -kInf ? 1 : 0;
    } else {
      rtcIntersect1M(im.scene, &ctx, rh, unsigned(n), sizeof(RTCRayHit));
      if (out)
        for (int m = 0; m < n; ++m) {
          const int id = im.object_id(rh[m].hit.geomID, rh[m].hit.primID);
          out->id[p + m] = id;
          out->t[p + m] = id < 0 ? kInf : rh[m].ray.tfar;
        }
    }
  }
}

}  // namespace

std::shared_ptr<const EmbreeScene::Rays> EmbreeScene::load_rays(const rays::RaySet& set) const {
  const Frame& frame = impl_->s.frame;
  auto r = std::make_shared<Rays>();
  r->occlusion = set.occlusion();
  r->tnear = impl_->s.epsilon;
  r->tfar = set.tfar;
  for (std::vector<float>* v : {&r->ox, &r->oy, &r->oz, &r->dx, &r->dy, &r->dz})
    v->resize(set.size());
  for (std::size_t k = 0; k < set.size(); ++k) {
    // As the library API's fill() moves a caller's ray (src/engine/api.cpp).
    const Vec3<double> o = frame.point({set.ox[k], set.oy[k], set.oz[k]});
    const Vec3<double> d = frame.direction({set.dx[k], set.dy[k], set.dz[k]});
    r->ox[k] = float(o.x), r->oy[k] = float(o.y), r->oz[k] = float(o.z);
    r->dx[k] = float(d.x), r->dy[k] = float(d.y), r->dz[k] = float(d.z);
  }
  return r;
}

double EmbreeScene::trace_rays(const Rays& r, int width, int threads,
                               rays::Answers* answers) const {
  if (width != 1 && width != 4 && width != 8 && width != 16)
    throw std::logic_error("trace_rays: width " + std::to_string(width));
  const Impl& im = *impl_;
  if (answers) {
    answers->occluded.assign(r.occlusion ? r.size() : 0, 0);
    answers->id.assign(r.occlusion ? 0 : r.size(), -1);
    answers->t.assign(r.occlusion ? 0 : r.size(), 0.0f);
  }
  const std::size_t n = r.size();
  const int rows = int((n + kRaysPerRow - 1) / kRaysPerRow);
  const auto start = Clock::now();
  embree_tiles(rows, std::max(1, threads), [&](int row0, int row1, RayCounts&) {
    const std::size_t r0 = std::size_t(row0) * kRaysPerRow;
    const std::size_t r1 = std::min(n, std::size_t(row1) * kRaysPerRow);
    if (how_.streams) return trace_ray_streams(im, r, r0, r1, answers);
    switch (width) {
      case 1:
        return trace_ray_packets<1>(im, r, r0, r1, answers);
      case 4:
        return trace_ray_packets<4>(im, r, r0, r1, answers);
      case 8:
        return trace_ray_packets<8>(im, r, r0, r1, answers);
      default:
        return trace_ray_packets<16>(im, r, r0, r1, answers);
    }
  });
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace lancer::peer
