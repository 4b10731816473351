#pragma once
// 16-lane float vectors for the per-pixel loops: one lane per pixel of a 4x4-pixel block.
// Values are GCC/Clang vector extensions, so arithmetic compiles for any instruction set; lane
// masks are AVX-512 mask registers where available (comparisons, blends and masked updates are
// then one instruction each), and all-ones/all-zeros integer lanes elsewhere.
#include <array>
#include <cstdint>
#include <cstring>
#include <utility>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif
#if defined(__SSE__)
#include <xmmintrin.h>
#endif
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "retimegs/render/formulas.hpp"
#include "retimegs/render/options.hpp"

// Without AVX-512, GCC notes that 64-byte vector arguments change the calling convention; these
// helpers are all inline, so no such call remains.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace retimegs::render::simd {

constexpr int kLanes = kTileSize;
using vf = float __attribute__((vector_size(kLanes * sizeof(float))));
using vi = std::int32_t __attribute__((vector_size(kLanes * sizeof(std::int32_t))));

// x - 0 is x for every x (-0 included), so this is a plain broadcast; vf{} + x is not (-0 + 0 is
// +0), so GCC would compute the scalar sum before broadcasting it.
inline vf splat(float x) {
  return x - vf{};
}
inline vi splat_int(std::int32_t x) {
  return vi{} + x;
}
inline void store(float* p, vf v) {
  std::memcpy(p, &v, sizeof(v));
}
inline void store(std::int32_t* p, vi v) {
  std::memcpy(p, &v, sizeof(v));
}

// One value stored around the caches (where the instruction set has it): for outputs that
// another thread or stage reads next, so that writing them does not first fetch the lines.
inline void store_stream(std::int32_t* p, std::int32_t v) {
#if defined(__SSE2__)
  _mm_stream_si32(p, v);
#else
  *p = v;
#endif
}
inline void store_stream(float* p, float v) {
  std::int32_t bits;
  std::memcpy(&bits, &v, sizeof(v));
  store_stream(reinterpret_cast<std::int32_t*>(p), bits);
}
// Orders the stream stores before the stores that follow (those of other threads included).
inline void stream_fence() {
#if defined(__SSE2__)
  _mm_sfence();
#endif
}

#if defined(__AVX512F__)
using mask = __mmask16;
constexpr mask kAllLanes = 0xffff;
inline mask lanes_below(int n) {
  return mask((1u << n) - 1u);
}  // lanes [0, n), n <= 16
inline mask less(vf a, vf b) {
  return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ);
}
inline mask less_equal(vf a, vf b) {
  return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ);
}
inline mask greater_equal(vf a, vf b) {
  return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ);
}
inline mask less(vi a, vi b) {
  return _mm512_cmplt_epi32_mask((__m512i)a, (__m512i)b);
}
inline mask and_not(mask a, mask b) {
  return _kandn_mask16(b, a);
}
inline bool any(mask m) {
  return m != 0;
}
// Bit l set iff lane l is.
inline std::uint32_t bits(mask m) {
  return m;
}
// m ? a : b, lane-wise.
inline vf select(mask m, vf a, vf b) {
  return _mm512_mask_blend_ps(m, b, a);
}
inline vi select(mask m, vi a, vi b) {
  return (vi)_mm512_mask_blend_epi32(m, (__m512i)b, (__m512i)a);
}
// m ? a * b : 0.
inline vf mul_or_zero(mask m, vf a, vf b) {
  return _mm512_maskz_mul_ps(m, a, b);
}
// c + (m ? 1 : 0).
inline vi count_if(vi c, mask m) {
  return (vi)_mm512_mask_add_epi32((__m512i)c, m, (__m512i)c, _mm512_set1_epi32(1));
}
#else
using mask = vi;
inline mask lanes_below(int n) {
  vi m;
  for (int l = 0; l < kLanes; ++l) m[l] = l < n ? -1 : 0;
  return m;
}
inline mask less(vf a, vf b) {
  return a < b;
}
inline mask less_equal(vf a, vf b) {
  return a <= b;
}
inline mask greater_equal(vf a, vf b) {
  return a >= b;
}
inline mask less(vi a, vi b) {
  return a < b;
}
inline mask and_not(mask a, mask b) {
  return a & ~b;
}
inline bool any(mask m) {
  std::int32_t r = 0;
  for (int l = 0; l < kLanes; ++l) r |= m[l];
  return r != 0;
}
inline std::uint32_t bits(mask m) {
  std::uint32_t r = 0;
  for (int l = 0; l < kLanes; ++l) r |= std::uint32_t(m[l] != 0) << l;
  return r;
}
inline vf select(mask m, vf a, vf b) {
  return (vf)(((vi)a & m) | ((vi)b & ~m));
}
inline vi select(mask m, vi a, vi b) {
  return (a & m) | (b & ~m);
}
inline vf mul_or_zero(mask m, vf a, vf b) {
  return (vf)((vi)(a * b) & m);
}
inline vi count_if(vi c, mask m) {
  return c - m;
}  // m is -1 where set
#endif

