// A packet's radiance: the reflections' chain folded bottom-up, or the ray tree of scenes with
// refraction, adding in the reference's order.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <vector>

#include "lancer/packet/shading.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct Radiance : Shading<Arch, Real, Mode> {
  using Sh = Shading<Arch, Real, Mode>;
  using typename Sh::B;
  using typename Sh::GivenHit;
  using typename Sh::I;
  using typename Sh::Id;
  using typename Sh::Level;
  using typename Sh::M;
  using typename Sh::Prepared;
  using typename Sh::V;

  // The ray tree of the lanes of `active` from `depth` on, for scenes with refraction:
  // recursion over packets with masks, depth first. Each level shades its lanes, then traces
  // the reflected packet, then the refracted one, each on the lanes that spawned it, and adds
  // local + reflect * child, then + transmit * child: the reference's order, bottom-up.
  // Recursion is at most max_depth + 1 deep; splitting materials bound it (kMaxSplitDepth).
  [[gnu::noinline]] static void radiance_tree(const Prepared& s, M active, int depth, int stage,
                                              V o, V d, I leaving, B& r, B& g, B& b,
                                              RayCounts& counts,
                                              const GivenHit* given = nullptr) noexcept {
    Level lv;
    const M reflected =
        Sh::template shade<true>(s, active, depth, stage, o, d, leaving, lv, counts, given);
    r = lv.r, g = lv.g, b = lv.b;
    if (xsimd::any(reflected)) {
      B cr, cg, cb;
      radiance_tree(s, reflected, depth + 1, kReflection, o, d, leaving, cr, cg, cb, counts);
      r = xsimd::select(reflected, r + lv.reflect * cr, r);
      g = xsimd::select(reflected, g + lv.reflect * cg, g);
      b = xsimd::select(reflected, b + lv.reflect * cb, b);
    }
    if (xsimd::any(lv.refracted)) {
      B cr, cg, cb;
      radiance_tree(s, lv.refracted, depth + 1, kRefraction, lv.to, lv.td, lv.t_leaving, cr, cg, cb,
                    counts);
      r = xsimd::select(lv.refracted, r + lv.transmit * cr, r);
      g = xsimd::select(lv.refracted, g + lv.transmit * cg, g);
      b = xsimd::select(lv.refracted, b + lv.transmit * cb, b);
    }
  }

  // The radiance of a packet of camera rays. Without refraction, reflection is an iterative
  // loop over levels with an active mask; the levels are then folded from the deepest up,
  // local + reflect * child, which is the order the reference's recursion adds in (a running
  // weight would not be). With refraction the rays form a tree: radiance_tree.
  template <bool kOneRay>
  [[gnu::always_inline]] static void radiance(const Prepared& s, M active, V o, V d,
                                              std::vector<Level>& levels, B& r, B& g, B& b,
                                              RayCounts& counts,
                                              const GivenHit* given = nullptr) noexcept {
    int depth = 0;
    I leaving(Id(-1));
    if (s.features.refraction) {
      radiance_tree(s, active, 0, kPrimaryIntersection, o, d, leaving, r, g, b, counts, given);
      return;
    }
    for (;;) {
      active = Sh::template shade<false, kOneRay>(
          s, active, depth, depth == 0 ? kPrimaryIntersection : kReflection, o, d, leaving,
          levels[depth], counts, depth == 0 ? given : nullptr);
      if (!xsimd::any(active)) break;
      ++depth;
    }
    r = levels[depth].r, g = levels[depth].g, b = levels[depth].b;
    for (int k = depth - 1; k >= 0; --k) {
      const Level& lv = levels[k];
      r = xsimd::select(lv.reflected, lv.r + lv.reflect * r, lv.r);
      g = xsimd::select(lv.reflected, lv.g + lv.reflect * g, lv.g);
      b = xsimd::select(lv.reflected, lv.b + lv.reflect * b, lv.b);
    }
  }
};

}  // namespace lancer::packet
