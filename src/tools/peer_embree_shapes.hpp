// The Embree peer's triangles, meshes and cylinders (see include/lancer/peer.hpp for the model):
// meshes as native triangle geometries over one shared vertex buffer, cylinders as a user
// geometry (the peer's own capped-cylinder formula) or as round linear curves. Included by
// peer_embree_impl.hpp alone, inside LANCER_HAVE_EMBREE.
#pragma once

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "lancer/peer.hpp"
#include "lancer/shapes.hpp"

namespace lancer::peer {

// lancer's object id of an Embree hit in one geometry: table[prim] when there is a table, else
// first + step * prim.
struct GeomIds {
  int first = 0, step = 0;
  const std::int32_t* table = nullptr;
  int of(unsigned prim) const { return table ? table[prim] : first + step * int(prim); }
};

// A callback's lane loop in one clone per x86 level (AVX-512, AVX2 + FMA, baseline), chosen by
// the loader from the CPU (GCC's target_clones).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define LANCER_PEER_CLONES \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define LANCER_PEER_CLONES
#endif

// User geometries' callbacks test lanes in chunks of at most this many (Embree's widest packet).
inline constexpr unsigned kLaneChunk = 16;

// dst[i] = v[i] where h[i] is set, for i < n: both loaded first, then selected, one field per
// loop (GCC if-converts, so vectorises, no more than that).
template <class T>
inline void select_lanes(T* __restrict dst, const int* __restrict h, const T* __restrict v, int n) {
  for (int i = 0; i < n; ++i) {
    const T old = dst[i], value = v[i];
    dst[i] = h[i] ? value : old;
  }
}
template <class T>
inline void select_lanes(T* __restrict dst, const int* __restrict h, T value, int n) {
  for (int i = 0; i < n; ++i) {
    const T old = dst[i];
    dst[i] = h[i] ? value : old;
  }
}

// Stores the hits of lanes [i0, i0 + n) of a packet of N (Embree's SoA layout) where h[i] is
// set: tfar, the normal, u = v = 0, primitive, geometry and instance ids. A lane without a hit
// keeps its bits. No branch.
inline void store_hits(float* ray, float* hit, unsigned N, unsigned i0, unsigned n, const int* h,
                       const float* t, const float* nx, const float* ny, const float* nz,
                       unsigned prim, unsigned geom, unsigned inst) {
  auto* ids = reinterpret_cast<unsigned*>(hit);
  const int m = int(n);
  select_lanes(ray + 8 * N + i0, h, t, m);
  select_lanes(hit + 0 * N + i0, h, nx, m);
  select_lanes(hit + 1 * N + i0, h, ny, m);
  select_lanes(hit + 2 * N + i0, h, nz, m);
  select_lanes(hit + 3 * N + i0, h, 0.0f, m);
  select_lanes(hit + 4 * N + i0, h, 0.0f, m);
  select_lanes(ids + 5 * N + i0, h, prim, m);
  select_lanes(ids + 6 * N + i0, h, geom, m);
  select_lanes(ids + 7 * N + i0, h, inst, m);
}

class EmbreeShapes {
 public:
  // The shapes of a prepared scene (nullptr or empty: none); kept by reference.
  void set(const PreparedShapes<float>* shapes) {
    sh_ = shapes && shapes->num_shapes > 0 ? shapes : nullptr;
    if (!sh_) return;
    // Embree reads vertices with 16-byte loads: one float of padding after the last.
    const std::size_t nv = sh_->vx.size();
    vertices_.assign(3 * nv + 1, 0.0f);
    for (std::size_t v = 0; v < nv; ++v) {
      vertices_[3 * v + 0] = sh_->vx[v];
      vertices_[3 * v + 1] = sh_->vy[v];
      vertices_[3 * v + 2] = sh_->vz[v];
    }
    index_.assign(sh_->tri.begin(), sh_->tri.end());
    index_.resize(index_.size() + 4, 0);
  }

