/* Reduced-precision storage of F̄ (IEEE binary16 and bfloat16) and its conversions.
 *
 * F̄'s entries are form factors divided by d: in [0, 1], often far below binary16's smallest
 * normal number (2^-14 ≈ 6.1e-5; F̄ entries of 1e-7 are common at d = 1024). Each row i is
 * therefore stored divided by a power of two s_i chosen so that the row's largest entry
 * lands in [2^14, 2^15): entries down to 2^-29 of the row maximum stay normal, scaling is
 * exact, and the kernels fold s_i into the dot product (one multiply per row and channel).
 * bfloat16 has float's exponent range and needs no scale (s_i = 1).
 *
 * Conversions round to nearest, ties to even, in portable C; they run once per operator.
 * The kernels decode with F16C/AVX-512 instructions (realtime_avx2.c, realtime_avx512.c).
 */
#include "config.h"
#include "operator/operator.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint32_t bits_of(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

static float float_of(uint32_t u)
{
    float f;
    memcpy(&f, &u, 4);
    return f;
}

uint16_t lrr__f32_to_f16(float f)
{
    uint32_t u = bits_of(f);
    uint16_t sign = (uint16_t)((u >> 16) & 0x8000u);
    uint32_t a = u & 0x7fffffffu;
    if (a >= 0x7f800000u) /* Inf or NaN (NaN keeps a quiet payload bit) */
        return (uint16_t)(sign | 0x7c00u | (a > 0x7f800000u ? 0x200u : 0));
    if (a >= 0x477ff000u) /* rounds to >= 65520: overflow to Inf */
        return (uint16_t)(sign | 0x7c00u);
    if (a < 0x38800000u) { /* below 2^-14: subnormal or zero in binary16 */
        if (a < 0x33000000u) /* below half the smallest subnormal 2^-25: zero */
            return sign;
        uint32_t mant = (a & 0x7fffffu) | 0x800000u;
        int shift = 126 - (int)(a >> 23); /* 14..24 */
        uint32_t half = mant >> shift, rest = mant & ((1u << shift) - 1), mid = 1u << (shift - 1);
        if (rest > mid || (rest == mid && (half & 1u)))
            half++;
        return (uint16_t)(sign | half);
    }
    /* normal: rebias the exponent (127 → 15) and round 23 → 10 mantissa bits */
    uint32_t h = ((a >> 13) - ((127u - 15u) << 10));
    uint32_t rest = a & 0x1fffu;
    if (rest > 0x1000u || (rest == 0x1000u && (h & 1u)))
        h++; /* a carry into the exponent is still the right answer */
    return (uint16_t)(sign | h);
}

float lrr__f16_to_f32(uint16_t h)
{
    uint32_t sign = (uint32_t)(h & 0x8000u) << 16;
    uint32_t e = (h >> 10) & 0x1fu, m = h & 0x3ffu;
    if (e == 0x1f)
        return float_of(sign | 0x7f800000u | (m << 13));
    if (e == 0) { /* zero or subnormal: m · 2^-24 exactly */
        float v = ldexpf((float)m, -24);
        return sign ? -v : v;
    }
    return float_of(sign | ((e + 127u - 15u) << 23) | (m << 13));
}

uint16_t lrr__f32_to_bf16(float f)
{
    uint32_t u = bits_of(f);
    if ((u & 0x7fffffffu) > 0x7f800000u) /* NaN: keep it a NaN */
        return (uint16_t)((u >> 16) | 0x40u);
    uint32_t rest = u & 0xffffu, b = u >> 16;
    if (rest > 0x8000u || (rest == 0x8000u && (b & 1u)))
        b++;
    return (uint16_t)b;
}

float lrr__bf16_to_f32(uint16_t b)
{
    return float_of((uint32_t)b << 16);
}

static const char *const storage_names[] = {"f32", "f16", "bf16"};

const char *lrr_storage_name(lrr_storage s)
{
    return (unsigned)s < 3 ? storage_names[s] : NULL;
}

lrr_status lrr_storage_from_name(const char *name, lrr_storage *out)
{
    for (int i = 0; i < 3; i++)
        if (strcmp(name, storage_names[i]) == 0) {
            *out = (lrr_storage)i;
            return LRR_OK;
        }
    return LRR_ERR_INVALID_ARG;
}

/* lrr_fbar_format: how a solver reads F̄ (solve/cpu.c, solve/sparse.c) */
static const char *const fbar_names[] = {"auto", "dense", "sparse"};

const char *lrr_fbar_format_name(lrr_fbar_format f)
{
    return (unsigned)f < 3 ? fbar_names[f] : NULL;
}

lrr_status lrr_fbar_format_from_name(const char *name, lrr_fbar_format *out)
{
    for (int i = 0; i < 3; i++)
        if (strcmp(name, fbar_names[i]) == 0) {
            *out = (lrr_fbar_format)i;
            return LRR_OK;
        }
    return LRR_ERR_INVALID_ARG;
}