// a < b ? a : b and a < b ? b : a, lane-wise (vminps / vmaxps compute exactly these).
inline vf min(vf a, vf b) {
#if defined(__AVX512F__)
  return _mm512_maskz_min_ps(kAllLanes, a, b);
#else
  return select(less(a, b), a, b);
#endif
}

// sqrt(max(x, 0)), lane-wise.
inline vf sqrt_nonnegative(vf x) {
#if defined(__AVX512F__)
  return _mm512_maskz_sqrt_ps(kAllLanes, _mm512_maskz_max_ps(kAllLanes, x, _mm512_setzero_ps()));
#else
  vf r;
  for (int l = 0; l < kLanes; ++l) r[l] = x[l] > 0.0f ? __builtin_sqrtf(x[l]) : 0.0f;
  return r;
#endif
}

// floor(x) and ceil(x) as integers, for |x| < 2^31.
inline vi floor_to_int(vf x) {
#if defined(__AVX512F__)
  return (vi)_mm512_maskz_cvt_roundps_epi32(kAllLanes, x,
                                            _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
#else
  vi r;
  for (int l = 0; l < kLanes; ++l) r[l] = std::int32_t(__builtin_floorf(x[l]));
  return r;
#endif
}
inline vi ceil_to_int(vf x) {
#if defined(__AVX512F__)
  return (vi)_mm512_maskz_cvt_roundps_epi32(kAllLanes, x,
                                            _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC);
#else
  vi r;
  for (int l = 0; l < kLanes; ++l) r[l] = std::int32_t(__builtin_ceilf(x[l]));
  return r;
#endif
}

inline vf max(vf a, vf b) {
#if defined(__AVX512F__)
  return _mm512_maskz_max_ps(kAllLanes, b, a);
#else
  return select(less(a, b), b, a);
#endif
}
inline vi min(vi a, vi b) {
  return select(less(a, b), a, b);
}
inline vi max(vi a, vi b) {
  return select(less(a, b), b, a);
}

// Minimum and maximum over each group of 4 lanes (4g .. 4g + 3), in every lane of the group:
// two in-lane shuffles each.
template <typename Op>
inline vf group4(vf v, Op op) {
  const vf pairs =
      op(v, __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14));
  return op(pairs, __builtin_shufflevector(pairs, pairs, 2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14,
                                           15, 12, 13));
}
inline vf group4_min(vf v) {
  return group4(v, [](vf a, vf b) { return min(a, b); });
}
inline vf group4_max(vf v) {
  return group4(v, [](vf a, vf b) { return max(a, b); });
}

// Largest lane.
inline std::int32_t reduce_max(vi v) {
  std::int32_t r = v[0];
  for (int l = 1; l < kLanes; ++l) r = r > v[l] ? r : v[l];
  return r;
}

// The polynomial of 2^f on [0, 1) and the constants, shared with the CUDA kernels.
using render::exp2_fraction;
using render::kLn2;
using render::kLog2e;

