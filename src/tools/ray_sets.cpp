// Incoherent ray sets: see include/lancer/ray_sets.hpp for what they are and why so.
#include "lancer/ray_sets.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/tiles.hpp"

namespace lancer::rays {

const char* to_string(Kind k) { return k == Kind::ao ? "ao" : "diffuse"; }

namespace {
struct Box {
  Vec3<double> lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  Vec3<double> hi = -lo;
  bool empty = true;
  void grow(const Vec3<double>& p, double r = 0) {
    lo = {std::min(lo.x, p.x - r), std::min(lo.y, p.y - r), std::min(lo.z, p.z - r)};
    hi = {std::max(hi.x, p.x + r), std::max(hi.y, p.y + r), std::max(hi.z, p.z + r)};
    empty = false;
  }
  double diagonal() const { return empty ? 0 : length(hi - lo); }
};
}  // namespace

double scene_extent(const Scene& scene) {
  Box box;
  for (const Sphere& s : scene.spheres) box.grow(s.center, s.radius);
  for (const Shape& sh : scene.shapes) {
    if (sh.kind == Shape::Kind::cylinder) {
      box.grow(sh.cylinder.base, sh.cylinder.radius);
      box.grow(sh.cylinder.top, sh.cylinder.radius);
    } else {
      for (const Vec3<double>& v : sh.mesh.vertices) box.grow(v);
    }
  }
  if (box.empty) {
    // Planes alone: how far apart the camera and the planes' points lie.
    box.grow(scene.camera.position);
    for (const Plane& p : scene.planes) box.grow(p.point);
  }
  const double d = box.diagonal();
  return d > 0 && std::isfinite(d) ? d : 1.0;
}

double unit_uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1p-53; }

Vec3<double> cosine_direction(std::mt19937_64& rng, const Vec3<double>& n) {
  double x, y, r2;
  do {
    x = 2 * unit_uniform(rng) - 1;
    y = 2 * unit_uniform(rng) - 1;
    r2 = x * x + y * y;
  } while (r2 >= 1);
  const double z = std::sqrt(1 - r2);
  // An orthonormal basis about n without a branch on its direction (Duff et al. 2017): only
  // exact IEEE operations, so the same bits everywhere.
  const double sign = n.z >= 0 ? 1.0 : -1.0;
  const double a = -1 / (sign + n.z), b = n.x * n.y * a;
  const Vec3<double> t1{1 + sign * n.x * n.x * a, sign * b, -sign * n.x};
  const Vec3<double> t2{b, sign + n.y * n.y * a, -n.y};
  return normalize(t1 * x + t2 * y + n * z);
}

RaySet make_set(const api::Scene& scene, Kind kind, const SetOptions& options) {
  if (options.per_hit < 1) throw InputError("ray set: per_hit must be >= 1");
  RaySet set;
  set.kind = kind;
  set.options = options;
  set.extent = scene_extent(scene.description());
  set.offset = options.offset_fraction * set.extent;
  set.tfar = kind == Kind::ao ? float(options.ao_fraction * set.extent)
                              : std::numeric_limits<float>::infinity();
  std::mt19937_64 rng(options.seed);
  const api::Info& in = scene.info();
  const std::size_t expect = std::size_t(in.nx) * in.ny * options.per_hit;
  for (std::vector<float>* v : {&set.ox, &set.oy, &set.oz, &set.dx, &set.dy, &set.dz})
    v->reserve(expect);
  for (int j = 0; j < in.ny; ++j)
    for (int i0 = 0; i0 < in.nx; i0 += 16) {
      api::Ray16 r;
      api::Hit16 h;
      int valid[16];
      for (int k = 0; k < 16; ++k) {
        float o[3], d[3];
        valid[k] = i0 + k < in.nx ? -1 : 0;
        scene.camera_ray(std::min(i0 + k, in.nx - 1), j, 0, 0, o, d);
        r.org_x[k] = o[0], r.org_y[k] = o[1], r.org_z[k] = o[2];
        r.dir_x[k] = d[0], r.dir_y[k] = d[1], r.dir_z[k] = d[2];
        r.tnear[k] = 0, r.tfar[k] = std::numeric_limits<float>::infinity();
        r.mask[k] = api::kAllObjects;
        h.id[k] = -1;
      }
      scene.intersect(valid, r, h);
      for (int k = 0; k < 16; ++k) {
        if (!valid[k] || h.id[k] < 0) continue;
        ++set.camera_hits;
        const Vec3<double> o{r.org_x[k], r.org_y[k], r.org_z[k]};
        const Vec3<double> d{r.dir_x[k], r.dir_y[k], r.dir_z[k]};
        Vec3<double> n = normalize(Vec3<double>{h.ng_x[k], h.ng_y[k], h.ng_z[k]});
        if (dot(n, d) > 0) n = -n;  // the camera's side
        const Vec3<double> p = o + d * double(h.t[k]) + n * set.offset;
        for (int q = 0; q < options.per_hit; ++q) {
          const Vec3<double> w = cosine_direction(rng, n);
          set.ox.push_back(float(p.x)), set.oy.push_back(float(p.y)), set.oz.push_back(float(p.z));
          set.dx.push_back(float(w.x)), set.dy.push_back(float(w.y)), set.dz.push_back(float(w.z));
        }
      }
    }
  if (set.camera_hits == 0)
    throw InputError(std::string("--mode ") + to_string(kind) +
                     ": the camera sees no object, so there are no rays to make");
  return set;
}

// ---- packets for the library API --------------------------------------------------------------

