// Incoherent ray sets (`lancer bench --mode ao` and `--mode diffuse`): the secondary rays of the
// kinds Aila and Laine (2009) measure, made from a scene's camera hits before anything is timed,
// so that every engine traces the very same rays.
//
// The camera hits: sub-sample (0, 0) of every pixel, row-major from the top, traced through the
// library API (lancer.hpp; bench prepares it in exact precision, so the set is the same for every
// row). Each hit gives `per_hit` rays (4), in pixel order:
//   direction: cosine-weighted about the hit's geometric normal turned towards the camera's side
//     (Malley's method: a point uniform in the unit disc, lifted onto the hemisphere);
//   origin:    the hit point (o + t d, in double) moved `offset` along that normal, where offset =
//     offset_fraction x extent, so that no ray starts inside or on the surface it leaves;
//   tnear 0 (the scene's epsilon applies), tfar: ao_fraction x extent for ambient occlusion
//     (any hit: occluded), infinity for diffuse (the closest hit).
// The extent is the diagonal of the axis-aligned box of the bounded objects (spheres, triangles,
// meshes, cylinders), or, in a scene of planes alone, of the camera's position and the planes'
// points; 1 where that box is a point.
//
// Reproducible on every platform and compiler: std::mt19937_64 (its sequence is fixed by the C++
// standard) seeded with `seed`, its 64-bit outputs turned into numbers by our own arithmetic
// (never a std:: distribution, whose results the standard leaves to the library), and only
// +, -, *, / and sqrt, correctly rounded everywhere, on the way to each direction.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "lancer/lancer.hpp"
#include "lancer/precision.hpp"
#include "lancer/vec3.hpp"

namespace lancer::rays {

enum class Kind { ao, diffuse };
const char* to_string(Kind k);  // "ao", "diffuse"

struct SetOptions {
  std::uint64_t seed = 1;
  int per_hit = 4;                // rays per camera hit
  double ao_fraction = 0.05;      // AO's tfar, in units of the extent
  double offset_fraction = 1e-4;  // the origin's offset along the normal, in units of the extent
};

// The rays of one set, world space, structure of arrays, in pixel order (per_hit consecutive rays
// per camera hit).
struct RaySet {
  Kind kind = Kind::ao;
  SetOptions options;
  double extent = 1, offset = 0;
  float tfar = 0;               // every ray's: ao_fraction x extent, or infinity
  std::size_t camera_hits = 0;  // of the nx x ny camera rays
  std::vector<float> ox, oy, oz, dx, dy, dz;
  std::size_t size() const { return ox.size(); }
  bool occlusion() const { return kind == Kind::ao; }
};

// The scene's extent, as defined above.
double scene_extent(const Scene& scene);

// A uniform double in [0, 1) from the top 53 bits of one output.
double unit_uniform(std::mt19937_64& rng);
// A cosine-weighted unit direction about the unit normal n (Malley's method, the disc point by
// rejection from the square: about 1.27 outputs per pair kept), in double.
Vec3<double> cosine_direction(std::mt19937_64& rng, const Vec3<double>& n);

// The set of `kind` for a scene prepared through the library API (any precision: the camera
// hits are traced by its intersect<16>). InputError if the scene's camera sees nothing.
RaySet make_set(const api::Scene& scene, Kind kind, const SetOptions& options = {});

// What answers packets of `width` rays through the library API, for the summaries: the ISA of
// the widest kernel up to that width ("avx512f"), or, one ray at a
// time, "one-ray avx2" / "one-ray avx512f" where Info::one_ray names the one-ray kernels,
// "lone lane, sse4.2 packet" where a scene with shapes answers one ray on a packet kernel.
std::string api_isa(const api::Scene& scene, int width);

// Every ray's answer: occluded (AO sets) or the closest hit's object id and t (diffuse sets;
// id -1 and t infinity for a miss).
struct Answers {
  std::vector<int> occluded;
  std::vector<int> id;
  std::vector<float> t;
};

// The set in packets of N rays, laid out once (untimed), as a user holds them for the library
// API; the last packet's lanes past the set's end are invalid.
class ApiPackets {
 public:
  ApiPackets(const RaySet& set, int width);
  ~ApiPackets();
  ApiPackets(const ApiPackets&) = delete;
  ApiPackets& operator=(const ApiPackets&) = delete;
  int width() const;
  std::size_t rays() const;
  // Traces every ray on `threads` threads (1: the calling thread) through scene.occluded<N> or
  // scene.intersect<N>, as the set's kind asks; with `answers`, fills it. Returns the seconds.
  double trace(const api::Scene& scene, int threads, Answers* answers = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The set straight into the packet kernels, without the library API: the rays moved into the
// queries' frame once (FrameKind::query, as the API moves each ray on every call: in double,
// rounded once to float) and laid out as the kernels take them, so that only the kernels are timed,
// as the Embree peer's calls are. Float packets (exact or fast, width 4, 8 or 16); InputError
// otherwise.
class KernelPackets {
 public:
  // The scene prepared once in float (the structure --accel auto builds), for every width.
  struct Prepared;
  static std::shared_ptr<const Prepared> prepare(const Scene& scene, Precision precision);
  KernelPackets(std::shared_ptr<const Prepared> scene, const RaySet& set, int width);
  ~KernelPackets();
  KernelPackets(const KernelPackets&) = delete;
  KernelPackets& operator=(const KernelPackets&) = delete;
  std::size_t rays() const;
  // As ApiPackets::trace: occluded_packet or closest_hit_packet over every packet.
  double trace(int threads, Answers* answers = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// How two engines' answers on one set differ: rays whose occluded flag or hit object differs,
// or whose t differs (bitwise when tolerance is 0, else by more than tolerance x max(1, t)).
struct Agreement {
  std::size_t rays = 0, differ = 0;
};
Agreement compare(const RaySet& set, const Answers& reference, const Answers& other,
                  double tolerance);

}  // namespace lancer::rays
