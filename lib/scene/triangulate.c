/* Polygon triangulation for the scene importer (import.c): ear clipping in the polygon's
 * own orientation, so one-sided faces keep their front (see import.c's top comment). */
#include "config.h"
#include "scene/scene.h"

#include <math.h>
#include <stdbool.h>
#include <stddef.h>

/* Ear clipping is cubic in the polygon size; larger polygons are fanned (correct for convex
 * ones, which is what huge polygons in practice are) so a hostile file cannot stall us. */
#define MAX_EAR_CLIP 256

static double cross2(const double *a, const double *b, const double *c, int u, int v)
{
    return (b[u] - a[u]) * (c[v] - a[v]) - (b[v] - a[v]) * (c[u] - a[u]);
}

/* Splits polygon p (n >= 3 points) into n-2 triangles tri[3t..3t+2] (indices into p) with the
 * polygon's own orientation: ear clipping in the plane of its Newell normal. Degenerate,
 * non-planar or self-intersecting polygons fall back to a fan over what is left (their
 * triangles may then be zero-area, which the scene counts and skips). */
void lrr__triangulate(size_t n, const double *p, unsigned *idx, unsigned *tri)
{
    double nrm[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++) {
        const double *a = p + 3 * i, *b = p + 3 * ((i + 1) % n);
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    int k = fabs(nrm[0]) >= fabs(nrm[1]) ? 0 : 1;
    if (fabs(nrm[2]) > fabs(nrm[k]))
        k = 2;
    int u = (k + 1) % 3, v = (k + 2) % 3; /* (u, v, k) is right-handed */
    double sign = nrm[k] >= 0 ? 1.0 : -1.0;
    for (size_t i = 0; i < n; i++)
        idx[i] = (unsigned)i;
    size_t m = n, out = 0;
    bool clip = n <= MAX_EAR_CLIP && isfinite(nrm[0] + nrm[1] + nrm[2]);
    while (m > 3 && clip) {
        bool found = false;
        for (size_t i = 0; i < m && !found; i++) {
            unsigned ia = idx[(i + m - 1) % m], ib = idx[i], ic = idx[(i + 1) % m];
            const double *a = p + 3 * ia, *b = p + 3 * ib, *c = p + 3 * ic;
            if (sign * cross2(a, b, c, u, v) <= 0)
                continue; /* reflex or flat corner */
            bool empty = true;
            for (size_t j = 0; j < m && empty; j++) {
                unsigned q = idx[j];
                if (q == ia || q == ib || q == ic)
                    continue;
                const double *x = p + 3 * q;
                if (sign * cross2(a, b, x, u, v) >= 0 && sign * cross2(b, c, x, u, v) >= 0 &&
                    sign * cross2(c, a, x, u, v) >= 0)
                    empty = false;
            }
            if (!empty)
                continue;
            tri[3 * out] = ia;
            tri[3 * out + 1] = ib;
            tri[3 * out + 2] = ic;
            out++;
            memmove(idx + i, idx + i + 1, (m - i - 1) * sizeof *idx);
            m--;
            found = true;
        }
        clip = found;
    }
    for (size_t i = 1; i + 1 < m; i++) {
        tri[3 * out] = idx[0];
        tri[3 * out + 1] = idx[i];
        tri[3 * out + 2] = idx[i + 1];
        out++;
    }
}
