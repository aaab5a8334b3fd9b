// The library API's rays checked and moved into the prepared frame (src/engine/api.cpp):
// world-space float origins and directions, Frame::point and Frame::direction written out in double
// (dot's order: x, y, then z; no products where the frame keeps the world's axes, and then, at a
// float origin, the same numbers by float subtractions) and rounded once to T. Plain loops over
// lanes without a branch, over restrict arrays, which the compiler vectorises for the ISA it is
// built for: each ISA's translation unit instantiates them for its kernel table (Arch names the
// instantiation), and the library's baseline code for the reference's width. One lane's check and
// move are written once (ray_fails, FrameMove) and shared by every loop.
#pragma once

#include <type_traits>

#include "lancer/prepared.hpp"

namespace lancer::packet {

// 1 where a ray fails the API's checks: an origin not finite, a direction whose |d|^2 is not
// within 1e-5 of 1, computed in double, a NaN tnear or tfar. Bitwise operations, no branch.
[[gnu::always_inline]] inline int ray_fails(float ox, float oy, float oz, float dx, float dy,
                                            float dz, float tnear, float tfar) noexcept {
  const double d2 = double(dx) * dx + double(dy) * dy + double(dz) * dz;
  // x - x is 0 for finite x, NaN for an infinity or a NaN.
  const float o = (ox - ox) + (oy - oy) + (oz - oz);
  const double e = d2 - 1.0;
  const int ok =
      int(o == 0.0f) & int(e <= 1e-5) & int(e >= -1e-5) & int(tnear == tnear) & int(tfar == tfar);
  return ok ^ 1;
}

// 1 where a live lane is plain: it sees some object and starts at epsilon (the kernel alone
// answers it).
template <class T>
[[gnu::always_inline]] inline int ray_plain(float tnear, unsigned mask, unsigned all_objects,
                                            T eps) noexcept {
  return int((mask & all_objects) != 0) & int(T(tnear) <= eps);
}

// Frame::point and Frame::direction of one lane, the frame's numbers held in locals. Axes: the
// frame keeps the world's axes (Frame::axes), the same functions without the products.
struct FrameMove {
  double ex, ey, ez, ux, uy, uz, vx, vy, vz, wx, wy, wz, depth;
  explicit FrameMove(const Frame& f) noexcept
      : ex(f.origin.x),
        ey(f.origin.y),
        ez(f.origin.z),
        ux(f.u.x),
        uy(f.u.y),
        uz(f.u.z),
        vx(f.v.x),
        vy(f.v.y),
        vz(f.v.z),
        wx(f.w.x),
        wy(f.w.y),
        wz(f.w.z),
        depth(f.depth) {}
  // Whether a float frame keeping the world's axes moves a point by a float subtraction: its
  // origin floats, no depth. double(a) - double(b) rounded to float is then a - b in float
  // (double's 53 bits are more than 2 x 24 + 2: the double rounding is innocuous), so the move
  // runs in float, twice the lanes of double.
  template <class T>
  bool in_float() const noexcept {
    return std::is_same_v<T, float> && depth == 0 && double(float(ex)) == ex &&
           double(float(ey)) == ey && double(float(ez)) == ez;
  }
  template <bool Axes, bool InFloat = false, class T>
  [[gnu::always_inline]] void operator()(float ox, float oy, float oz, float dx, float dy, float dz,
                                         T& o0, T& o1, T& o2, T& o3, T& o4, T& o5) const noexcept {
    if constexpr (InFloat) {
      o0 = ox - float(ex), o1 = oy - float(ey), o2 = oz - float(ez);
      o3 = dx, o4 = dy, o5 = dz;
      return;
    }
    const double px = double(ox) - ex, py = double(oy) - ey, pz = double(oz) - ez;
    if constexpr (Axes) {
      o0 = T(px), o1 = T(py), o2 = T(pz + depth);
      o3 = T(dx), o4 = T(dy), o5 = T(dz);
    } else {
      const double qx = dx, qy = dy, qz = dz;
      o0 = T(px * ux + py * uy + pz * uz);
      o1 = T(px * vx + py * vy + pz * vz);
      o2 = T((px * wx + py * wy + pz * wz) + depth);
      o3 = T(qx * ux + qy * uy + qz * uz);
      o4 = T(qx * vx + qy * vy + qz * vz);
      o5 = T(qx * wx + qy * wy + qz * wz);
    }
  }
};

// fn(move, axes, in_float) with the frame's FrameMove and, as std::bool_constant, the move it
// takes for T: turned; the axes in double; the axes in float (FrameMove::in_float). The one
// place a loop's move is chosen, once a call.
template <class T, class Fn>
[[gnu::always_inline]] inline decltype(auto) with_move(const Frame& frame, Fn&& fn) noexcept {
  const FrameMove move(frame);
  if (!frame.axes) return fn(move, std::false_type{}, std::false_type{});
  if (move.in_float<T>()) return fn(move, std::true_type{}, std::true_type{});
  return fn(move, std::true_type{}, std::false_type{});
}

template <bool Axes, bool InFloat, class T>
[[gnu::always_inline]] inline void frame_rays_loop(
    const FrameMove& move, int n, const float* __restrict ox, const float* __restrict oy,
    const float* __restrict oz, const float* __restrict dx, const float* __restrict dy,
    const float* __restrict dz, T* __restrict o0, T* __restrict o1, T* __restrict o2,
    T* __restrict o3, T* __restrict o4, T* __restrict o5) noexcept {
  for (int l = 0; l < n; ++l)
    move.operator()<Axes, InFloat>(ox[l], oy[l], oz[l], dx[l], dy[l], dz[l], o0[l], o1[l], o2[l],
                                   o3[l], o4[l], o5[l]);
}

template <class Arch, class T>
void frame_rays(const Frame& frame, int n, const float* __restrict ox, const float* __restrict oy,
                const float* __restrict oz, const float* __restrict dx, const float* __restrict dy,
                const float* __restrict dz, T* __restrict o0, T* __restrict o1, T* __restrict o2,
                T* __restrict o3, T* __restrict o4, T* __restrict o5) noexcept {
  with_move<T>(frame, [&](const FrameMove& move, auto axes, auto in_float) {
    frame_rays_loop<decltype(axes)::value, decltype(in_float)::value>(move, n, ox, oy, oz, dx, dy,
                                                                      dz, o0, o1, o2, o3, o4, o5);
  });
}

// Whether some lane l < n with on[l] != 0 fails the API's checks (bit 0) and whether every
// lane is on and plain (bit 1: the plain packet, whose lanes all go to the kernel).
template <class Arch, class T>
int scan_rays(int n, const float* __restrict ox, const float* __restrict oy,
              const float* __restrict oz, const float* __restrict dx, const float* __restrict dy,
              const float* __restrict dz, const float* __restrict tnear,
              const float* __restrict tfar, const unsigned* __restrict mask,
              const int* __restrict on, unsigned all_objects, T eps) noexcept {
  int bad = 0, plain = 1;
  for (int l = 0; l < n; ++l) {
    const int live = int(on[l] != 0);
    bad |= ray_fails(ox[l], oy[l], oz[l], dx[l], dy[l], dz[l], tnear[l], tfar[l]) & live;
    plain &= live & ray_plain(tnear[l], mask[l], all_objects, eps);
  }
  return bad | plain << 1;
}

// The caller's arrays of one packet's W lanes (lancer.hpp's RayPacket from some lane on), for
// the kernels' one-pass entries (packet/kernel.hpp intersect_lanes, occluded_lanes). `on` is
// the caller's valid mask, or all ones.
struct RayLanes {
  const float *ox, *oy, *oz, *dx, *dy, *dz, *tnear, *tfar;
  const unsigned* mask;
  const int* on;
  unsigned all_objects;
  // The lanes from lane c on.
  RayLanes from(int c) const noexcept {
    return {ox + c,    oy + c,   oz + c,   dx + c, dy + c,     dz + c,
            tnear + c, tfar + c, mask + c, on + c, all_objects};
  }
};

// W lanes checked and moved in one pass, into rays' six rows of W (origin x, y, z, direction
// x, y, z): scan_rays' bits, and frame_rays' values. W is the kernel's: no remainder loop.
template <int W, bool Axes, bool InFloat, class T>
[[gnu::always_inline]] inline int take_rays_in(const FrameMove& move, const RayLanes& r, T eps,
                                               T* __restrict rays) noexcept {
  const float* __restrict ox = r.ox, * __restrict oy = r.oy, * __restrict oz = r.oz;
  const float* __restrict dx = r.dx, * __restrict dy = r.dy, * __restrict dz = r.dz;
  int bad = 0, plain = 1;
  for (int l = 0; l < W; ++l) {
    const int live = int(r.on[l] != 0);
    bad |= ray_fails(ox[l], oy[l], oz[l], dx[l], dy[l], dz[l], r.tnear[l], r.tfar[l]) & live;
    plain &= live & ray_plain(r.tnear[l], r.mask[l], r.all_objects, eps);
    move.operator()<Axes, InFloat>(ox[l], oy[l], oz[l], dx[l], dy[l], dz[l], rays[l], rays[W + l],
                                   rays[2 * W + l], rays[3 * W + l], rays[4 * W + l],
                                   rays[5 * W + l]);
  }
  return bad | plain << 1;
}

template <int W, class T>
[[gnu::always_inline]] inline int take_rays(const Frame& frame, const RayLanes& r, T eps,
                                            T* __restrict rays) noexcept {
  return with_move<T>(frame, [&](const FrameMove& move, auto axes, auto in_float) {
    return take_rays_in<W, decltype(axes)::value, decltype(in_float)::value>(move, r, eps, rays);
  });
}

}  // namespace lancer::packet
