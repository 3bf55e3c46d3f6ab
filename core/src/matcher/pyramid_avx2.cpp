// The pyramid's one input kernel with AVX2 intrinsics (this file only is built
// with -mavx2; pyramid.cpp calls it where the patch kernels are AVX2 ones).
// The compiler's own vectorisation of the interleaved BGR loop takes twice the
// time of this byte shuffle: its reads of three bytes a pixel become long
// chains of permutes. No library headers here: an inline function compiled
// with AVX2 in this file could be the copy the linker keeps for every caller.
#include <immintrin.h>

namespace bdis {
namespace detail {

using uchar = unsigned char;
void lumaOfBgrRowPortable(const uchar* bgr, int w, int saturated, uchar* grey, uchar* valid);

namespace {

/// 16 bytes from `lo` in the lower 128-bit lane, 16 from `hi` in the upper.
inline __m256i loadTwoLanes(const uchar* lo, const uchar* hi) {
  return _mm256_inserti128_si256(_mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(lo))),
                                 _mm_loadu_si128(reinterpret_cast<const __m128i*>(hi)), 1);
}

/// The same 16-byte shuffle in both lanes; -1 gives a zero byte.
inline __m256i laneShuffle(char a0, char a1, char a2, char a3, char a4, char a5, char a6, char a7, char a8,
                           char a9, char a10, char a11, char a12, char a13, char a14, char a15) {
  return _mm256_setr_epi8(a0, a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, a11, a12, a13, a14, a15, a0, a1, a2,
                          a3, a4, a5, a6, a7, a8, a9, a10, a11, a12, a13, a14, a15);
}

/// The luma of 16 pixels, given their (b, r) byte pairs and their green
/// words: 29 b + 150 g + 77 r + 128, shifted down by 8. The sum is at most
/// 65408, so unsigned 16-bit words hold it; b and r times their weights (at
/// most 27030) do not saturate the signed multiply-add.
inline __m256i lumaWords(__m256i blue_red, __m256i green) {
  const __m256i weights_br = _mm256_set1_epi16(static_cast<short>(29 | (77 << 8)));
  const __m256i sum = _mm256_add_epi16(_mm256_maddubs_epi16(blue_red, weights_br),
                                       _mm256_mullo_epi16(green, _mm256_set1_epi16(150)));
  return _mm256_srli_epi16(_mm256_add_epi16(sum, _mm256_set1_epi16(128)), 8);
}

/// All ones where a pixel is not black (its (b, r) word or its green word is
/// not 0) and its luma is below `saturated_at`.
inline __m256i validWords(__m256i blue_red, __m256i green, __m256i luma, __m256i saturated_at) {
  const __m256i black = _mm256_cmpeq_epi16(_mm256_or_si256(blue_red, green), _mm256_setzero_si256());
  return _mm256_andnot_si256(black, _mm256_cmpgt_epi16(saturated_at, luma));
}

}  // namespace

void lumaOfBgrRowAvx2(const uchar* __restrict bgr, int w, int saturated, uchar* __restrict grey,
                      uchar* __restrict valid) {
  // Each lane holds 16 pixels, 48 bytes read as three vectors a, b, c. The
  // blue and red bytes of pixels 0-7 (8-15) go into byte pairs (b, r) for
  // one multiply-add; green into 16-bit words.
  const __m256i br_lo_from_a = laneShuffle(0, 2, 3, 5, 6, 8, 9, 11, 12, 14, 15, -1, -1, -1, -1, -1);
  const __m256i br_lo_from_b = laneShuffle(-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 1, 2, 4, 5, 7);
  const __m256i br_hi_from_b = laneShuffle(8, 10, 11, 13, 14, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
  const __m256i br_hi_from_c = laneShuffle(-1, -1, -1, -1, -1, 0, 1, 3, 4, 6, 7, 9, 10, 12, 13, 15);
  const __m256i g_lo_from_a = laneShuffle(1, -1, 4, -1, 7, -1, 10, -1, 13, -1, -1, -1, -1, -1, -1, -1);
  const __m256i g_lo_from_b = laneShuffle(-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, -1, 3, -1, 6, -1);
  const __m256i g_hi_from_b = laneShuffle(9, -1, 12, -1, 15, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
  const __m256i g_hi_from_c = laneShuffle(-1, -1, -1, -1, -1, -1, 2, -1, 5, -1, 8, -1, 11, -1, 14, -1);
  // Grey levels are 0-255: any threshold outside -1..256 acts as its end.
  const int threshold = saturated < -1 ? -1 : (saturated > 256 ? 256 : saturated);
  const __m256i saturated_at = _mm256_set1_epi16(static_cast<short>(threshold));
  const __m256i one = _mm256_set1_epi8(1);
  int x = 0;
  for (; x + 32 <= w; x += 32) {
    const uchar* p = bgr + 3 * x;
    const __m256i a = loadTwoLanes(p, p + 48);
    const __m256i b = loadTwoLanes(p + 16, p + 64);
    const __m256i c = loadTwoLanes(p + 32, p + 80);
    const __m256i br_lo = _mm256_or_si256(_mm256_shuffle_epi8(a, br_lo_from_a), _mm256_shuffle_epi8(b, br_lo_from_b));
    const __m256i br_hi = _mm256_or_si256(_mm256_shuffle_epi8(b, br_hi_from_b), _mm256_shuffle_epi8(c, br_hi_from_c));
    const __m256i g_lo = _mm256_or_si256(_mm256_shuffle_epi8(a, g_lo_from_a), _mm256_shuffle_epi8(b, g_lo_from_b));
    const __m256i g_hi = _mm256_or_si256(_mm256_shuffle_epi8(b, g_hi_from_b), _mm256_shuffle_epi8(c, g_hi_from_c));
    const __m256i luma_lo = lumaWords(br_lo, g_lo);
    const __m256i luma_hi = lumaWords(br_hi, g_hi);
    // Per lane the packs interleave lo and hi in pixel order, and the lanes
    // are pixels 0-15 and 16-31: the bytes come out in order.
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(grey + x), _mm256_packus_epi16(luma_lo, luma_hi));
    const __m256i valid_lo = validWords(br_lo, g_lo, luma_lo, saturated_at);
    const __m256i valid_hi = validWords(br_hi, g_hi, luma_hi, saturated_at);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(valid + x),
                        _mm256_and_si256(_mm256_packs_epi16(valid_lo, valid_hi), one));
  }
  lumaOfBgrRowPortable(bgr + 3 * x, w - x, saturated, grey + x, valid + x);
}

}  // namespace detail
}  // namespace bdis
