// The library API's rays checked and moved into the prepared frame (src/engine/api.cpp):
// world-space float origins and directions, Frame::point and Frame::direction written out in double
// (dot's order: x, y, then z) and rounded once to T. One plain loop over lanes without a branch,
// over restrict arrays, which the compiler vectorises for the ISA it is built for: each ISA's
// translation unit instantiates it for its kernel table (Arch names the instantiation), and the
// library's baseline code for the reference's width.
#pragma once

#include "lancer/prepared.hpp"

namespace lancer::packet {

template <class Arch, class T>
void frame_rays(const Frame& frame, int n, const float* __restrict ox, const float* __restrict oy,
                const float* __restrict oz, const float* __restrict dx, const float* __restrict dy,
                const float* __restrict dz, T* __restrict o0, T* __restrict o1, T* __restrict o2,
                T* __restrict o3, T* __restrict o4, T* __restrict o5) noexcept {
  const double ex = frame.origin.x, ey = frame.origin.y, ez = frame.origin.z;
  const double ux = frame.u.x, uy = frame.u.y, uz = frame.u.z;
  const double vx = frame.v.x, vy = frame.v.y, vz = frame.v.z;
  const double wx = frame.w.x, wy = frame.w.y, wz = frame.w.z, depth = frame.depth;
  for (int l = 0; l < n; ++l) {
    const double px = double(ox[l]) - ex, py = double(oy[l]) - ey, pz = double(oz[l]) - ez;
    const double qx = dx[l], qy = dy[l], qz = dz[l];
    o0[l] = T(px * ux + py * uy + pz * uz);
    o1[l] = T(px * vx + py * vy + pz * vz);
    o2[l] = T((px * wx + py * wy + pz * wz) + depth);
    o3[l] = T(qx * ux + qy * uy + qz * uz);
    o4[l] = T(qx * vx + qy * vy + qz * vz);
    o5[l] = T(qx * wx + qy * wy + qz * wz);
  }
}

// Whether some lane l < n with on[l] != 0 fails the API's checks (bit 0: an origin not finite,
// a direction whose |d|^2 is not within 1e-5 of 1, computed in double, a NaN tnear or tfar),
// and whether every lane is on, sees some object (mask & all_objects) and starts at epsilon
// (bit 1: the plain packet, whose lanes all go to the kernel). Bitwise operations, no branch.
template <class Arch, class T>
int scan_rays(int n, const float* __restrict ox, const float* __restrict oy,
              const float* __restrict oz, const float* __restrict dx, const float* __restrict dy,
              const float* __restrict dz, const float* __restrict tnear,
              const float* __restrict tfar, const unsigned* __restrict mask,
              const int* __restrict on, unsigned all_objects, T eps) noexcept {
  int bad = 0, plain = 1;
  for (int l = 0; l < n; ++l) {
    const double d2 = double(dx[l]) * dx[l] + double(dy[l]) * dy[l] + double(dz[l]) * dz[l];
    // x - x is 0 for finite x, NaN for an infinity or a NaN.
    const float o = (ox[l] - ox[l]) + (oy[l] - oy[l]) + (oz[l] - oz[l]);
    const double e = d2 - 1.0;
    const int ok = int(o == 0.0f) & int(e <= 1e-5) & int(e >= -1e-5) & int(tnear[l] == tnear[l]) &
                   int(tfar[l] == tfar[l]);
    const int live = int(on[l] != 0);
    bad |= (ok ^ 1) & live;
    plain &= live & int((mask[l] & all_objects) != 0) & int(T(tnear[l]) <= eps);
  }
  return bad | plain << 1;
}

}  // namespace lancer::packet