// 2^y for finite y < 128 as 2^floor(y) * 2^(y - floor(y)); relative error < 3e-7. Results under
// 2^-126 are ~0.
inline vf exp2(vf y) {
#if defined(__AVX512F__) && defined(__AVX512DQ__)
  // vreduceps: y - floor(y) exactly, in one instruction; vscalefps multiplies by 2^floor(y)
  // itself. (The all-lanes masked forms: GCC 12 warns (falsely) about the unmasked ones'
  // undefined pass-through.)
  const vf f = _mm512_maskz_reduce_ps(kAllLanes, y, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  return _mm512_maskz_scalef_ps(kAllLanes, exp2_fraction(f), y);
#elif defined(__AVX512F__)
  const vf n = _mm512_maskz_roundscale_ps(kAllLanes, y, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  return _mm512_maskz_scalef_ps(kAllLanes, exp2_fraction(y - n), n);
#else
  constexpr float kMinExponent = -126.0f;  // below: 2^y would be denormal; flush to ~1e-38
  const vf y_min = select(less(y, splat(kMinExponent)), splat(kMinExponent), y);
  vf n;
  for (int l = 0; l < kLanes; ++l) n[l] = __builtin_floorf(y_min[l]);
  const vi bits = (__builtin_convertvector(n, vi) + 127) << 23;
  return exp2_fraction(y_min - n) * (vf)bits;
#endif
}

// ln(x) for x >= 0 (denormals included; 0 gives -inf), within 2 ulps; ln(1) = 0 exactly.
// x = 2^e (1 + f) with 1 + f in [sqrt(1/2), sqrt(2)), ln(1 + f) = f - f^2 / 2 + f^3 P(f) with
// Cephes' degree-8 P for logf, and e ln 2 added as e (ln 2)_high + e (ln 2)_low, (ln 2)_high with
// 9 significant bits (the products are exact).
inline vf log_nonnegative(vf x) {
  constexpr float kMinNormal = 1.17549435e-38f, kDenormalScale = 8388608.0f;  // 2^-126, 2^23
  const mask zero = less_equal(x, vf{});
  const mask tiny = less(x, splat(kMinNormal));
  x = select(tiny, x * kDenormalScale, x);
  // The bits of x minus those of sqrt(1/2): the exponent of 1 + f in the top bits.
  constexpr std::int32_t kSqrtHalfBits = 0x3f3504f3, kExponentMask = std::int32_t(0xff800000u);
  const vi offset = (vi)x - kSqrtHalfBits;
  const vf e = __builtin_convertvector((offset >> 23) + select(tiny, splat_int(-23), vi{}), vf);
  const vf f = (vf)((vi)x - (offset & kExponentMask)) - 1.0f;
  vf p = splat(7.0376836292e-2f);
  p = p * f - 1.1514610310e-1f;
  p = p * f + 1.1676998740e-1f;
  p = p * f - 1.2420140846e-1f;
  p = p * f + 1.4249322787e-1f;
  p = p * f - 1.6668057665e-1f;
  p = p * f + 2.0000714765e-1f;
  p = p * f - 2.4999993993e-1f;
  p = p * f + 3.3333331174e-1f;
  const vf f2 = f * f;
  const vf ln_mantissa = f + (p * f * f2 - 0.5f * f2);
  constexpr float kLn2High = 0.693359375f, kLn2Low = -2.12194440e-4f;
  const vf result = (ln_mantissa + e * kLn2Low) + e * kLn2High;
  return select(zero, splat(-__builtin_inff()), result);
}

// 1 / x for x in [0.001, 1] (one minus a clamped alpha): rcp14 and one Newton step on AVX-512
// (relative error ~1e-7, a rounding or two from the quotient), a division elsewhere.
inline vf reciprocal(vf x) {
#if defined(__AVX512F__)
  const vf r = _mm512_maskz_rcp14_ps(kAllLanes, x);
  return r * (2.0f - x * r);
#else
  return 1.0f / x;
#endif
}

// Sum of the lanes by pairwise halving, in registers (the same order on every instruction set).
inline float sum(vf v) {
  using vf8 = float __attribute__((vector_size(8 * sizeof(float))));
  using vf4 = float __attribute__((vector_size(4 * sizeof(float))));
  const vf8 s8 = __builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7) +
                 __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15);
  const vf4 s4 =
      __builtin_shufflevector(s8, s8, 0, 1, 2, 3) + __builtin_shufflevector(s8, s8, 4, 5, 6, 7);
  return (s4[0] + s4[2]) + (s4[1] + s4[3]);
}

