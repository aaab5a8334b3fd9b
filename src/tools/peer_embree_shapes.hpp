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
  std::vector<float> vertices_;       // x, y, z of every vertex, then one float of padding
  std::vector<std::uint32_t> index_;  // lancer's triangle indices, writable as Embree asks

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

  // Lane i of a packet of N against cylinder k: the nearest of the side's two roots within the
  // height and, when capped, the two end discs, within (tnear, tfar); hit and t, and the
  // (unnormalised) outward normal. Branch-free selects, so the callers' lane loops can be
  // vectorised.
  static bool cylinder_t(const PreparedShapes<float>& c, unsigned k, const RTCRayN* ray, unsigned N,
                         unsigned i, float& t, Vec3<float>& n) {
    auto* r = const_cast<RTCRayN*>(ray);
    const Vec3<float> a = c.cyl_axis[k];
    const float h = c.cyl_h[k], r2 = c.cyl_r2[k];
    const Vec3<float> oc{RTCRayN_org_x(r, N, i) - c.cyl_base[k].x,
                         RTCRayN_org_y(r, N, i) - c.cyl_base[k].y,
                         RTCRayN_org_z(r, N, i) - c.cyl_base[k].z};
    const Vec3<float> d{RTCRayN_dir_x(r, N, i), RTCRayN_dir_y(r, N, i), RTCRayN_dir_z(r, N, i)};
    const float tnear = RTCRayN_tnear(r, N, i), tfar = RTCRayN_tfar(r, N, i);
    const float oa = dot(oc, a), da = dot(d, a);
    const Vec3<float> op = oc - a * oa, dp = d - a * da;  // across the axis
    const float qa = dot(dp, dp), qb = dot(op, dp), qc = dot(op, op) - r2;
    const float disc = qb * qb - qa * qc;
    const float q = std::sqrt(std::max(disc, 0.0f));
    const bool side_ok = disc >= 0.0f && qa > 0.0f;
    const float t0 = (-qb - q) / qa, t1 = (-qb + q) / qa;
    const float z0 = oa + t0 * da, z1 = oa + t1 * da;
    const bool h0 = side_ok && t0 > tnear && t0 < tfar && z0 >= 0.0f && z0 <= h;
    const bool h1 = side_ok && t1 > tnear && t1 < tfar && z1 >= 0.0f && z1 <= h;
    float best = h0 ? t0 : h1 ? t1 : tfar;
    bool hit = h0 || h1;
    n = op + dp * best;
    // End discs: the base (z = 0, normal -a) and the top (z = h, normal a).
    const bool caps = c.cyl_caps[k] != 0 && da != 0.0f;
    for (int e = 0; e < 2; ++e) {
      const float te = ((e ? h : 0.0f) - oa) / da;
      const Vec3<float> p = op + dp * te;
      const bool he = caps && te > tnear && te < best && dot(p, p) <= r2;
      best = he ? te : best;
      hit = hit || he;
      n = he ? (e ? a : -a) : n;
    }
    t = best;
    return hit;
  }

  static void cylinder_intersect(const RTCIntersectFunctionNArguments* args) {
    const auto& c = *static_cast<const PreparedShapes<float>*>(args->geometryUserPtr);
    const unsigned N = args->N, k = args->primID;
    RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, N);
    RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, N);
    const unsigned geom = args->geomID, inst = args->context->instID[0];
    for (unsigned i = 0; i < N; ++i) {
      float t;
      Vec3<float> n;
      const bool h = cylinder_t(c, k, ray, N, i, t, n) && args->valid[i] == -1;
      // Every field written, selected per lane: no branch in the loop.
      RTCRayN_tfar(ray, N, i) = h ? t : RTCRayN_tfar(ray, N, i);
      RTCHitN_Ng_x(hit, N, i) = h ? n.x : RTCHitN_Ng_x(hit, N, i);
      RTCHitN_Ng_y(hit, N, i) = h ? n.y : RTCHitN_Ng_y(hit, N, i);
      RTCHitN_Ng_z(hit, N, i) = h ? n.z : RTCHitN_Ng_z(hit, N, i);
      RTCHitN_u(hit, N, i) = h ? 0.0f : RTCHitN_u(hit, N, i);
      RTCHitN_v(hit, N, i) = h ? 0.0f : RTCHitN_v(hit, N, i);
      RTCHitN_primID(hit, N, i) = h ? k : RTCHitN_primID(hit, N, i);
      RTCHitN_geomID(hit, N, i) = h ? geom : RTCHitN_geomID(hit, N, i);
      RTCHitN_instID(hit, N, i, 0) = h ? inst : RTCHitN_instID(hit, N, i, 0);
    }
  }

  static void cylinder_occluded(const RTCOccludedFunctionNArguments* args) {
    const auto& c = *static_cast<const PreparedShapes<float>*>(args->geometryUserPtr);
    const unsigned N = args->N, k = args->primID;
    for (unsigned i = 0; i < N; ++i) {
      float t;
      Vec3<float> n;
      const bool h = cylinder_t(c, k, args->ray, N, i, t, n) && args->valid[i] == -1;
      RTCRayN_tfar(args->ray, N, i) =
          h ? -std::numeric_limits<float>::infinity() : RTCRayN_tfar(args->ray, N, i);
    }
  }
};

}  // namespace lancer::peer
