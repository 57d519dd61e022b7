#include "field/reference_kernel.h"

#include <immintrin.h>

#include <algorithm>

namespace qjulia::detail {
namespace {

constexpr int kInFlight = 4;  // independent vectors per group

__attribute__((target("avx512f,fma"))) std::uint64_t run_avx512(const double* x, const double* y,
                                                                const double* z, std::size_t n,
                                                                const Quat& c, int n_iter,
                                                                double bailout,
                                                                std::int32_t* exit_step) {
  const __m512d cw = _mm512_set1_pd(c.w), cx = _mm512_set1_pd(c.x), cy = _mm512_set1_pd(c.y),
                cz = _mm512_set1_pd(c.z), r2 = _mm512_set1_pd(bailout * bailout);
  std::uint64_t steps = 0;
  constexpr std::size_t kGroup = 8 * kInFlight;
  for (std::size_t base = 0; base < n; base += kGroup) {
    __m512d w[kInFlight], a[kInFlight], b[kInFlight], d[kInFlight];
    __mmask8 alive[kInFlight];
    __m512i step[kInFlight];
    for (int v = 0; v < kInFlight; ++v) {
      const std::size_t at = base + 8 * v;
      const __mmask8 in = at >= n ? 0 : n - at >= 8 ? 0xff : (1u << (n - at)) - 1;
      w[v] = _mm512_maskz_loadu_pd(in, x + at);
      a[v] = _mm512_maskz_loadu_pd(in, y + at);
      b[v] = _mm512_maskz_loadu_pd(in, z + at);
      d[v] = _mm512_setzero_pd();
      const __m512d n2 =
          _mm512_fmadd_pd(b[v], b[v], _mm512_fmadd_pd(a[v], a[v], _mm512_mul_pd(w[v], w[v])));
      alive[v] = _mm512_mask_cmp_pd_mask(in, n2, r2, _CMP_LE_OQ);
      step[v] = _mm512_mask_set1_epi64(_mm512_set1_epi64(-1), in & ~alive[v], 0);
    }
    for (int k = 1; k <= n_iter; ++k) {
      __mmask8 any = 0;
      for (int v = 0; v < kInFlight; ++v) {
        // h^2 + c: (w^2 - |v|^2 + cw, 2 w v + c)
        const __m512d t = _mm512_add_pd(w[v], w[v]);
        const __m512d nw = _mm512_fnmadd_pd(
            d[v], d[v],
            _mm512_fnmadd_pd(b[v], b[v],
                             _mm512_fnmadd_pd(a[v], a[v], _mm512_fmadd_pd(w[v], w[v], cw))));
        a[v] = _mm512_fmadd_pd(t, a[v], cx);
        b[v] = _mm512_fmadd_pd(t, b[v], cy);
        d[v] = _mm512_fmadd_pd(t, d[v], cz);
        w[v] = nw;
        const __m512d n2 = _mm512_fmadd_pd(
            d[v], d[v],
            _mm512_fmadd_pd(b[v], b[v], _mm512_fmadd_pd(a[v], a[v], _mm512_mul_pd(nw, nw))));
        steps += static_cast<std::uint64_t>(__builtin_popcount(alive[v]));
        const __mmask8 out = _mm512_mask_cmp_pd_mask(alive[v], n2, r2, _CMP_NLE_UQ);
        step[v] = _mm512_mask_set1_epi64(step[v], out, k);
        alive[v] &= static_cast<__mmask8>(~out);
        any |= alive[v];
      }
      if (!any) break;
    }
    for (int v = 0; v < kInFlight; ++v) {
      const std::size_t at = base + 8 * v;
      if (at >= n) break;
      alignas(64) long long s[8];
      _mm512_store_si512(s, step[v]);
      for (std::size_t i = 0; i < std::min<std::size_t>(8, n - at); ++i)
        exit_step[at + i] = static_cast<std::int32_t>(s[i]);
    }
  }
  return steps;
}

__attribute__((target("avx2,fma"))) std::uint64_t run_avx2(const double* x, const double* y,
                                                           const double* z, std::size_t n,
                                                           const Quat& c, int n_iter,
                                                           double bailout,
                                                           std::int32_t* exit_step) {
  const __m256d cw = _mm256_set1_pd(c.w), cx = _mm256_set1_pd(c.x), cy = _mm256_set1_pd(c.y),
                cz = _mm256_set1_pd(c.z), r2 = _mm256_set1_pd(bailout * bailout);
  std::uint64_t steps = 0;
  constexpr std::size_t kGroup = 4 * kInFlight;
  for (std::size_t base = 0; base < n; base += kGroup) {
    alignas(32) double lx[kGroup] = {}, ly[kGroup] = {}, lz[kGroup] = {};
    const std::size_t m = std::min(kGroup, n - base);
    std::copy_n(x + base, m, lx);
    std::copy_n(y + base, m, ly);
    std::copy_n(z + base, m, lz);
    __m256d w[kInFlight], a[kInFlight], b[kInFlight], d[kInFlight], alive[kInFlight],
        step[kInFlight];
    for (int v = 0; v < kInFlight; ++v) {
      w[v] = _mm256_load_pd(lx + 4 * v);
      a[v] = _mm256_load_pd(ly + 4 * v);
      b[v] = _mm256_load_pd(lz + 4 * v);
      d[v] = _mm256_setzero_pd();
      const __m256d n2 =
          _mm256_fmadd_pd(b[v], b[v], _mm256_fmadd_pd(a[v], a[v], _mm256_mul_pd(w[v], w[v])));
      alive[v] = _mm256_cmp_pd(n2, r2, _CMP_LE_OQ);
      step[v] = _mm256_blendv_pd(_mm256_setzero_pd(), _mm256_set1_pd(-1), alive[v]);
    }
    for (int k = 1; k <= n_iter; ++k) {
      int any = 0;
      const __m256d kv = _mm256_set1_pd(k);
      for (int v = 0; v < kInFlight; ++v) {
        const __m256d t = _mm256_add_pd(w[v], w[v]);
        const __m256d nw = _mm256_fnmadd_pd(
            d[v], d[v],
            _mm256_fnmadd_pd(b[v], b[v],
                             _mm256_fnmadd_pd(a[v], a[v], _mm256_fmadd_pd(w[v], w[v], cw))));
        a[v] = _mm256_fmadd_pd(t, a[v], cx);
        b[v] = _mm256_fmadd_pd(t, b[v], cy);
        d[v] = _mm256_fmadd_pd(t, d[v], cz);
        w[v] = nw;
        const __m256d n2 = _mm256_fmadd_pd(
            d[v], d[v],
            _mm256_fmadd_pd(b[v], b[v], _mm256_fmadd_pd(a[v], a[v], _mm256_mul_pd(nw, nw))));
        steps += static_cast<std::uint64_t>(__builtin_popcount(_mm256_movemask_pd(alive[v])));
        const __m256d out = _mm256_and_pd(alive[v], _mm256_cmp_pd(n2, r2, _CMP_NLE_UQ));
        step[v] = _mm256_blendv_pd(step[v], kv, out);
        alive[v] = _mm256_andnot_pd(out, alive[v]);
        any |= _mm256_movemask_pd(alive[v]);
      }
      if (!any) break;
    }
    for (int v = 0; v < kInFlight; ++v) {
      alignas(32) double s[4];
      _mm256_store_pd(s, step[v]);
      for (int i = 0; i < 4; ++i)
        if (base + 4 * v + i < n) exit_step[base + 4 * v + i] = static_cast<std::int32_t>(s[i]);
    }
  }
  return steps;
}

}  // namespace

std::uint64_t reference_julia_escape(const double* x, const double* y, const double* z,
                                     std::size_t n, const Quat& c, int n_iter, double bailout,
                                     std::int32_t* exit_step) {
  if (__builtin_cpu_supports("avx512f"))
    return run_avx512(x, y, z, n, c, n_iter, bailout, exit_step);
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
    return run_avx2(x, y, z, n, c, n_iter, bailout, exit_step);
  return 0;
}

const char* reference_kernel_isa() {
  if (__builtin_cpu_supports("avx512f")) return "AVX-512";
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "AVX2";
  return "none";
}

}  // namespace qjulia::detail
