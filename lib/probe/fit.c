/* Fits to a light probe: median cut into directional lights, and the order-2 spherical
 * harmonics projection with its irradiance. */
#include "config.h"
#include "probe/probe.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* A rectangle of pixels [u0, u1) × [v0, v1); empty when u0 == u1. */
typedef struct region {
    size_t u0, u1, v0, v1;
    double energy;
} region;

static double region_energy(const lrr_probe *p, const region *r)
{
    double e = 0;
    for (size_t v = r->v0; v < r->v1; v++)
        for (size_t u = r->u0; u < r->u1; u++)
            e += p->energy[v * p->w + u];
    return e;
}

static int splittable(const region *r) { return (r->u1 - r->u0) * (r->v1 - r->v0) > 1; }

/* Splits r into r (first part) and *second, across its longer side at the cut that makes the
 * two energies closest. marg is scratch of max(w, h) doubles. An unsplittable region gives an
 * empty second region. */
static void split_region(const lrr_probe *p, region *r, region *second, double *marg)
{
    *second = *r;
    if (!splittable(r)) {
        second->u1 = second->u0;
        second->energy = 0;
        return;
    }
    size_t w = r->u1 - r->u0, h = r->v1 - r->v0;
    double theta = PI * 0.5 * (double)(r->v0 + r->v1) / (double)p->h;
    double wlen = (double)w * (2 * PI / (double)p->w) * sin(theta);
    double hlen = (double)h * (PI / (double)p->h);
    int across_u = h == 1 || (w > 1 && wlen > hlen); /* cut between columns */
    size_t len = across_u ? w : h;
    memset(marg, 0, len * sizeof *marg);
    for (size_t v = r->v0; v < r->v1; v++)
        for (size_t u = r->u0; u < r->u1; u++)
            marg[across_u ? u - r->u0 : v - r->v0] += p->energy[v * p->w + u];
    double total = 0;
    for (size_t k = 0; k < len; k++)
        total += marg[k];
    double prefix = 0, best = INFINITY, best_prefix = 0;
    size_t cut = 1;
    for (size_t k = 1; k < len; k++) {
        prefix += marg[k - 1];
        double d = fabs(prefix - (total - prefix));
        if (d < best) {
            best = d;
            cut = k;
            best_prefix = prefix;
        }
    }
    if (across_u) {
        r->u1 = r->u0 + cut;
        second->u0 = r->u1;
    } else {
        r->v1 = r->v0 + cut;
        second->v0 = r->v1;
    }
    r->energy = best_prefix;
    second->energy = total - best_prefix;
}

static void region_light(const lrr_probe *p, const region *r, lrr_light *L)
{
    size_t n = p->w * p->h;
    double e = 0, eu = 0, ev = 0, rgb[3] = {0, 0, 0};
    for (size_t v = r->v0; v < r->v1; v++)
        for (size_t u = r->u0; u < r->u1; u++) {
            size_t i = v * p->w + u;
            double ei = p->energy[i];
            e += ei;
            eu += ei * ((double)u + 0.5);
            ev += ei * ((double)v + 0.5);
            for (int c = 0; c < 3; c++)
                rgb[c] += p->q[c * n + i];
        }
    double uc, vc;
    if (e > 0) {
        uc = eu / e;
        vc = ev / e;
    } else {
        uc = 0.5 * (double)(r->u0 + r->u1);
        vc = 0.5 * (double)(r->v0 + r->v1);
    }
    double theta = PI * vc / (double)p->h, phi = 2 * PI * uc / (double)p->w;
    L->dir[0] = (float)(sin(theta) * cos(phi));
    L->dir[1] = (float)cos(theta);
    L->dir[2] = (float)(sin(theta) * sin(phi));
    for (int c = 0; c < 3; c++)
        L->rgb[c] = (float)rgb[c];
}