namespace {
// Packets per unit of work handed to a thread (run_tiles' "row").
constexpr std::size_t kPacketsPerRow = 16;

template <int N>
struct Packets {
  std::vector<api::RayPacket<N>> rays;
  int last_valid[N];  // the last packet's lanes
  std::size_t count = 0;

  void fill(const RaySet& s) {
    count = s.size();
    rays.resize((count + N - 1) / N);
    for (std::size_t p = 0; p < rays.size(); ++p) {
      api::RayPacket<N>& r = rays[p];
      for (int k = 0; k < N; ++k) {
        // Lanes past the end repeat the set's last ray, invalid.
        const std::size_t at = std::min(p * N + k, count - 1);
        r.org_x[k] = s.ox[at], r.org_y[k] = s.oy[at], r.org_z[k] = s.oz[at];
        r.dir_x[k] = s.dx[at], r.dir_y[k] = s.dy[at], r.dir_z[k] = s.dz[at];
        r.tnear[k] = 0, r.tfar[k] = s.tfar, r.mask[k] = api::kAllObjects;
        if (p + 1 == rays.size()) last_valid[k] = p * N + k < count ? -1 : 0;
      }
    }
  }

  void trace(const api::Scene& scene, bool occlusion, std::size_t p0, std::size_t p1,
             Answers* out) const {
    alignas(64) int occ[N];
    api::HitPacket<N> hit;
    for (std::size_t p = p0; p < p1; ++p) {
      const int* valid = p + 1 == rays.size() ? last_valid : nullptr;
      if (occlusion) {
        scene.occluded<N>(valid, rays[p], occ);
        if (out)
          for (int k = 0; k < N && p * N + k < count; ++k) out->occluded[p * N + k] = occ[k];
      } else {
        scene.intersect<N>(valid, rays[p], hit);
        if (out)
          for (int k = 0; k < N && p * N + k < count; ++k)
            out->id[p * N + k] = hit.id[k], out->t[p * N + k] = hit.t[k];
      }
    }
  }
};
}  // namespace

struct ApiPackets::Impl {
  int width = 1;
  bool occlusion = true;
  std::size_t rays = 0;
  Packets<1> p1;
  Packets<4> p4;
  Packets<8> p8;
  Packets<16> p16;

  template <class Fn>
  void visit(Fn fn) const {
    switch (width) {
      case 1:
        return fn(p1);
      case 4:
        return fn(p4);
      case 8:
        return fn(p8);
      default:
        return fn(p16);
    }
  }
};

ApiPackets::ApiPackets(const RaySet& set, int width) : impl_(std::make_unique<Impl>()) {
  if (width != 1 && width != 4 && width != 8 && width != 16)
    throw InputError("ray set: packets of 1, 4, 8 or 16 rays, not " + std::to_string(width));
  impl_->width = width;
  impl_->occlusion = set.occlusion();
  impl_->rays = set.size();
  switch (width) {
    case 1:
      impl_->p1.fill(set);
      break;
    case 4:
      impl_->p4.fill(set);
      break;
    case 8:
      impl_->p8.fill(set);
      break;
    default:
      impl_->p16.fill(set);
      break;
  }
}
ApiPackets::~ApiPackets() = default;
int ApiPackets::width() const { return impl_->width; }
std::size_t ApiPackets::rays() const { return impl_->rays; }

double ApiPackets::trace(const api::Scene& scene, int threads, Answers* answers) const {
  const Impl& im = *impl_;
  if (answers) {
    answers->occluded.assign(im.occlusion ? im.rays : 0, 0);
    answers->id.assign(im.occlusion ? 0 : im.rays, -1);
    answers->t.assign(im.occlusion ? 0 : im.rays, 0.0f);
  }
  const auto start = std::chrono::steady_clock::now();
  im.visit([&](const auto& packets) {
    const std::size_t n = packets.rays.size();
    const int rows = int((n + kPacketsPerRow - 1) / kPacketsPerRow);
    run_tiles(rows, threads, [&](int r0, int r1, RayCounts&) {
      packets.trace(scene, im.occlusion, std::size_t(r0) * kPacketsPerRow,
                    std::min(n, std::size_t(r1) * kPacketsPerRow), answers);
    });
  });
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Agreement compare(const RaySet& set, const Answers& reference, const Answers& other,
                  double tolerance) {
  Agreement a;
  a.rays = set.size();
  for (std::size_t k = 0; k < a.rays; ++k) {
    if (set.occlusion()) {
      a.differ += reference.occluded[k] != other.occluded[k];
      continue;
    }
    const float t0 = reference.t[k], t1 = other.t[k];
    bool same = reference.id[k] == other.id[k];
    if (same && reference.id[k] >= 0) {
      if (tolerance == 0) {
        same = std::memcmp(&t0, &t1, sizeof t0) == 0;
      } else {
        same = std::fabs(double(t0) - t1) <= tolerance * std::max(1.0, double(std::fabs(t0)));
      }
    }
    a.differ += !same;
  }
  return a;
}

std::string api_isa(const api::Scene& scene, int width) {
  const api::Info& info = scene.info();
  if (width > 1) return packet::isa_name(std::min(width, info.width), info.precision);
  if (info.one_ray == "scalar") return info.one_ray;
  const bool packet =
      info.one_ray.size() > 7 && info.one_ray.compare(info.one_ray.size() - 7, 7, " packet") == 0;
  return packet ? "lone lane, " + info.one_ray : "one-ray " + info.one_ray;
}

}  // namespace lancer::rays
