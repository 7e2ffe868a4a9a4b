/* Smooth shading for the viewer: the corners of the subpatch triangles welded where they
 * share a position and a plane (so colour never bleeds around a crease: a wall's corner and
 * the floor's stay apart), each welded corner given the area-weighted mean radiosity of the
 * subpatches that meet there. The GL thread uploads those corner colours instead of B. */
#include "view_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct corner_key {
    float p[3];
    long nq[3];   /* the subpatch's normal, quantised: same plane, same key */
    uint32_t v;   /* which of the 3n corners */
} corner_key;

static int key_cmp(const void *pa, const void *pb)
{
    const corner_key *a = pa, *b = pb;
    for (int j = 0; j < 3; j++) {
        if (a->p[j] != b->p[j])
            return a->p[j] < b->p[j] ? -1 : 1;
        if (a->nq[j] != b->nq[j])
            return a->nq[j] < b->nq[j] ? -1 : 1;
    }
    return 0;
}

/* corner[v] = the welded corner of v; returns the number m of welded corners. */
static size_t weld(corner_key *k, size_t count, uint32_t *corner)
{
    qsort(k, count, sizeof *k, key_cmp);
    size_t m = 0;
    for (size_t i = 0; i < count; i++) {
        if (i > 0 && key_cmp(&k[i - 1], &k[i]) != 0)
            m++;
        corner[k[i].v] = (uint32_t)m;
    }
    return count ? m + 1 : 0;
}

/* The gather lists: corner u takes the subpatches src[first[u] .. first[u+1]-1], weighted
 * by their share w of the area meeting there (so a frame is one pass, no division). */
static int build_lists(view_smooth *s, const uint32_t *corner, const float *area)
{
    s->first = calloc(s->m + 1, sizeof *s->first);
    s->src = malloc(3 * s->n * sizeof *s->src);
    s->w = malloc(3 * s->n * sizeof *s->w);
    double *total = calloc(s->m, sizeof *total);
    if (!s->first || !s->src || !s->w || !total) {
        free(total);
        return -1;
    }
    for (size_t v = 0; v < 3 * s->n; v++) {
        s->first[corner[v] + 1]++;
        total[corner[v]] += area[v / 3];
    }
    for (size_t u = 0; u < s->m; u++)
        s->first[u + 1] += s->first[u];
    for (size_t v = 0; v < 3 * s->n; v++) { /* total[] doubles as the fill cursor's weight */
        uint32_t u = corner[v], at = s->first[u]++;
        s->src[at] = (uint32_t)(v / 3);
        s->w[at] = total[u] > 0 ? (float)(area[v / 3] / total[u]) : 1.0f / 3;
    }
    for (size_t u = s->m; u > 0; u--) /* the fill advanced every first[u] to first[u+1] */
        s->first[u] = s->first[u - 1];
    s->first[0] = 0;
    free(total);
    return 0;
}

int view_smooth_init(view_smooth *s, const float *vtx, const float *normal, const float *area,
                     size_t n)
{
    memset(s, 0, sizeof *s);
    s->n = n;
    corner_key *k = malloc(3 * n * sizeof *k);
    s->corner = malloc(3 * n * sizeof *s->corner);
    if (!k || !s->corner || 3 * n > UINT32_MAX) {
        free(k);
        view_smooth_free(s);
        fprintf(stderr, "lrr view: out of memory for smooth shading (%zu triangles)\n", n);
        return -1;
    }
    for (size_t v = 0; v < 3 * n; v++) {
        memcpy(k[v].p, vtx + 3 * v, sizeof k[v].p);
        for (int j = 0; j < 3; j++)
            k[v].nq[j] = lrintf(normal[3 * (v / 3) + j] * 1000.0f);
        k[v].v = (uint32_t)v;
    }
    s->m = weld(k, 3 * n, s->corner);
    free(k);
    s->out = malloc(s->m * 3 * sizeof *s->out);
    if (!s->out || build_lists(s, s->corner, area) != 0) {
        view_smooth_free(s);
        fprintf(stderr, "lrr view: out of memory for smooth shading (%zu corners)\n", s->m);
        return -1;
    }
    return 0;
}

const float *view_smooth_apply(view_smooth *s, const float *b)
{
    for (size_t u = 0; u < s->m; u++) {
        float acc[3] = {0, 0, 0};
        for (uint32_t k = s->first[u]; k < s->first[u + 1]; k++)
            for (int c = 0; c < 3; c++)
                acc[c] += s->w[k] * b[3 * s->src[k] + c];
        memcpy(s->out + 3 * u, acc, sizeof acc);
    }
    return s->out;
}

void view_smooth_free(view_smooth *s)
{
    free(s->corner);
    free(s->first);
    free(s->src);
    free(s->w);
    free(s->out);
    memset(s, 0, sizeof *s);
}