lrr_status lrr_probe_median_cut(const lrr_probe *probe, size_t count, lrr_light *out)
{
    lrr_context *ctx = probe->ctx;
    size_t n = probe->w * probe->h;
    if (count == 0 || count > n)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "median cut: %zu lights for a %zu×%zu probe (1 to %zu)", count,
                          probe->w, probe->h, n);
    region *reg;
    double *marg;
    lrr_status st = lrr__calloc(ctx, &reg, count, sizeof *reg, "median cut regions");
    if (st != LRR_OK)
        return st;
    st = lrr__calloc(ctx, &marg, probe->w, sizeof *marg, "median cut scratch");
    if (st != LRR_OK) {
        lrr_aligned_free(reg);
        return st;
    }
    reg[0] = (region){0, probe->w, 0, probe->h, 0};
    reg[0].energy = region_energy(probe, &reg[0]);
    size_t have = 1;
    if ((count & (count - 1)) == 0) {
        /* classic: every region split in each pass */
        while (have < count) {
            for (size_t r = 0; r < have; r++)
                split_region(probe, &reg[r], &reg[have + r], marg);
            have *= 2;
        }
    } else {
        /* adaptive: split the region with the most energy */
        while (have < count) {
            size_t best = SIZE_MAX;
            for (size_t r = 0; r < have; r++)
                if (splittable(&reg[r]) && (best == SIZE_MAX || reg[r].energy > reg[best].energy))
                    best = r;
            if (best == SIZE_MAX)
                best = 0; /* cannot happen for count <= W·H; gives an empty region */
            split_region(probe, &reg[best], &reg[have], marg);
            have++;
        }
    }
    for (size_t r = 0; r < count; r++)
        region_light(probe, &reg[r], &out[r]);
    lrr_aligned_free(marg);
    lrr_aligned_free(reg);
    return LRR_OK;
}

/* The nine real SH basis functions at unit direction (x, y, z). */
static void sh9_basis(double x, double y, double z, double Y[9])
{
    Y[0] = 0.282094791773878;
    Y[1] = 0.488602511902920 * y;
    Y[2] = 0.488602511902920 * z;
    Y[3] = 0.488602511902920 * x;
    Y[4] = 1.092548430592079 * x * y;
    Y[5] = 1.092548430592079 * y * z;
    Y[6] = 0.315391565252520 * (3 * z * z - 1);
    Y[7] = 1.092548430592079 * x * z;
    Y[8] = 0.546274215296040 * (x * x - y * y);
}

lrr_status lrr_probe_sh9(const lrr_probe *probe, float coeffs[27])
{
    size_t n = probe->w * probe->h;
    double acc[27] = {0};
    for (size_t i = 0; i < n; i++) {
        double Y[9];
        sh9_basis(probe->dir[i], probe->dir[n + i], probe->dir[2 * n + i], Y);
        double q[3] = {probe->q[i], probe->q[n + i], probe->q[2 * n + i]};
        for (int k = 0; k < 9; k++)
            for (int c = 0; c < 3; c++)
                acc[3 * k + c] += Y[k] * q[c];
    }
    /* Finite radiances near FLT_MAX can sum beyond float's range: report it rather than
     * return infinite coefficients (which lrr_sh9_irradiance would then refuse). */
    for (int k = 0; k < 27; k++)
        if (!(fabs(acc[k]) <= FLT_MAX))
            return lrr__error(probe->ctx, LRR_ERR_INVALID_ARG,
                              "probe SH9: coefficient %d of channel %d is %g, beyond float's "
                              "range (radiances too large)",
                              k / 3, k % 3, acc[k]);
    for (int k = 0; k < 27; k++)
        coeffs[k] = (float)acc[k];
    return LRR_OK;
}

lrr_status lrr_sh9_irradiance(const float coeffs[27], size_t m, const float *normals,
                              float *out)
{
    static const double band[9] = {PI,          2 * PI / 3, 2 * PI / 3, 2 * PI / 3, PI / 4,
                                   PI / 4,      PI / 4,     PI / 4,     PI / 4};
    for (int k = 0; k < 27; k++)
        if (!isfinite(coeffs[k]))
            return LRR_ERR_INVALID_ARG;
    for (size_t i = 0; i < m; i++) {
        double x = normals[3 * i], y = normals[3 * i + 1], z = normals[3 * i + 2];
        double len = sqrt(x * x + y * y + z * z);
        if (!isfinite(len) || len == 0)
            return LRR_ERR_INVALID_ARG;
        double Y[9], e[3] = {0, 0, 0};
        sh9_basis(x / len, y / len, z / len, Y);
        for (int k = 0; k < 9; k++)
            for (int c = 0; c < 3; c++)
                e[c] += band[k] * coeffs[3 * k + c] * Y[k];
        for (int c = 0; c < 3; c++)
            out[3 * i + c] = (float)e[c];
    }
    return LRR_OK;
}
