// The Embree peer: the scene in Embree 3, traced with rtcIntersect1/4/8/16 and rtcOccluded1/4/8/16
// on lancer's own camera rays. See include/lancer/peer.hpp for the model and its limits.
#include <cstdlib>
#include <memory>
#include <stdexcept>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peer.hpp"

#ifdef LANCER_HAVE_EMBREE

#include "peer_embree_impl.hpp"
#include "peer_embree_rays.hpp"

namespace lancer::peer {

bool embree_available() { return true; }
std::string embree_version() { return RTC_VERSION_STRING; }

EmbreeScene::EmbreeScene(const Scene& scene, PlaneMode planes, const std::string& config,
                         const EmbreeConfig& how)
    : how_(how) {
  auto impl = std::make_shared<Impl>();
  impl->mode = planes;
  impl->config = how;
  impl->build(scene, config);
  impl_ = std::move(impl);
}

EmbreeScene::EmbreeScene(const EmbreeScene& built, const EmbreeConfig& how)
    : impl_(built.impl_), how_(how) {
  if (!how.same_build(built.how_))
    throw std::logic_error("EmbreeScene: " + how.name() + " cannot share the scene of " +
                           built.how_.name());
}

double EmbreeScene::build_seconds() const { return impl_->build_seconds; }
const EmbreeConfig& EmbreeScene::config() const { return how_; }

EmbreeScene::~EmbreeScene() = default;

PlaneMode EmbreeScene::plane_mode() const { return impl_->mode; }

namespace {
void check_width(int width) {
  if (width != 1 && width != 4 && width != 8 && width != 16)
    throw InputError("--peer embree: width must be 1, 4, 8 or 16, not " + std::to_string(width));
  if (width > 1 && !packet::kernels_for(width)) {
    // LANCER_MAX_WIDTH (checked valid by kernels_for) caps the float lanes: blame it, not the
    // CPU, when it is what leaves this width out.
    const char* cap = std::getenv("LANCER_MAX_WIDTH");
    throw InputError("--peer embree: width " + std::to_string(width) + " needs " +
                     packet::isa_name(width) + ", which " +
                     (cap && std::atoi(cap) < width
                          ? "LANCER_MAX_WIDTH=" + std::string(cap) + " leaves out (it caps the " +
                                "packets at " + cap + " float lanes)"
                          : std::string("this CPU or OS does not run")));
  }
}
}  // namespace

PrimaryResult EmbreeScene::primary(int width, int threads) const {
  check_width(width);
  const Impl& im = *impl_;
  PrimaryResult res;
  res.width = width;
  res.threads = std::max(1, threads);
  res.t.assign(std::size_t(im.s.camera.nx) * im.s.camera.ny, 0.0f);
  const auto start = Clock::now();
  res.rays = embree_tiles(im.s.camera.ny, res.threads, [&](int r0, int r1, RayCounts& c) {
    // Streams are Embree's own regrouping, whatever the width asked for; tiles are packets.
    if (how_.streams) return im.primary_streams(res.t.data(), r0, r1, c);
    auto packets = [&](auto w) {
      constexpr int W = decltype(w)::value;
      if constexpr (W > 1) {
        if (how_.tiles) return im.template primary_tiles<W>(res.t.data(), r0, r1, c);
      }
      im.template primary_rows<W>(res.t.data(), r0, r1, c);
    };
    switch (width) {
      case 1:
        return packets(std::integral_constant<int, 1>{});
      case 4:
        return packets(std::integral_constant<int, 4>{});
      case 8:
        return packets(std::integral_constant<int, 8>{});
      default:
        return packets(std::integral_constant<int, 16>{});
    }
  });
  res.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return res;
}

EmbreeScene::RaysResult EmbreeScene::trace_all(int width, int threads) const {
  check_width(width);
  const Impl& im = *impl_;
  RaysResult res;
  const auto start = Clock::now();
  res.rays = embree_tiles(im.s.camera.ny, std::max(1, threads), [&](int r0, int r1, RayCounts& c) {
    switch (width) {
      case 1:
        im.trace_rows<1>(r0, r1, c);
        break;
      case 4:
        im.trace_rows<4>(r0, r1, c);
        break;
      case 8:
        im.trace_rows<8>(r0, r1, c);
        break;
      default:
        im.trace_rows<16>(r0, r1, c);
        break;
    }
  });
  res.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return res;
}

double EmbreeScene::one_rays(const float* rays, std::size_t n, bool occluded,
                             std::size_t& found) const {
  const Impl& im = *impl_;
  const FlushDenormals ftz;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  alignas(64) RTCRayHit rh;
  RTCRayN* ray = RTCRayHitN_RayN(reinterpret_cast<RTCRayHitN*>(&rh), 1);
  std::size_t count = 0;
  const auto start = Clock::now();
  for (std::size_t i = 0; i < n; ++i) {
    const float* r = rays + 8 * i;
    set_ray<1>(ray, 0, {r[0], r[1], r[2]}, {r[3], r[4], r[5]}, r[6], r[7]);
    if (occluded) {
      rtcOccluded1(im.scene, &ctx, &rh.ray);
      count += rh.ray.tfar < 0.0f;  // Embree marks a blocked ray with tfar = -inf
    } else {
      clear_hit<1>(RTCRayHitN_HitN(reinterpret_cast<RTCRayHitN*>(&rh), 1), 0);
      rtcIntersect1(im.scene, &ctx, &rh);
      count += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  found = count;
  return seconds;
}

std::vector<PeerHit> EmbreeScene::camera_hits(int width) const {
  check_width(width);
  const Impl& im = *impl_;
  const PreparedCamera<float>& cam = im.s.camera;
  std::vector<PeerHit> out(std::size_t(cam.nx) * cam.ny * cam.samples * cam.samples);
  const FlushDenormals ftz_daz;
  switch (width) {
    case 1:
      im.camera_hits<1>(out.data());
      break;
    case 4:
      im.camera_hits<4>(out.data());
      break;
    case 8:
      im.camera_hits<8>(out.data());
      break;
    default:
      im.camera_hits<16>(out.data());
      break;
  }
  return out;
}

}  // namespace lancer::peer

#else  // !LANCER_HAVE_EMBREE

namespace lancer::peer {

bool embree_available() { return false; }
std::string embree_version() { return ""; }

struct EmbreeScene::Impl {};

EmbreeScene::EmbreeScene(const Scene&, PlaneMode, const std::string&, const EmbreeConfig&) {
  throw InputError(
      "--peer embree: this lancer was built without Embree (install libembree-dev and "
      "configure with -DLANCER_WITH_EMBREE=ON)");
}
EmbreeScene::EmbreeScene(const EmbreeScene& built, const EmbreeConfig&) : impl_(built.impl_) {}
EmbreeScene::~EmbreeScene() = default;
PlaneMode EmbreeScene::plane_mode() const { return PlaneMode::user; }
double EmbreeScene::build_seconds() const { return 0; }
const EmbreeConfig& EmbreeScene::config() const { return how_; }
PrimaryResult EmbreeScene::primary(int, int) const { return {}; }
EmbreeScene::RaysResult EmbreeScene::trace_all(int, int) const { return {}; }
double EmbreeScene::one_rays(const float*, std::size_t, bool, std::size_t& found) const {
  found = 0;
  return 0;
}
std::vector<PeerHit> EmbreeScene::camera_hits(int) const { return {}; }
struct EmbreeScene::Rays {};
std::shared_ptr<const EmbreeScene::Rays> EmbreeScene::load_rays(const rays::RaySet&) const {
  return {};
}
double EmbreeScene::trace_rays(const Rays&, int, int, rays::Answers*) const { return 0; }

}  // namespace lancer::peer

#endif  // LANCER_HAVE_EMBREE

namespace lancer::peer {

PlaneMode plane_mode_from_env() {
  const char* env = std::getenv("LANCER_EMBREE_PLANES");
  const std::string v = env ? env : "";
  if (v.empty() || v == "user") return PlaneMode::user;
  if (v == "quad") return PlaneMode::quad;
  throw InputError("LANCER_EMBREE_PLANES: must be user or quad, not '" + v + "'");
}

EmbreeConfig embree_config_from_env() {
  EmbreeConfig c;
  const char* env = std::getenv("LANCER_EMBREE_SETUP");
  std::string v = env ? env : "";
  std::size_t start = 0;
  while (start <= v.size() && !v.empty()) {
    const std::size_t comma = std::min(v.find(',', start), v.size());
    const std::string word = v.substr(start, comma - start);
    if (word == "user-spheres")
      c.user_spheres = true;
    else if (word == "high")
      c.high_quality = true;
    else if (word == "tiles")
      c.tiles = true;
    else if (word == "compact")
      c.compact = true;
    else if (word == "streams")
      c.streams = true;
    else if (word == "robust")
      c.robust = true;
    else if (word == "curves")
      c.curves = true;
    else if (!word.empty())
      throw InputError("LANCER_EMBREE_SETUP: unknown word '" + word +
                       "' (known: user-spheres, high, tiles, compact, streams, robust, curves)");
    start = comma + 1;
  }
  return c;
}

std::vector<EmbreeConfig> embree_setups() {
  if (std::getenv("LANCER_EMBREE_SETUP")) return {embree_config_from_env()};
  std::vector<EmbreeConfig> out(6);
  out[1].high_quality = true;
  out[2].user_spheres = true;
  out[3].user_spheres = out[3].high_quality = true;
  out[4].user_spheres = out[4].tiles = true;
  out[5].user_spheres = out[5].streams = true;
  return out;
}

std::vector<EmbreeConfig> embree_setups(const std::vector<const Scene*>& scenes) {
  bool spheres = false, shapes = false, cylinders = false;
  for (const Scene* s : scenes) {
    spheres = spheres || !s->spheres.empty();
    shapes = shapes || !s->shapes.empty();
    for (const Shape& sh : s->shapes) cylinders = cylinders || sh.kind == Shape::Kind::cylinder;
  }
  std::vector<EmbreeConfig> out;
  if (!shapes) {
    out = embree_setups();
  } else if (std::getenv("LANCER_EMBREE_SETUP")) {
    out = {embree_config_from_env()};
  } else {
    // Build quality and the robust flag change the scene; packets and streams only how it is
    // traced (those setups share one Embree scene in lancer bench).
    for (int curves = 0; curves <= int(cylinders); ++curves)
      for (int build = 0; build < 4; ++build)
        for (int trace = 0; trace < 3; ++trace) {
          EmbreeConfig c;
          c.curves = curves == 1;
          c.high_quality = build % 2 == 1;
          c.robust = build >= 2;
          c.tiles = trace == 1;
          c.streams = trace == 2;
          out.push_back(c);
        }
  }
  for (EmbreeConfig& c : out) {
    c.name_spheres = spheres || !shapes;
    c.name_cylinders = cylinders;
  }
  return out;
}

bool EmbreeConfig::same_build(const EmbreeConfig& o) const {
  return user_spheres == o.user_spheres && high_quality == o.high_quality && compact == o.compact &&
         robust == o.robust && curves == o.curves;
}

std::string EmbreeConfig::name() const {
  std::string n;
  if (name_spheres) n += user_spheres ? "user spheres, " : "sphere points, ";
  if (name_cylinders) n += curves ? "round curves, " : "user cylinders, ";
  if (!name_spheres && !name_cylinders) n += "triangles, ";
  n += high_quality ? "build high" : "build medium";
  if (robust) n += ", robust";
  if (streams)
    n += ", 1M streams";
  else if (tiles)
    n += ", square packets";
  if (compact) n += ", compact";
  return n;
}

std::vector<int> embree_widths(const std::vector<int>& requested) {
  std::vector<int> out;
  for (int w : requested)
    if (w == 1 || ((w == 4 || w == 8 || w == 16) && packet::kernels_for(w))) out.push_back(w);
  return out;
}

}  // namespace lancer::peer