float lrr__f16_scale(float max_abs)
{
    if (!(max_abs > 0))
        return 1.0f;
    int e;
    frexpf(max_abs, &e); /* max_abs = f·2^e, f in [0.5, 1) */
    /* at least FLT_MIN: below 2^-111 the power of two would be subnormal or 0, and a row of
     * such values (a loaded M of 2.5e-42, found by the fuzzer) divided by it gave NaN; a
     * normal scale codes them as binary16 subnormals or 0, an error below 2^-151 */
    return ldexpf(1.0f, e - 15 < FLT_MIN_EXP - 1 ? FLT_MIN_EXP - 1 : e - 15);
}

static float f16_row_scale(const float *row, size_t k)
{
    float mx = 0;
    for (size_t q = 0; q < k; q++)
        mx = fmaxf(mx, row[q]);
    return lrr__f16_scale(mx);
}

float lrr__fbar_encode_row(lrr_storage storage, const float *row, size_t k, uint16_t *out)
{
    float s = storage == LRR_STORAGE_F16 ? f16_row_scale(row, k) : 1.0f;
    for (size_t q = 0; q < k; q++)
        out[q] = storage == LRR_STORAGE_F16 ? lrr__f32_to_f16(row[q] / s)
                                            : lrr__f32_to_bf16(row[q]);
    return s;
}

void lrr__fbar_decode_row(lrr_storage storage, float scale, const uint16_t *codes, size_t k,
                          float *out)
{
    for (size_t q = 0; q < k; q++)
        out[q] = scale * (storage == LRR_STORAGE_F16 ? lrr__f16_to_f32(codes[q])
                                                     : lrr__bf16_to_f32(codes[q]));
}

void lrr_operator_fbar_row(const lrr_operator *op, size_t i, float *out)
{
    const size_t k = op->k;
    if (!lrr__fbar_data(op)) { /* lrr_operator_load_head: no F̄ to decode (lrr.h) */
        memset(out, 0, k * sizeof(float));
        return;
    }
    if (op->storage == LRR_STORAGE_F32) {
        lrr__fbar_copy_rows(op, i, i + 1, out);
        return;
    }
    const float s = op->row_scale[i];
    for (size_t q = 0; q < k; q++) {
        uint16_t h = op->fbar16[lrr__fbar_index(op, i, q)];
        out[q] = s * (op->storage == LRR_STORAGE_F16 ? lrr__f16_to_f32(h) : lrr__bf16_to_f32(h));
    }
}

lrr_status lrr__fbar_convert(lrr_operator *op, lrr_storage storage)
{
    lrr_context *ctx = op->ctx;
    const size_t n = op->n, k = op->k;
    float *f32 = NULL, *scale = NULL;
    uint16_t *f16 = NULL;
    lrr_status st;
    if (storage == LRR_STORAGE_F32) {
        if ((st = lrr__calloc(ctx, &f32, n, k * sizeof(float), "F̄ (n×k floats)")))
            return st;
        #pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++)
            lrr_operator_fbar_row(op, i, f32 + i * k);
    } else {
        if ((st = lrr__calloc(ctx, &f16, n, k * sizeof(uint16_t), "F̄ (n×k 16-bit)")) ||
            (st = lrr__calloc(ctx, &scale, n, sizeof(float), "F̄ row scales"))) {
            lrr_aligned_free(f16);
            return st;
        }
        float *tmp = NULL;
        if (op->storage != LRR_STORAGE_F32 &&
            (st = lrr__calloc(ctx, &tmp, n, k * sizeof(float), "F̄ (n×k floats)"))) {
            lrr_aligned_free(f16);
            lrr_aligned_free(scale);
            return st;
        }
        if (tmp) {
            #pragma omp parallel for schedule(static)
            for (size_t i = 0; i < n; i++)
                lrr_operator_fbar_row(op, i, tmp + i * k);
        }
        if (!tmp && op->panels) /* float source in panels: rows of it, in place */
            st = lrr__fbar_set_panels(op, 0);
        if (st) {
            lrr_aligned_free(f16);
            lrr_aligned_free(scale);
            return st;
        }
        const float *src = tmp ? tmp : op->fbar;
        #pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++)
            scale[i] = lrr__fbar_encode_row(storage, src + i * k, k, f16 + i * k);
        lrr_aligned_free(tmp);
    }
    lrr_aligned_free(op->fbar);
    lrr_aligned_free(op->fbar16);
    lrr_aligned_free(op->row_scale);
    op->fbar = f32;
    op->fbar16 = f16;
    op->row_scale = scale;
    op->storage = storage;
    op->panels = 0; /* the new arrays were written as rows */
    return LRR_OK;
}