// Lane sums of 8 vectors at once: lane j of the result (j < 8) is the sum of v[j]'s lanes.
// A transposing tree (each level halves the partial sums per vector and doubles the vectors per
// register): 16 shuffles and 8 additions instead of 8 x 8 for eight separate sums.
inline vf sum8(const vf (&v)[8]) {
  vf c[4];  // c[i] = [8 partials of v[2i] | 8 of v[2i + 1]]
  for (int i = 0; i < 4; ++i)
    c[i] = __builtin_shufflevector(v[2 * i], v[2 * i + 1], 0, 1, 2, 3, 4, 5, 6, 7, 16, 17, 18, 19,
                                   20, 21, 22, 23) +
           __builtin_shufflevector(v[2 * i], v[2 * i + 1], 8, 9, 10, 11, 12, 13, 14, 15, 24, 25, 26,
                                   27, 28, 29, 30, 31);
  vf d[2];  // d[i] = 4 partials each of v[4i], v[4i + 1], v[4i + 2], v[4i + 3]
  for (int i = 0; i < 2; ++i)
    d[i] = __builtin_shufflevector(c[2 * i], c[2 * i + 1], 0, 1, 2, 3, 8, 9, 10, 11, 16, 17, 18, 19,
                                   24, 25, 26, 27) +
           __builtin_shufflevector(c[2 * i], c[2 * i + 1], 4, 5, 6, 7, 12, 13, 14, 15, 20, 21, 22,
                                   23, 28, 29, 30, 31);
  // e = 2 partials each of v[0] .. v[7]
  const vf e = __builtin_shufflevector(d[0], d[1], 0, 1, 4, 5, 8, 9, 12, 13, 16, 17, 20, 21, 24, 25,
                                       28, 29) +
               __builtin_shufflevector(d[0], d[1], 2, 3, 6, 7, 10, 11, 14, 15, 18, 19, 22, 23, 26,
                                       27, 30, 31);
  return __builtin_shufflevector(e, e, 0, 2, 4, 6, 8, 10, 12, 14, 0, 2, 4, 6, 8, 10, 12, 14) +
         __builtin_shufflevector(e, e, 1, 3, 5, 7, 9, 11, 13, 15, 1, 3, 5, 7, 9, 11, 13, 15);
}

// Rows <-> columns of a [16, W] row-major block (W <= 4): column k holds component k of row l in
// lane l. Contiguous vector loads or stores and at most three two-vector shuffles per result
// (GCC's __builtin_shuffle: vpermt2ps on AVX-512), in place of the 16-element gathers GCC emits
// for a per-lane form (a gather loads one element at a time).
namespace detail {
using Index = std::array<std::int32_t, kLanes>;

// Result r of a transpose: element j is lane lane(j) of source vector source(j). Loading, the
// sources are the W memory vectors and r is column k; storing, the sources are the W columns and
// r is memory vector k.
template <int W, bool kStore, int R>
struct Transpose {
  static_assert(W >= 1 && W <= 4, "one to four components");
  static constexpr int source(int j) {
    return kStore ? (kLanes * R + j) % W : (W * j + R) / kLanes;
  }
  static constexpr int lane(int j) { return kStore ? (kLanes * R + j) / W : (W * j + R) % kLanes; }
  template <typename F>
  static constexpr Index table(F f) {
    Index t{};
    for (int j = 0; j < kLanes; ++j) t[j] = f(j);
    return t;
  }
  // Sources 0 and 1, sources 2 and 3 (indices into the concatenated pair), then the merge.
  static constexpr Index low =
      table([](int j) { return source(j) < 2 ? kLanes * source(j) + lane(j) : 0; });
  static constexpr Index high =
      table([](int j) { return source(j) >= 2 ? kLanes * (source(j) - 2) + lane(j) : 0; });
  static constexpr Index merge = table([](int j) {
    return source(j) < 2 ? j : kLanes + (W == 3 ? lane(j) : j);  // W = 3: source 2 directly
  });

