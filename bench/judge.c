/*
 * lrr-bench scenes: the accuracy judgement (issue 27, item 5). The operator's radiosity
 * against the path-traced reference on the same subpatches, both in the scene's subpatch
 * order, judged on the reflected light B − E of the subpatches that emit nothing:
 *
 *   regions  material (reflectance and emission rounded to 1/256) × cell of an 8×8×8 grid
 *            over the box of the subpatch centres. Per region r the area-weighted means b_r
 *            (operator) and p_r (reference) and the standard error s_r of p_r,
 *            √(Σ A_i² σ_i²) / A_r per channel (the subpatches' paths are independent);
 *            rel_l2 = √(Σ_r A_r |b_r − p_r|² / Σ_r A_r |p_r|²), noise the same with s_r.
 *   facings  Σ A_i lum(B_i − E_i) of the operator over that of the reference, for normals
 *            up (y > 0.5), side (|y| <= 0.5) and down (y < −0.5).
 *   subpatch the regions' formula with every subpatch its own region.
 *   verify   rel_l2 with the noise taken off, over lrr_operator_verify's regions (its grid
 *            for its number of draws × the axis direction nearest the normal) but every
 *            judged subpatch: when verify's figure and the bench's differ, this tells
 *            whether the regions' size or verify's sampling makes the difference.
 *
 * Why regions and not subpatches or triangles: per subpatch the reference's noise is as
 * large as the error looked for, and a filter keeping only the quiet subpatches or
 * triangles keeps the lamps and what they light directly, which hid a systematic loss of
 * the later bounces. A region averages the noise away (its standard error says how far)
 * while a bias that spans a material or a part of the scene stays. The facings show where
 * a bias sits: light that arrives after several bounces reaches downward faces most.
 * lrr_operator_verify (lib/verify/verify.c) uses the same kind of regions with facings in
 * place of materials and a coarser grid, on a sample of subpatches.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

/* Rec. 709 luminance: one number per subpatch for the facings' ratios. */
static double lum(const float *v)
{
    return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
}

/* Judged: a subpatch with area that emits nothing. A lamp's B is mostly its own E, which
 * both sides know exactly; counting it would dilute the error of the reflected light. */
static int judged(const float *geo)
{
    const float *e = geo + SC_GEO_EMISSION;
    return geo[SC_GEO_AREA] > 0 && !(e[0] > 0 || e[1] > 0 || e[2] > 0);
}

/* ------------------------------------------------------------------ regions */
/* A subpatch's region: its material, rounded to 1/256 (so that float noise in a material's
 * reflectance does not split it), and its grid cell; i last, so that the sort (and with it
 * the order of the sums) does not depend on qsort. No padding: compared with memcmp. */
typedef struct region_key {
    int32_t material[6]; /* ρ and E, RGB, × 256 rounded */
    uint32_t cell;
    uint32_t i;
} region_key;

static int cmp_key(const void *x, const void *y)
{
    return memcmp(x, y, sizeof(region_key));
}

/* The box of all subpatch centres (lamps too: the grid is the scene's, not the judged part's). */
static void centre_box(size_t n, const float *geo, double lo[3], double span[3])
{
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    lo[0] = lo[1] = lo[2] = INFINITY;
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], geo[SC_GEO * i + SC_GEO_CENTRE + a]);
            hi[a] = fmax(hi[a], geo[SC_GEO * i + SC_GEO_CENTRE + a]);
        }
    for (int a = 0; a < 3; a++)
        span[a] = n ? hi[a] - lo[a] : 0;
}

static uint32_t cell_of(const float *c, const double lo[3], const double span[3], long grid)
{
    uint32_t at = 0;
    for (int a = 0; a < 3; a++) {
        double u = span[a] > 0 ? (c[a] - lo[a]) / span[a] : 0;
        long g = (long)floor(u * (double)grid);
        g = g < 0 ? 0 : g >= grid ? grid - 1 : g;
        at = at * (uint32_t)grid + (uint32_t)g;
    }
    return at;
}

/* lrr_operator_verify's facing: the axis direction nearest the normal, 0..5. */
static int32_t axis_facing(const float *nv)
{
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (fabsf(nv[a]) > fabsf(nv[axis]))
            axis = a;
    return 2 * axis + (nv[axis] < 0);
}

