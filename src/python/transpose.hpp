// Rows of (x, y, z) floats to and from the API's structure-of-arrays packets, four rows at a time
// with SSE2 shuffles (every x86-64 CPU has them): the module's share of a ray query is reading
// each ray from the caller's (n, 3) arrays into a packet and writing its normal back, and a
// lane-by-lane copy of that costs as much as a tenth of a query on a small scene.
#pragma once

#include <cstddef>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace lancer::python {

// 4 rows (12 floats: x0 y0 z0 x1 y1 z1 ...) into x[0..3], y[0..3], z[0..3].
inline void rows_to_lanes4(const float* in, float* x, float* y, float* z) {
#if defined(__SSE2__)
  const __m128 a = _mm_loadu_ps(in);                                // x0 y0 z0 x1
  const __m128 b = _mm_loadu_ps(in + 4);                            // y1 z1 x2 y2
  const __m128 c = _mm_loadu_ps(in + 8);                            // z2 x3 y3 z3
  const __m128 t = _mm_shuffle_ps(b, c, _MM_SHUFFLE(1, 1, 2, 2));   // x2 x2 x3 x3
  _mm_storeu_ps(x, _mm_shuffle_ps(a, t, _MM_SHUFFLE(2, 0, 3, 0)));  // x0 x1 x2 x3
  const __m128 u = _mm_shuffle_ps(b, c, _MM_SHUFFLE(2, 2, 3, 0));   // y1 y2 y3 y3
  const __m128 v = _mm_shuffle_ps(a, u, _MM_SHUFFLE(0, 0, 1, 1));   // y0 y0 y1 y1
  _mm_storeu_ps(y, _mm_shuffle_ps(v, u, _MM_SHUFFLE(2, 1, 2, 0)));  // y0 y1 y2 y3
  const __m128 w = _mm_shuffle_ps(a, b, _MM_SHUFFLE(1, 1, 2, 2));   // z0 z0 z1 z1
  const __m128 q = _mm_shuffle_ps(c, c, _MM_SHUFFLE(3, 3, 0, 0));   // z2 z2 z3 z3
  _mm_storeu_ps(z, _mm_shuffle_ps(w, q, _MM_SHUFFLE(2, 0, 2, 0)));  // z0 z1 z2 z3
#else
  for (int k = 0; k < 4; ++k) x[k] = in[3 * k], y[k] = in[3 * k + 1], z[k] = in[3 * k + 2];
#endif
}

// The inverse: x[0..3], y[0..3], z[0..3] into 4 rows (12 floats).
inline void lanes_to_rows4(const float* x, const float* y, const float* z, float* out) {
#if defined(__SSE2__)
  const __m128 X = _mm_loadu_ps(x), Y = _mm_loadu_ps(y), Z = _mm_loadu_ps(z);
  const __m128 xy_lo = _mm_unpacklo_ps(X, Y);                                   // x0 y0 x1 y1
  const __m128 xy_hi = _mm_unpackhi_ps(X, Y);                                   // x2 y2 x3 y3
  const __m128 zx0 = _mm_shuffle_ps(Z, X, _MM_SHUFFLE(1, 1, 0, 0));             // z0 z0 x1 x1
  const __m128 yz1 = _mm_shuffle_ps(Y, Z, _MM_SHUFFLE(1, 1, 1, 1));             // y1 y1 z1 z1
  const __m128 zx2 = _mm_shuffle_ps(Z, X, _MM_SHUFFLE(3, 3, 2, 2));             // z2 z2 x3 x3
  const __m128 yz3 = _mm_shuffle_ps(Y, Z, _MM_SHUFFLE(3, 3, 3, 3));             // y3 y3 z3 z3
  _mm_storeu_ps(out, _mm_shuffle_ps(xy_lo, zx0, _MM_SHUFFLE(2, 0, 1, 0)));      // x0 y0 z0 x1
  _mm_storeu_ps(out + 4, _mm_shuffle_ps(yz1, xy_hi, _MM_SHUFFLE(1, 0, 2, 0)));  // y1 z1 x2 y2
  _mm_storeu_ps(out + 8, _mm_shuffle_ps(zx2, yz3, _MM_SHUFFLE(2, 0, 2, 0)));    // z2 x3 y3 z3
#else
  for (int k = 0; k < 4; ++k) out[3 * k] = x[k], out[3 * k + 1] = y[k], out[3 * k + 2] = z[k];
#endif
}

}  // namespace lancer::python