  static vi index(const Index& t) {
    vi v;
    std::memcpy(&v, t.data(), sizeof(v));
    return v;
  }
  static vf apply(const vf* s) {
    if constexpr (W == 1) {
      return s[0];
    } else {
      vf r = __builtin_shuffle(s[0], s[1], index(low));
      if constexpr (W == 3) r = __builtin_shuffle(r, s[2], index(merge));
      if constexpr (W == 4)
        r = __builtin_shuffle(r, __builtin_shuffle(s[2], s[3], index(high)), index(merge));
      return r;
    }
  }
};

template <int W, bool kStore, std::size_t... R>
void transpose(const vf* in, vf* out, std::index_sequence<R...>) {
  ((out[R] = Transpose<W, kStore, int(R)>::apply(in)), ...);
}
}  // namespace detail

// columns[k][l] = rows[W * l + k], l < 16.
template <int W>
inline void load_columns(const float* rows, vf (&columns)[W]) {
  vf memory[W];
  std::memcpy(memory, rows, sizeof(memory));
  detail::transpose<W, false>(memory, columns, std::make_index_sequence<W>());
}

// The same for the first `count` rows (1 <= count <= 16); lanes past `count` repeat the last row.
template <int W>
inline void load_columns(const float* rows, int count, vf (&columns)[W]) {
  if (count == kLanes) return load_columns<W>(rows, columns);
  for (vf& column : columns) column = vf{};  // written lane by lane below
  for (int l = 0; l < kLanes; ++l)
    for (int k = 0; k < W; ++k) columns[k][l] = rows[W * (l < count ? l : count - 1) + k];
}
inline vi load_lanes(const std::int32_t* values, int count) {
  vi v{};
  if (count == kLanes) {
    std::memcpy(&v, values, sizeof(v));
  } else {
    for (int l = 0; l < kLanes; ++l) v[l] = values[l < count ? l : count - 1];
  }
  return v;
}

// rows[W * l + k] = columns[k][l], l < 16.
template <int W>
inline void store_columns(float* rows, const vf (&columns)[W]) {
  vf memory[W];
  detail::transpose<W, true>(columns, memory, std::make_index_sequence<W>());
  std::memcpy(rows, memory, sizeof(memory));
}

// Starts loading the cache line at p. An asm statement, because GCC 12 drops __builtin_prefetch
// when the address comes from an indexed load (as in `base + stride * ids[k]`).
inline void prefetch(const void* p) {
#if defined(__x86_64__)
  asm volatile("prefetcht0 %0" : : "m"(*static_cast<const char*>(p)));
#else
  __builtin_prefetch(p);
#endif
}

// Flushes denormal results and operands to zero on this thread while in scope. Far from its
// centre a Gaussian's alpha (and alpha * T) underflows into the denormal range, where x86
// arithmetic takes a microcode assist of ~100 cycles per instruction; values that small are far
// below every threshold of the blend.
class FlushDenormals {
 public:
#if defined(__SSE__)
  static constexpr unsigned kFlushToZero = 0x8000, kDenormalsAreZero = 0x0040;  // MXCSR bits
  FlushDenormals() : saved_(_mm_getcsr()) {
    _mm_setcsr(saved_ | kFlushToZero | kDenormalsAreZero);
  }
  ~FlushDenormals() {
    _mm_setcsr(saved_);
  }
  FlushDenormals(const FlushDenormals&) = delete;
  FlushDenormals& operator=(const FlushDenormals&) = delete;

 private:
  unsigned saved_;
#endif
};

}  // namespace retimegs::render::simd