/* How regions are cut: material × cell of an SC_GRID³ grid (the judgement), or as
 * lrr_operator_verify cuts them, axis facing × cell of a coarser grid (the diagnostic
 * that tells region size from sampling when the two figures differ). */
typedef struct region_cut {
    long grid;
    int by_facing;
} region_cut;

/* The judged subpatches' keys, sorted so that each region is one run; returns their count. */
static size_t region_keys(size_t n, const float *geo, region_cut cut, region_key *keys)
{
    double lo[3], span[3];
    centre_box(n, geo, lo, span);
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        const float *g = geo + SC_GEO * i;
        if (!judged(g))
            continue;
        region_key *k = &keys[m++];
        memset(k->material, 0, sizeof k->material);
        for (int c = 0; c < 3 && !cut.by_facing; c++) {
            k->material[c] = (int32_t)lround(256.0 * g[SC_GEO_RHO + c]);
            k->material[3 + c] = (int32_t)lround(256.0 * g[SC_GEO_EMISSION + c]);
        }
        if (cut.by_facing)
            k->material[0] = axis_facing(g + SC_GEO_NORMAL);
        k->cell = cell_of(g + SC_GEO_CENTRE, lo, span, cut.grid);
        k->i = (uint32_t)i;
    }
    qsort(keys, m, sizeof *keys, cmp_key);
    return m;
}

/* One region's sums: A, Σ A b, Σ A b16, Σ A p (reflected light, RGB), Σ A² σ² (RGB). */
typedef struct region_sum {
    double area, b[3], b16[3], p[3], var[3];
} region_sum;

/* Sums over regions: Σ A_r |b_r − p_r|², the same for the f16 B, Σ A_r |s_r|² and
 * Σ A_r |p_r|²; the count of non-empty regions. */
typedef struct judge_sums {
    double num, num16, var, den;
    size_t regions;
} judge_sums;

static double dist2(const double *x, const double *y)
{
    double s = 0;
    for (int c = 0; c < 3; c++)
        s += (x[c] - y[c]) * (x[c] - y[c]);
    return s;
}

static void region_close(const region_sum *r, judge_sums *t)
{
    static const double zero[3] = {0, 0, 0};
    if (!(r->area > 0))
        return;
    double b[3], b16[3], p[3], s2 = 0;
    for (int c = 0; c < 3; c++) {
        b[c] = r->b[c] / r->area;
        b16[c] = r->b16[c] / r->area;
        p[c] = r->p[c] / r->area;
        s2 += r->var[c] / (r->area * r->area);
    }
    t->num += r->area * dist2(b, p);
    t->num16 += r->area * dist2(b16, p);
    t->var += r->area * s2;
    t->den += r->area * dist2(p, zero);
    t->regions++;
}

static void region_add(region_sum *r, const sc_judge_input *in, size_t i)
{
    const double a = in->geo[SC_GEO * i + SC_GEO_AREA];
    const float *e = in->geo + SC_GEO * i + SC_GEO_EMISSION;
    r->area += a;
    for (int c = 0; c < 3; c++) {
        r->b[c] += a * ((double)in->b[3 * i + c] - e[c]);
        r->b16[c] += a * ((double)in->b16[3 * i + c] - e[c]);
        r->p[c] += a * ((double)in->p[3 * i + c] - e[c]);
        r->var[c] += a * a * (double)in->se[3 * i + c] * in->se[3 * i + c];
    }
}

static double root_ratio(double num, double den)
{
    return den > 0 ? sqrt(num / den) : NAN;
}

/* The sums over the regions of one cut; *count the subpatches judged. */
static int region_sums(const sc_judge_input *in, region_cut cut, judge_sums *t, size_t *count)
{
    region_key *keys = malloc((in->n ? in->n : 1) * sizeof *keys);
    if (!keys)
        return -1;
    const size_t m = region_keys(in->n, in->geo, cut, keys);
    region_sum r = {0};
    memset(t, 0, sizeof *t);
    for (size_t s = 0; s < m; s++) {
        if (s && memcmp(keys[s].material, keys[s - 1].material, sizeof keys[s].material +
                                                                    sizeof keys[s].cell)) {
            region_close(&r, t);
            memset(&r, 0, sizeof r);
        }
        region_add(&r, in, keys[s].i);
    }
    region_close(&r, t);
    free(keys);
    *count = m;
    return 0;
}

/* E|b_r − p_r|² = |bias_r|² + |s_r|²: the reference's expected noise taken off */
static double debiased(const judge_sums *t)
{
    return root_ratio(fmax(0, t->num - t->var), t->den);
}