  // Attaches the meshes and cylinders to `scene`, recording each geometry's ids in `geoms`
  // (indexed by geometry id).
  void attach(RTCDevice device, RTCScene scene, const EmbreeConfig& how,
              std::vector<GeomIds>& geoms) const {
    if (!sh_) return;
    const RTCBuildQuality quality =
        how.high_quality ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM;
    auto record = [&](unsigned id, GeomIds ids) {
      if (geoms.size() <= id) geoms.resize(id + 1);
      geoms[id] = ids;
    };
    // Triangles of one mesh are consecutive, in object-id order: one geometry per run.
    const std::size_t nt = sh_->triangles();
    for (std::size_t first = 0; first < nt;) {
      std::size_t end = first + 1;
      while (end < nt && sh_->tri_object[end] == sh_->tri_object[first]) ++end;
      RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
      rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices_.data(),
                                 0, 3 * sizeof(float), sh_->vx.size());
      rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, index_.data(),
                                 3 * sizeof(std::uint32_t) * first, 3 * sizeof(std::uint32_t),
                                 end - first);
      rtcSetGeometryBuildQuality(g, quality);
      rtcCommitGeometry(g);
      record(rtcAttachGeometry(scene, g), {sh_->tri_object[first], 0, nullptr});
      rtcReleaseGeometry(g);
      first = end;
    }
    const unsigned nc = unsigned(sh_->cyl_object.size());
    if (nc == 0) return;
    RTCGeometry g;
    if (how.curves) {
      g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 2 * nc));
      auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(unsigned), nc));
      if (!v || !idx) throw std::runtime_error("embree: curve buffers failed");
      for (unsigned k = 0; k < nc; ++k) {
        const Vec3<float> b = sh_->cyl_base[k];
        const Vec3<float> t = b + sh_->cyl_axis[k] * sh_->cyl_h[k];
        const float r = std::sqrt(sh_->cyl_r2[k]);
        const float both[8] = {b.x, b.y, b.z, r, t.x, t.y, t.z, r};
        std::copy(both, both + 8, v + 8 * k);
        idx[k] = 2 * k;
      }
    } else {
      g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
      rtcSetGeometryUserPrimitiveCount(g, nc);
      rtcSetGeometryUserData(g, const_cast<PreparedShapes<float>*>(sh_));
      rtcSetGeometryBoundsFunction(g, &EmbreeShapes::cylinder_bounds,
                                   const_cast<PreparedShapes<float>*>(sh_));
      rtcSetGeometryIntersectFunction(g, &EmbreeShapes::cylinder_intersect);
      rtcSetGeometryOccludedFunction(g, &EmbreeShapes::cylinder_occluded);
    }
    rtcSetGeometryBuildQuality(g, quality);
    rtcCommitGeometry(g);
    record(rtcAttachGeometry(scene, g), {0, 0, sh_->cyl_object.data()});
    rtcReleaseGeometry(g);
  }

  // Extends `r` (the scene's size about the origin of the prepared frame) to the shapes.
  float size(float r) const {
    if (!sh_) return r;
    for (std::size_t v = 0; v < sh_->vx.size(); ++v)
      r = std::max(r, std::sqrt(sh_->vx[v] * sh_->vx[v] + sh_->vy[v] * sh_->vy[v] +
                                sh_->vz[v] * sh_->vz[v]));
    for (std::size_t k = 0; k < sh_->cyl_object.size(); ++k) {
      const Vec3<float> b = sh_->cyl_base[k];
      const float reach = std::sqrt(sh_->cyl_r2[k]);
      r = std::max(r, length(b) + sh_->cyl_h[k] + reach);
    }
    return r;
  }

 private:
  const PreparedShapes<float>* sh_ = nullptr;
  std::vector<float> vertices_;  // x, y, z of every vertex, then one float of padding
  // lancer's triangle indices, padded by 16 bytes as the vertices: Embree may read a buffer's
  // last item with a 16-byte load.
  std::vector<std::uint32_t> index_;

  static void cylinder_bounds(const RTCBoundsFunctionArguments* args) {
    const auto& c = *static_cast<const PreparedShapes<float>*>(args->geometryUserPtr);
    const unsigned k = args->primID;
    const Vec3<float> a = c.cyl_axis[k], b = c.cyl_base[k];
    const Vec3<float> t = b + a * c.cyl_h[k];
    const float r = std::sqrt(c.cyl_r2[k]);
    const float ax[3] = {a.x, a.y, a.z}, bx[3] = {b.x, b.y, b.z}, tx[3] = {t.x, t.y, t.z};
    float lo[3], hi[3];
    for (int i = 0; i < 3; ++i) {
      // The end discs reach r * sqrt(1 - a_i^2) along axis i; padded for rounding.
      const float reach = r * std::sqrt(std::max(0.0f, 1.0f - ax[i] * ax[i]));
      const float pad = 1e-5f * (std::abs(bx[i]) + std::abs(tx[i]) + r);
      lo[i] = std::min(bx[i], tx[i]) - reach - pad;
      hi[i] = std::max(bx[i], tx[i]) + reach + pad;
    }
    RTCBounds* o = args->bounds_o;
    o->lower_x = lo[0], o->lower_y = lo[1], o->lower_z = lo[2];
    o->upper_x = hi[0], o->upper_y = hi[1], o->upper_z = hi[2];
  }

  // Lanes [i0, i0 + n) of a packet of N rays (Embree's SoA layout: each field an array of N)
  // against cylinder k: the nearest of the side's two roots within the height and, when
  // capped, of the two end discs, within (tnear, tfar). Out: t (tfar where none), hit (-1 or
  // 0, and valid), the (unnormalised) outward normal. One loop of selects and no branch, over
  // plain arrays: the compiler vectorises it.
  LANCER_PEER_CLONES
  static void cylinder_lanes(const PreparedShapes<float>& c, unsigned k, const float* ray,
                             unsigned N, unsigned i0, unsigned n, const int* valid,
                             float* __restrict t, int* __restrict hit, float* __restrict nx,
                             float* __restrict ny, float* __restrict nz) {
    const float* __restrict ox = ray + 0 * N + i0;
    const float* __restrict oy = ray + 1 * N + i0;
    const float* __restrict oz = ray + 2 * N + i0;
    const float* __restrict tn = ray + 3 * N + i0;
    const float* __restrict dx = ray + 4 * N + i0;
    const float* __restrict dy = ray + 5 * N + i0;
    const float* __restrict dz = ray + 6 * N + i0;
    const float* __restrict tf = ray + 8 * N + i0;
    const float ax = c.cyl_axis[k].x, ay = c.cyl_axis[k].y, az = c.cyl_axis[k].z;
    const float bx = c.cyl_base[k].x, by = c.cyl_base[k].y, bz = c.cyl_base[k].z;
    const float h = c.cyl_h[k], r2 = c.cyl_r2[k];
    const bool capped = c.cyl_caps[k] != 0;
    for (unsigned i = 0; i < n; ++i) {
      const float cx = ox[i] - bx, cy = oy[i] - by, cz = oz[i] - bz;
      const float oa = cx * ax + cy * ay + cz * az;
      const float da = dx[i] * ax + dy[i] * ay + dz[i] * az;
      // Across the axis.
      const float px = cx - ax * oa, py = cy - ay * oa, pz = cz - az * oa;
      const float qx = dx[i] - ax * da, qy = dy[i] - ay * da, qz = dz[i] - az * da;
      const float qa = qx * qx + qy * qy + qz * qz;
      const float qb = px * qx + py * qy + pz * qz;
      const float qc = px * px + py * py + pz * pz - r2;
      const float disc = qb * qb - qa * qc;
      const float q = std::sqrt(disc > 0.0f ? disc : 0.0f);
      const bool side = (disc >= 0.0f) & (qa > 0.0f);
      const float inv = 1.0f / (qa > 0.0f ? qa : 1.0f);
      const float t0 = (-qb - q) * inv, t1 = (-qb + q) * inv;
      const float z0 = oa + t0 * da, z1 = oa + t1 * da;
      const float lo = tn[i], hi = tf[i];
      const bool h0 = side & (t0 > lo) & (t0 < hi) & (z0 >= 0.0f) & (z0 <= h);
      const bool h1 = side & (t1 > lo) & (t1 < hi) & (z1 >= 0.0f) & (z1 <= h);
      float best = h0 ? t0 : (h1 ? t1 : hi);
      float mx = px + qx * best, my = py + qy * best, mz = pz + qz * best;
      // End discs: the base (z = 0, normal -a) and the top (z = h, normal a).
      const bool caps = capped & (da != 0.0f);
      const float ida = 1.0f / (da != 0.0f ? da : 1.0f);
      const float tb = -oa * ida, tt = (h - oa) * ida;
      const float bx2 = px + qx * tb, by2 = py + qy * tb, bz2 = pz + qz * tb;
      const bool hb = caps & (tb > lo) & (tb < best) & (bx2 * bx2 + by2 * by2 + bz2 * bz2 <= r2);
      best = hb ? tb : best;
      mx = hb ? -ax : mx, my = hb ? -ay : my, mz = hb ? -az : mz;
      const float tx2 = px + qx * tt, ty2 = py + qy * tt, tz2 = pz + qz * tt;
      const bool ht = caps & (tt > lo) & (tt < best) & (tx2 * tx2 + ty2 * ty2 + tz2 * tz2 <= r2);
      best = ht ? tt : best;
      mx = ht ? ax : mx, my = ht ? ay : my, mz = ht ? az : mz;
      t[i] = best;
      hit[i] = (h0 | h1 | hb | ht) & (valid[i0 + i] == -1) ? -1 : 0;
      nx[i] = mx, ny[i] = my, nz[i] = mz;
    }
  }

  static void cylinder_intersect(const RTCIntersectFunctionNArguments* args) {
    const auto& c = *static_cast<const PreparedShapes<float>*>(args->geometryUserPtr);
    const unsigned N = args->N, k = args->primID;
    auto* ray = reinterpret_cast<float*>(RTCRayHitN_RayN(args->rayhit, N));
    auto* hit = reinterpret_cast<float*>(RTCRayHitN_HitN(args->rayhit, N));
    const unsigned geom = args->geomID, inst = args->context->instID[0];
    alignas(64) float t[kLaneChunk], nx[kLaneChunk], ny[kLaneChunk], nz[kLaneChunk];
    alignas(64) int h[kLaneChunk];
    for (unsigned i0 = 0; i0 < N; i0 += kLaneChunk) {
      const unsigned n = std::min(kLaneChunk, N - i0);
      cylinder_lanes(c, k, ray, N, i0, n, args->valid, t, h, nx, ny, nz);
      store_hits(ray, hit, N, i0, n, h, t, nx, ny, nz, k, geom, inst);
    }
  }

  static void cylinder_occluded(const RTCOccludedFunctionNArguments* args) {
    const auto& c = *static_cast<const PreparedShapes<float>*>(args->geometryUserPtr);
    const unsigned N = args->N, k = args->primID;
    auto* ray = reinterpret_cast<float*>(args->ray);
    alignas(64) float t[kLaneChunk], nx[kLaneChunk], ny[kLaneChunk], nz[kLaneChunk];
    alignas(64) int h[kLaneChunk];
    for (unsigned i0 = 0; i0 < N; i0 += kLaneChunk) {
      const unsigned n = std::min(kLaneChunk, N - i0);
      cylinder_lanes(c, k, ray, N, i0, n, args->valid, t, h, nx, ny, nz);
      select_lanes(ray + 8 * N + i0, h, -std::numeric_limits<float>::infinity(), int(n));
    }
  }
};

}  // namespace lancer::peer
