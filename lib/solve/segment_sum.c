/* w = Vᵀ E over one patch's subpatches, with E's validation folded in (the real-time step's
 * first product; solve/cpu.c calls it per patch). */
#include "config.h"
#include "solve/solve.h"

#include <math.h>
#include <string.h>

/* Four subpatches' 12 entries as three 4-float vectors (r0 g0 b0 r1 | g1 b1 r2 g2 |
 * b2 r3 g3 b3): baseline SSE2 through GCC's vector extensions, unaligned (E + 3·i). */
typedef float lrr__v4f __attribute__((vector_size(16), aligned(4)));
typedef int32_t lrr__v4i __attribute__((vector_size(16), aligned(4)));
typedef double lrr__v2d __attribute__((vector_size(16)));
#define WIDEN(v, a, b) __builtin_convertvector(__builtin_shufflevector(v, v, a, b), lrr__v2d)

/* Σ_i weight_i·E_i over subpatches i0..i1−1 per channel into acc (products in float, as
 * ever, sums in double); returns 0 when an entry may be negative, NaN or infinite (a sign
 * bit is set, -0 included, or a sum is not finite), for the caller's scan. Four subpatches
 * a step in six double pairs, whose lanes hold fixed channels. The scalar loop before it
 * (two subpatches in flight, the check a chain of minss per entry) was 13.6% of a
 * 221184 × 216 f16 frame (perf, Intel Xeon). lrr solve, old and new library interleaved,
 * medians of 300 (3 rounds): 2.16-2.21 → 1.955 ms; 3456 × 216 f32, medians of 20000:
 * 0.034-0.035 → 0.031-0.032 ms; `lrr solve --csv` identical on both and on 55296 × 864. */
int lrr__segment_sum(const float *weight, const float *E, size_t i0, size_t i1,
                              double acc[3])
{
    lrr__v2d s[6] = {{0, 0}, {0, 0}, {0, 0}, {0, 0}, {0, 0}, {0, 0}};
    lrr__v4i sign = {0, 0, 0, 0};
    size_t i = i0;
    for (; i + 4 <= i1; i += 4) {
        const lrr__v4f *e = (const lrr__v4f *)(const void *)(E + 3 * i);
        const lrr__v4f w = *(const lrr__v4f *)(const void *)(weight + i);
        const lrr__v4f a = e[0], b = e[1], c = e[2];
        sign |= (lrr__v4i)a | (lrr__v4i)b | (lrr__v4i)c;
        const lrr__v4f pa = a * __builtin_shufflevector(w, w, 0, 0, 0, 1),
                       pb = b * __builtin_shufflevector(w, w, 1, 1, 2, 2),
                       pc = c * __builtin_shufflevector(w, w, 2, 3, 3, 3);
        s[0] += WIDEN(pa, 0, 1), s[1] += WIDEN(pa, 2, 3); /* r g, b r */
        s[2] += WIDEN(pb, 0, 1), s[3] += WIDEN(pb, 2, 3); /* g b, r g */
        s[4] += WIDEN(pc, 0, 1), s[5] += WIDEN(pc, 2, 3); /* b r, g b */
    }
    double r = (s[0][0] + s[3][0]) + (s[1][1] + s[4][1]);
    double g = (s[0][1] + s[3][1]) + (s[2][0] + s[5][0]);
    double b = (s[1][0] + s[4][0]) + (s[2][1] + s[5][1]);
    int32_t neg = sign[0] | sign[1] | sign[2] | sign[3];
    for (; i < i1; i++) {
        const float w0 = weight[i], *e = E + 3 * i;
        r += w0 * e[0], g += w0 * e[1], b += w0 * e[2];
        for (int j = 0; j < 3; j++) {
            int32_t bits;
            memcpy(&bits, e + j, sizeof bits);
            neg |= bits;
        }
    }
    acc[0] = r, acc[1] = g, acc[2] = b;
    return neg >= 0 && isfinite(r) && isfinite(g) && isfinite(b);
}
#undef WIDEN
