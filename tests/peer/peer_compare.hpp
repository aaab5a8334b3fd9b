// The Embree peer's camera hits against lancer's reference, ray by ray (test_peer.cpp,
// test_peer_shapes.cpp): rays whose hit or miss differ, whose object differs, and the largest
// |dt| / t where both hit the same object.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "lancer/formulas.hpp"
#include "lancer/peer.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "lancer/shapes.hpp"

namespace lancer::testing {

struct Agreement {
  std::size_t rays = 0, hit_miss = 0, other_object = 0;
  std::size_t other_cylinder = 0;  // of other_object, those where Embree hit a cylinder
  double max_rel_t = 0;            // over rays both hit on the same object
};

inline bool is_cylinder(const PreparedScene<float>& s, int id) {
  return s.shapes && std::find(s.shapes->cyl_object.begin(), s.shapes->cyl_object.end(), id) !=
                         s.shapes->cyl_object.end();
}

// Picks the rays compared: from lancer's hit object, the ray and its t.
using Checked = bool (*)(const PreparedScene<float>&, int id, const Vec3<float>& o,
                         const Vec3<float>& d, float t);

// Every camera ray of `scene` through lancer's reference closest hit (bit-identical to the
// packets by lancer's own tests) and through Embree at `width`; `checked` (null: every ray)
// picks the rays compared.
inline Agreement compare_camera_rays(const Scene& scene, const peer::EmbreeScene& embree, int width,
                                     Checked checked = nullptr) {
  const PreparedScene<float> s = prepare<float>(scene);
  const PreparedCamera<float>& cam = s.camera;
  const std::vector<peer::PeerHit> hits = embree.camera_hits(width);
  Agreement a;
  for (int b = 0; b < cam.samples; ++b)
    for (int aa = 0; aa < cam.samples; ++aa)
      for (int j = 0; j < cam.ny; ++j)
        for (int i = 0; i < cam.nx; ++i) {
          Vec3<float> o, d;
          camera_ray(cam, cam.screen_x[std::size_t(aa) * cam.nx + i],
                     cam.screen_y[std::size_t(b) * cam.ny + j], o, d);
          const reference::Hit<float> l = reference::closest_hit(s, o, d);
          if (checked && !checked(s, l.id, o, d, l.t)) continue;
          const peer::PeerHit& e =
              hits[(std::size_t(b * cam.samples + aa) * cam.ny + j) * cam.nx + i];
          ++a.rays;
          if ((l.id >= 0) != (e.id >= 0))
            ++a.hit_miss;
          else if (l.id != e.id)
            ++a.other_object, a.other_cylinder += is_cylinder(s, e.id);
          else if (l.id >= 0)
            a.max_rel_t = std::max(a.max_rel_t, double(std::abs(e.t - l.t) / l.t));
        }
  return a;
}

}  // namespace lancer::testing