/* rel_l2, its debiased form, noise and rel_l2_f16 over regions; rel_l2_verify_grid. */
static int judge_regions(const sc_judge_input *in, sc_judgement *j)
{
    judge_sums t;
    region_cut cut = {SC_GRID, 0};
    if (region_sums(in, cut, &t, &j->subpatches) != 0)
        return -1;
    j->regions = t.regions;
    j->rel_l2 = root_ratio(t.num, t.den);
    j->rel_l2_f16 = root_ratio(t.num16, t.den);
    j->noise = root_ratio(t.var, t.den);
    j->rel_l2_debiased = debiased(&t);
    if (!in->verify_grid)
        return 0;
    size_t m;
    cut = (region_cut){(long)in->verify_grid, 1};
    if (region_sums(in, cut, &t, &m) != 0)
        return -1;
    j->rel_l2_verify_grid = debiased(&t);
    return 0;
}

/* ------------------------------------------------------------------ facings, subpatches */
static int facing_of(const float *normal)
{
    double len = sqrt((double)normal[0] * normal[0] + (double)normal[1] * normal[1] +
                      (double)normal[2] * normal[2]);
    double y = len > 0 ? normal[1] / len : 0;
    return y > 0.5 ? SC_UP : y < -0.5 ? SC_DOWN : SC_SIDE;
}

/* ratio per facing and its noise: the relative standard error of the reference's sum,
 * bounded from above with lum(σ_i) (a luminance's standard error is at most that of its
 * channels weighted, whatever their correlation). */
static void judge_facings(const sc_judge_input *in, sc_judgement *j)
{
    double op[SC_FACINGS] = {0}, ref[SC_FACINGS] = {0}, var[SC_FACINGS] = {0};
    for (size_t i = 0; i < in->n; i++) {
        const float *g = in->geo + SC_GEO * i;
        if (!judged(g))
            continue;
        const int f = facing_of(g + SC_GEO_NORMAL);
        const double a = g[SC_GEO_AREA], e = lum(g + SC_GEO_EMISSION);
        op[f] += a * (lum(in->b + 3 * i) - e);
        ref[f] += a * (lum(in->p + 3 * i) - e);
        var[f] += a * a * lum(in->se + 3 * i) * lum(in->se + 3 * i);
    }
    for (int f = 0; f < SC_FACINGS; f++) {
        j->ratio[f] = ref[f] > 0 ? op[f] / ref[f] : NAN;
        j->ratio_noise[f] = ref[f] > 0 ? sqrt(var[f]) / ref[f] : NAN;
    }
}

/* The regions' formula per subpatch: mostly the reference's noise on a real scene, shown
 * so that the regions' gain is visible. */
static void judge_subpatches(const sc_judge_input *in, sc_judgement *j)
{
    double num = 0, den = 0, var = 0;
    for (size_t i = 0; i < in->n; i++) {
        const float *g = in->geo + SC_GEO * i;
        if (!judged(g))
            continue;
        const double a = g[SC_GEO_AREA];
        for (int c = 0; c < 3; c++) {
            const double e = g[SC_GEO_EMISSION + c], p = in->p[3 * i + c] - e;
            const double d = (double)in->b[3 * i + c] - in->p[3 * i + c], s = in->se[3 * i + c];
            num += a * d * d;
            den += a * p * p;
            var += a * s * s;
        }
    }
    j->rel_l2_subpatch = root_ratio(num, den);
    j->noise_subpatch = root_ratio(var, den);
}

int sc_judge(const sc_judge_input *in, sc_judgement *j)
{
    if (in->n > UINT32_MAX || judge_regions(in, j) != 0)
        return -1;
    judge_facings(in, j);
    judge_subpatches(in, j);
    return 0;
}

void sc_judgement_init(sc_judgement *j)
{
    memset(j, 0, sizeof *j);
    double *v[] = {&j->rel_l2, &j->noise, &j->rel_l2_debiased, &j->rel_l2_f16,
                   &j->rel_l2_subpatch, &j->noise_subpatch, &j->rel_l2_verify_grid};
    for (size_t i = 0; i < sizeof v / sizeof v[0]; i++)
        *v[i] = NAN;
    for (int f = 0; f < SC_FACINGS; f++)
        j->ratio[f] = j->ratio_noise[f] = NAN;
}
