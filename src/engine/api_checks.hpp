// The library API's checks of a caller's rays (src/engine/api.cpp): every active lane before
// any is traced, in the kernel's vectors where a kernel answers, and the error naming the first
// lane that fails them.
#pragma once

#include <array>
#include <cmath>
#include <string>

#include "lancer/lancer.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/packet/api_rays.hpp"

namespace lancer::api::checks {

inline std::string lane(int k) { return "lane " + std::to_string(k) + ": "; }

// The error of a ray check_ray refused, out of the way of the rays it lets through.
template <int N>
[[noreturn, gnu::cold, gnu::noinline]] void refuse_ray(const char* what, const RayPacket<N>& r,
                                                       int k, double d2) {
  const std::string at = std::string(what) + ": " + lane(k);
  if (!(std::isfinite(r.org_x[k]) && std::isfinite(r.org_y[k]) && std::isfinite(r.org_z[k])))
    throw InputError(at + "org must be finite");
  if (!(std::fabs(d2 - 1.0) <= 1e-5))
    throw InputError(at + "dir must be unit length, |dir|^2 = " + std::to_string(d2));
  if (std::isnan(r.tnear[k])) throw InputError(at + "tnear is NaN");
  throw InputError(at + "tfar is NaN");
}

template <int N>
void check_ray(const char* what, const RayPacket<N>& r, int k) {
  const double d2 = double(r.dir_x[k]) * r.dir_x[k] + double(r.dir_y[k]) * r.dir_y[k] +
                    double(r.dir_z[k]) * r.dir_z[k];
  if (!(std::isfinite(r.org_x[k]) && std::isfinite(r.org_y[k]) && std::isfinite(r.org_z[k]) &&
        std::fabs(d2 - 1.0) <= 1e-5 && !std::isnan(r.tnear[k]) && !std::isnan(r.tfar[k])))
    refuse_ray(what, r, k, d2);
}

// The caller's valid mask, or every lane on where it gave none.
template <int N>
const int* on_lanes(const int* valid) {
  static constexpr auto kAll = [] {
    std::array<int, N> a{};
    for (int& x : a) x = 1;
    return a;
  }();
  return valid ? valid : kAll.data();
}

// Every active lane, before any is traced: on an error nothing has been written. Only where
// some lane fails does check_ray find the first and say what. Returns whether the packet is
// plain (scan_rays' bit 1).
template <class T, int N>
bool check_rays(const char* what, const int* valid, const RayPacket<N>& r, T eps,
                const packet::KernelTable<T>* k) {
  int live = N;
  if (valid) {
    live = 0;
    for (int l = 0; l < N; ++l) live += int(valid[l] != 0);
  }
  // A few active lanes: those alone; else every lane in one pass, the failing one found after.
  const auto scan_rays = k ? k->scan_rays : &packet::scan_rays<void, T>;
  const int scan = 4 * live < N
                       ? 1
                       : scan_rays(N, r.org_x, r.org_y, r.org_z, r.dir_x, r.dir_y, r.dir_z, r.tnear,
                                   r.tfar, r.mask, on_lanes<N>(valid), kAllObjects, eps);
  if (scan & 1)
    for (int l = 0; l < N; ++l)
      if (valid == nullptr || valid[l] != 0) check_ray(what, r, l);
  return (scan & 2) != 0;
}

// A caller's packet, straight from its arrays (valid may be null: every lane on).
template <int N>
packet::RayLanes ray_lanes(const int* valid, const RayPacket<N>& r) {
  return {r.org_x,    r.org_y, r.org_z, r.dir_x, r.dir_y,
          r.dir_z,    r.tnear, r.tfar,  r.mask,  on_lanes<N>(valid),
          kAllObjects};
}

}  // namespace lancer::api::checks
