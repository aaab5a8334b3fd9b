// Fast arithmetic for float batches (FastMode): fused multiply-adds (fused.hpp), and
// reciprocals / reciprocal square roots from the hardware's approximations refined by one Newton
// step. Include only from code built for the batch's ISA.
#pragma once

#include <cstdint>
#include <type_traits>
#include <xsimd/xsimd.hpp>

#include "lancer/packet/fused.hpp"
#include "lancer/packet/intrin.hpp"
#include "lancer/vec3.hpp"

namespace lancer::packet {

// Fast arithmetic for float batches: fused multiply-adds (fused.hpp), and reciprocals / reciprocal
// square roots from the hardware's approximations (12 bits on SSE/AVX, 14 on AVX-512) refined by
// one Newton step to about 22 bits. Which of these pay is measured by `lancer trade`.
template <class Arch>
struct FastMath {
  using B = xsimd::batch<float, Arch>;
  static constexpr bool kAvx512 = std::is_same_v<Arch, xsimd::avx512f>;

  static B approx_rcp(const B& x) noexcept {
    if constexpr (kAvx512)
      return _mm512_rcp14_ps(x);  // xsimd's avx512 reciprocal is an exact division
    else
      return xsimd::reciprocal(x);
  }
  static B approx_rsqrt(const B& x) noexcept {
    if constexpr (kAvx512)
      return _mm512_rsqrt14_ps(x);  // xsimd 8.1's rsqrt does not compile for avx512f
    else
      return xsimd::rsqrt(x);
  }
  // One Newton-Raphson step each: r' = r (2 - x r), y' = y (1.5 - x/2 y^2).
  static B rcp(const B& x) noexcept {
    const B r = approx_rcp(x);
    return fmadd(r, fnmadd(x, r, B(1.0f)), r);
  }
  static B rsqrt(const B& x) noexcept {
    const B y = approx_rsqrt(x);
    return y * fnmadd(B(0.5f) * x * y, y, B(1.5f));
  }

  static B dot(const Vec3<B>& a, const Vec3<B>& b) noexcept {
    return fmadd(a.z, b.z, fmadd(a.y, b.y, a.x * b.x));
  }
  static B div(const B& a, const B& b) noexcept { return a * rcp(b); }
  static Vec3<B> div(const Vec3<B>& v, const B& s) noexcept { return v * rcp(s); }
  static B length(const Vec3<B>& v) noexcept { return xsimd::sqrt(dot(v, v)); }
  static Vec3<B> normalize(const Vec3<B>& v) noexcept { return v * rsqrt(dot(v, v)); }
  static Vec3<B> sub_scaled(const Vec3<B>& a, const Vec3<B>& b, const B& s) noexcept {
    return {fnmadd(b.x, s, a.x), fnmadd(b.y, s, a.y), fnmadd(b.z, s, a.z)};
  }
  static Vec3<B> along(const Vec3<B>& o, const Vec3<B>& d, const B& t) noexcept {
    return {fmadd(t, d.x, o.x), fmadd(t, d.y, o.y), fmadd(t, d.z, o.z)};
  }
  static Vec3<B> reflect(const Vec3<B>& d, const Vec3<B>& n) noexcept {
    return sub_scaled(d, n, B(2.0f) * dot(d, n));
  }

  // c^e for c in [0, 1] and e >= 0 as 2^(e log2 c), each by a short polynomial (least-squares
  // fits on [0, 1): 2e-6 absolute in log2(1+m)/m, 1e-7 in 2^f): a fixed dozen operations where
  // binary powering loops log2(e) times. 0^e is 0 (e > 0) and c^0 is 1, as std::pow.
  static B pow01(const B& c, const B& e) noexcept {
    using I = xsimd::batch<std::int32_t, Arch>;
    const I bits = xsimd::bitwise_cast<I>(c);
    const B exponent = xsimd::batch_cast<float>((bits >> 23) - I(127));
    const B m = xsimd::bitwise_cast<B>((bits & I(0x007fffff)) | I(0x3f800000)) - B(1.0f);
    B g = B(0.0204903372f);
    g = fmadd(g, m, B(-0.0960662224f));
    g = fmadd(g, m, B(0.215588502f));
    g = fmadd(g, m, B(-0.339247757f));
    g = fmadd(g, m, B(0.477705927f));
    g = fmadd(g, m, B(-0.721162734f));
    g = fmadd(g, m, B(1.44269326f));
    const B log2c = fmadd(g, m, exponent);
    const B y = xsimd::max(e * log2c, B(-126.0f));
    const B yi = xsimd::floor(y);
    const B f = y - yi;
    B q = B(0.00189510704f);
    q = fmadd(q, f, B(0.00894621529f));
    q = fmadd(q, f, B(0.0558632821f));
    q = fmadd(q, f, B(0.24014077f));
    q = fmadd(q, f, B(0.69315462f));
    q = fmadd(q, f, B(0.999999896f));
    const I scaled = xsimd::bitwise_cast<I>(q) + (xsimd::batch_cast<std::int32_t>(yi) << 23);
    const B result = xsimd::bitwise_cast<B>(scaled);
    return xsimd::select(e == B(0.0f), B(1.0f), xsimd::select(c > B(0.0f), result, B(0.0f)));
  }
};

}  // namespace lancer::packet
