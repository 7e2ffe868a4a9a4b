/* The scene doctor (lrr_scene_check): exact predicates from CGAL (Epick: predicates exact on
 * the float coordinates, constructions only where noted). Only the extern "C" functions are
 * visible to the C side; no exception escapes.
 *
 * Pairs come from CGAL::box_intersection_d on the triangles' bounding boxes; for each pair:
 *   coplanar (all three of b on a's plane): interiors overlap when an edge of one properly
 *     crosses an edge of the other, a vertex or the centroid (an approximate construction) of
 *     one lies strictly inside the other, or both have the same three vertices. Same facing:
 *     z-fighting (error); opposite facing: contact (warning: a block standing on a floor).
 *   otherwise: counted as intersecting only when each crosses the other's plane strictly (so
 *     a wall standing on a floor, touching it, is not) and they meet: sharing no vertex, by
 *     CGAL::do_intersect; sharing one vertex, when the edge opposite it in one triangle meets
 *     the other triangle; sharing an edge, never. */
#include "config.h"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <map>
#include <new>
#include <utility>
#include <vector>

#include <sys/stat.h>

#ifdef LRR_HAVE_CGAL
/* CGAL's interval filters need directed rounding, and CGAL tests for it in a static
 * initialiser that throws (so terminates the process) when it fails: loading liblrr would
 * then abort every program that links it, whether it checks scenes or not (it does under
 * valgrind, which computes every SSE operation rounded to nearest). A library must not
 * abort: the same test runs in lrr_scene_check instead (rounding_works below), which then
 * returns LRR_ERR_UNSUPPORTED. */
#define CGAL_DISABLE_ROUNDING_MATH_CHECK 1
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>
#endif

#include <embree3/rtcore.h> /* C++ headers (templates): outside extern "C" */
extern "C" {
#include "scene/bvh.h"
#include "scene/scene.h"
}

#ifdef LRR_HAVE_CGAL
namespace {

typedef CGAL::Exact_predicates_inexact_constructions_kernel K;
typedef K::Point_3 P3;
typedef K::Point_2 P2;
typedef K::Triangle_3 T3;
typedef K::Segment_3 S3;
typedef CGAL::Box_intersection_d::Box_with_handle_d<double, 3, std::size_t,
                                                     CGAL::Box_intersection_d::ID_EXPLICIT>
    Box;
typedef std::array<float, 3> Key;

struct Checker {
    std::size_t n;
    const float *v;
    std::vector<P3> p; /* 3 per triangle */
    std::vector<char> degen;
    std::vector<lrr_check_finding> found;
    lrr_check_report *r;
    std::vector<std::vector<std::size_t>> sheets; /* open components, for upside_down() */
    lrr_context *ctx;
    lrr_status st; /* an Embree failure of upside_down() */

    Key key(std::size_t t, int i) const
    {
        return Key{{v[9 * t + 3 * i], v[9 * t + 3 * i + 1], v[9 * t + 3 * i + 2]}};
    }
    void add(lrr_check_kind k, std::size_t a, std::size_t b)
    {
        found.push_back(lrr_check_finding{k, r->face[a], r->face[b]});
    }

    /* 2D projection along the dominant axis of a's normal (signs preserved for coplanar
     * points up to a common factor). */
    static P2 proj(const P3 &q, int drop)
    {
        return drop == 0 ? P2(q.y(), q.z()) : drop == 1 ? P2(q.z(), q.x()) : P2(q.x(), q.y());
    }
    static bool strictly_inside(const P2 &q, const P2 *t, CGAL::Orientation o)
    {
        for (int i = 0; i < 3; i++)
            if (CGAL::orientation(t[i], t[(i + 1) % 3], q) != o)
                return false;
        return true;
    }
    void coplanar(std::size_t a, std::size_t b, int shared)
    {
        K::Vector_3 nrm = CGAL::normal(p[3 * a], p[3 * a + 1], p[3 * a + 2]);
        double ax = std::fabs(nrm.x()), ay = std::fabs(nrm.y()), az = std::fabs(nrm.z());
        int drop = ax >= ay && ax >= az ? 0 : ay >= az ? 1 : 2;
        P2 A[3], B[3];
        for (int i = 0; i < 3; i++) {
            A[i] = proj(p[3 * a + i], drop);
            B[i] = proj(p[3 * b + i], drop);
        }
        CGAL::Orientation oa = CGAL::orientation(A[0], A[1], A[2]);
        CGAL::Orientation ob = CGAL::orientation(B[0], B[1], B[2]);
        if (oa == CGAL::COLLINEAR || ob == CGAL::COLLINEAR)
            return;
        bool overlap = shared == 3;
        for (int i = 0; i < 3 && !overlap; i++)
            for (int j = 0; j < 3 && !overlap; j++) {
                const P2 &a0 = A[i], &a1 = A[(i + 1) % 3], &b0 = B[j], &b1 = B[(j + 1) % 3];
                int s1 = CGAL::orientation(a0, a1, b0), s2 = CGAL::orientation(a0, a1, b1);
                int s3 = CGAL::orientation(b0, b1, a0), s4 = CGAL::orientation(b0, b1, a1);
                if (s1 * s2 < 0 && s3 * s4 < 0)
                    overlap = true;
            }
        for (int i = 0; i < 3 && !overlap; i++)
            overlap = strictly_inside(A[i], B, ob) || strictly_inside(B[i], A, oa);
        if (!overlap)
            overlap = strictly_inside(CGAL::centroid(A[0], A[1], A[2]), B, ob) ||
                      strictly_inside(CGAL::centroid(B[0], B[1], B[2]), A, oa);
        if (!overlap)
            return;
        if (oa == ob) {
            r->coplanar_overlaps++;
            add(LRR_CHECK_ZFIGHT, a, b);
        } else {
            r->contacts++;
            add(LRR_CHECK_CONTACT, a, b);
        }
    }

    void pair(std::size_t a, std::size_t b)
    {
        if (a > b)
            std::swap(a, b);
        int shared = 0, sa = -1, sb = -1;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                if (p[3 * a + i] == p[3 * b + j]) {
                    shared++;
                    sa = i;
                    sb = j;
                }
        const P3 *A = &p[3 * a], *B = &p[3 * b];
        int ob[3], oa[3];
        bool cop = true;
        for (int i = 0; i < 3; i++) {
            ob[i] = CGAL::orientation(A[0], A[1], A[2], B[i]);
            oa[i] = CGAL::orientation(B[0], B[1], B[2], A[i]);
            cop = cop && ob[i] == 0;
        }
        if (cop) {
            coplanar(a, b, shared);
            return;
        }
        auto straddles = [](const int *o) {
            bool pos = false, neg = false;
            for (int i = 0; i < 3; i++) {
                pos = pos || o[i] > 0;
                neg = neg || o[i] < 0;
            }
            return pos && neg;
        };
        if (!straddles(ob) || !straddles(oa) || shared >= 2)
            return;
        bool hit;
        if (shared == 0) {
            hit = CGAL::do_intersect(T3(A[0], A[1], A[2]), T3(B[0], B[1], B[2]));
        } else {
            S3 ea(A[(sa + 1) % 3], A[(sa + 2) % 3]), eb(B[(sb + 1) % 3], B[(sb + 2) % 3]);
            hit = CGAL::do_intersect(ea, T3(B[0], B[1], B[2])) ||
                  CGAL::do_intersect(eb, T3(A[0], A[1], A[2]));
        }
        if (hit) {
            r->intersecting_pairs++;
            add(LRR_CHECK_INTERSECT, a, b);
        }
    }

    void run()
    {
        p.reserve(3 * n);
        degen.assign(n, 0);
        for (std::size_t t = 0; t < n; t++)
            for (int i = 0; i < 3; i++)
                p.push_back(P3(v[9 * t + 3 * i], v[9 * t + 3 * i + 1], v[9 * t + 3 * i + 2]));
        std::vector<Box> boxes;
        for (std::size_t t = 0; t < n; t++) {
            if (CGAL::collinear(p[3 * t], p[3 * t + 1], p[3 * t + 2])) {
                degen[t] = 1;
                r->fix[t] = 1;
                r->degenerate++;
                add(LRR_CHECK_DEGENERATE, t, t);
                continue;
            }
            CGAL::Bbox_3 bb = p[3 * t].bbox() + p[3 * t + 1].bbox() + p[3 * t + 2].bbox();
            boxes.push_back(Box(bb, t));
        }
        std::vector<std::pair<std::size_t, std::size_t>> cand;
        CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), [&](const Box &x, const Box &y) {
            cand.push_back(std::make_pair(std::min(x.handle(), y.handle()),
                                          std::max(x.handle(), y.handle())));
        });
        std::sort(cand.begin(), cand.end());
        for (const auto &c : cand)
            pair(c.first, c.second);
        topology();
        upside_down();
        std::sort(found.begin(), found.end(),
                  [](const lrr_check_finding &x, const lrr_check_finding &y) {
                      if (x.kind != y.kind)
                          return x.kind < y.kind;
                      return x.face_a != y.face_a ? x.face_a < y.face_a : x.face_b < y.face_b;
                  });
    }

    /* The open sheets that look upside down (SheetRays), with one Embree BVH of all the
     * triangles (degenerate ones are never hit). */
    void upside_down();

    /* Edges keyed by exact vertex positions; components by shared edges. */
    void topology()
    {
        std::map<Key, std::size_t> vid;
        std::vector<std::size_t> tv(3 * n);
        for (std::size_t t = 0; t < n; t++)
            for (int i = 0; i < 3; i++) {
                auto it = vid.insert(std::make_pair(key(t, i), vid.size())).first;
                tv[3 * t + i] = it->second;
            }
        /* undirected edge -> list of (triangle, forward?) */
        std::map<std::pair<std::size_t, std::size_t>, std::vector<std::pair<std::size_t, bool>>>
            edges;
        for (std::size_t t = 0; t < n; t++) {
            if (degen[t])
                continue;
            for (int i = 0; i < 3; i++) {
                std::size_t x = tv[3 * t + i], y = tv[3 * t + (i + 1) % 3];
                edges[std::make_pair(std::min(x, y), std::max(x, y))].push_back(
                    std::make_pair(t, x < y));
            }
        }
        std::vector<std::vector<std::pair<std::size_t, bool>>> adj(n); /* (nbr, same dir) */
        std::vector<char> open(n, 0);
        for (const auto &e : edges) {
            const auto &u = e.second;
            if (u.size() == 1) {
                r->open_edges++;
                open[u[0].first] = 1;
                add(LRR_CHECK_OPEN_EDGE, u[0].first, u[0].first);
                continue;
            }
            for (std::size_t i = 0; i < u.size(); i++)
                for (std::size_t j = i + 1; j < u.size(); j++) {
                    bool same = u[i].second == u[j].second;
                    adj[u[i].first].push_back(std::make_pair(u[j].first, same));
                    adj[u[j].first].push_back(std::make_pair(u[i].first, same));
                }
        }
        std::vector<char> seen(n, 0), flip(n, 0);
        for (std::size_t s = 0; s < n; s++) {
            if (degen[s] || seen[s])
                continue;
            std::vector<std::size_t> comp{s};
            seen[s] = 1;
            bool closed = true, bad = false, conflict = false;
            for (std::size_t k = 0; k < comp.size(); k++) {
                std::size_t t = comp[k];
                closed = closed && !open[t];
                for (const auto &nb : adj[t]) {
                    /* consistent: the neighbour traverses the edge the other way */
                    char want = (char)(flip[t] ^ (nb.second ? 1 : 0));
                    if (nb.second)
                        bad = true;
                    if (!seen[nb.first]) {
                        seen[nb.first] = 1;
                        flip[nb.first] = want;
                        comp.push_back(nb.first);
                    } else if (flip[nb.first] != want) {
                        conflict = true;
                    }
                }
            }
            if (!closed)
                sheets.push_back(comp);
            if (!closed || !bad)
                continue;
            r->inconsistent_components++;
            std::size_t nflip = 0;
            for (std::size_t t : comp)
                nflip += (std::size_t)flip[t];
            char minority = 2 * nflip <= comp.size() ? 1 : 0;
            std::size_t rep = s;
            for (std::size_t t : comp)
                if (flip[t] != minority) {
                    rep = t;
                    break;
                }
            for (std::size_t t : comp)
                if (flip[t] == minority) {
                    add(LRR_CHECK_ORIENTATION, t, rep);
                    if (!conflict) /* non-orientable (or non-manifold): report only */
                        r->fix[t] = 2;
                }
        }
    }
};

/* Open sheets modelled upside down (a floor quad facing down into its room): from up to
 * SAMPLES triangles of each sheet, RAYS rays leave each side (the normal and four directions
 * tilted 27° from it). A sheet facing the right way sees front faces from its front and back
 * faces (or nothing) from its back; "wrong" counts the opposite: back faces seen from the
 * front and front faces seen from the back. Flagged when wrong > 2 × right and at least 4
 * rays say so (a light quad under its ceiling sees the ceiling's front from its back, but as
 * many front faces from its front: not flagged). At most 80 rays per sheet. */
struct SheetRays {
    enum { SAMPLES = 8, RAYS = 5 };
    const float *v;
    std::size_t n;
    RTCScene scene;
    float lift; /* ray origins leave the surface by this much */

    /* false when the unit normal is not representable (a sliver whose cross product
     * underflows, or coordinates near FLT_MAX whose products overflow) */
    bool normal(std::size_t t, double nrm[3]) const
    {
        const float *a = v + 9 * t;
        double e1[3], e2[3];
        for (int j = 0; j < 3; j++) {
            e1[j] = (double)a[3 + j] - a[j];
            e2[j] = (double)a[6 + j] - a[j];
        }
        nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
        nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
        nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double len = std::sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        if (!(len > 0 && std::isfinite(len)))
            return false;
        for (int j = 0; j < 3; j++)
            nrm[j] /= len;
        return true;
    }
    /* +1: the ray from t's centroid along dir (on side s of t) meets a front face, -1 a back
     * face, 0 nothing (or a face edge-on) */
    int cast(std::size_t t, const double dir[3], double s) const
    {
        const float *a = v + 9 * t;
        double nrm[3];
        if (!normal(t, nrm))
            return 0;
        struct RTCRayHit rh;
        std::memset(&rh, 0, sizeof rh);
        rh.ray.org_x = (a[0] + a[3] + a[6]) / 3 + (float)(s * nrm[0]) * lift;
        rh.ray.org_y = (a[1] + a[4] + a[7]) / 3 + (float)(s * nrm[1]) * lift;
        rh.ray.org_z = (a[2] + a[5] + a[8]) / 3 + (float)(s * nrm[2]) * lift;
        rh.ray.dir_x = (float)dir[0];
        rh.ray.dir_y = (float)dir[1];
        rh.ray.dir_z = (float)dir[2];
        rh.ray.tfar = INFINITY;
        rh.ray.mask = UINT32_MAX;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        /* Embree asserts (ray.valid()) origins within ±1.844e18 (its FLT_LARGE): a raw
         * scene may hold larger coordinates, whose sheets are then not ray tested */
        const float big = 1e18f;
        if (!(std::fabs(rh.ray.org_x) <= big && std::fabs(rh.ray.org_y) <= big &&
              std::fabs(rh.ray.org_z) <= big))
            return 0;
        struct RTCIntersectContext ictx;
        rtcInitIntersectContext(&ictx);
        rtcIntersect1(scene, &ictx, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
            return 0;
        double hn[3];
        if (!normal(rh.hit.primID, hn))
            return 0;
        double c = hn[0] * dir[0] + hn[1] * dir[1] + hn[2] * dir[2];
        return c < -1e-6 ? 1 : c > 1e-6 ? -1 : 0;
    }
    bool upside_down(const std::vector<std::size_t> &comp) const
    {
        int right = 0, wrong = 0;
        std::size_t step = comp.size() > SAMPLES ? comp.size() / SAMPLES : 1;
        for (std::size_t k = 0; k < comp.size() && k / step < SAMPLES; k += step) {
            std::size_t t = comp[k];
            double nrm[3], u[3], w[3];
            if (!normal(t, nrm))
                continue;
            double h[3] = {1, 0, 0};
            if (std::fabs(nrm[0]) > 0.6) {
                h[0] = 0;
                h[1] = 1;
            }
            u[0] = h[1] * nrm[2] - h[2] * nrm[1];
            u[1] = h[2] * nrm[0] - h[0] * nrm[2];
            u[2] = h[0] * nrm[1] - h[1] * nrm[0];
            double ul = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
            for (int j = 0; j < 3; j++)
                u[j] /= ul;
            w[0] = nrm[1] * u[2] - nrm[2] * u[1];
            w[1] = nrm[2] * u[0] - nrm[0] * u[2];
            w[2] = nrm[0] * u[1] - nrm[1] * u[0];
            for (double s = 1; s >= -1; s -= 2)
                for (int r = 0; r < RAYS; r++) {
                    double a = r == 0 ? 0 : 0.5, cu = r == 1 ? a : r == 2 ? -a : 0;
                    double cw = r == 3 ? a : r == 4 ? -a : 0, dir[3];
                    for (int j = 0; j < 3; j++)
                        dir[j] = s * nrm[j] + cu * u[j] + cw * w[j];
                    int hit = cast(t, dir, s);
                    if (hit != 0 && (hit > 0) == (s > 0))
                        right++;
                    else if (hit != 0)
                        wrong++;
                }
        }
        return wrong > 2 * right && wrong >= 4;
    }
};

void Checker::upside_down()
{
    if (sheets.empty())
        return;
    lrr__geometry g;
    std::memset(&g, 0, sizeof g);
    g.n_tri = n;
    g.vert = const_cast<float *>(v);
    lrr__bvh bvh;
    if ((st = lrr__bvh_build(ctx, &g, RTC_BUILD_QUALITY_MEDIUM, 1, "lrr_scene_check", &bvh)))
        return;
    /* the ray caster's lift (lib/formfactor/raycast.c): clear of float rounding of the
     * origin, far below any feature */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double maxabs = 0;
    for (std::size_t i = 0; i < 9 * n; i++) {
        lo[i % 3] = std::min(lo[i % 3], (double)v[i]);
        hi[i % 3] = std::max(hi[i % 3], (double)v[i]);
        maxabs = std::max(maxabs, std::fabs((double)v[i]));
    }
    double diag = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                            (hi[2] - lo[2]) * (hi[2] - lo[2]));
    SheetRays rays{v, n, bvh.scene, (float)(1e-6 * diag + 8 * FLT_EPSILON * maxabs)};
    for (const auto &comp : sheets) {
        if (!rays.upside_down(comp))
            continue;
        r->upside_down_sheets++;
        std::size_t first = *std::min_element(comp.begin(), comp.end());
        for (std::size_t t : comp)
            add(LRR_CHECK_UPSIDE_DOWN, t, first);
    }
    st = lrr__bvh_status(ctx, &bvh, "ray query");
    lrr__bvh_release(&bvh);
}

bool is_file(const char *name)
{
    struct stat st;
    return stat(name, &st) == 0;
}

} // namespace
#endif /* LRR_HAVE_CGAL */

extern "C" void lrr_check_report_destroy(lrr_check_report *r)
{
    if (!r)
        return;
    std::free(r->findings);
    lrr_aligned_free(r->vert);
    lrr_aligned_free(r->rho);
    lrr_aligned_free(r->emission);
    lrr_aligned_free(r->face);
    std::free(r->fix);
    lrr__check_names_free(r);
    std::free(r);
}

#ifdef LRR_HAVE_CGAL
/* CGAL's own test (Interval_nt's Test_runtime_rounding_modes): with the rounding mode set
 * upwards, -(-a·b) and a·b differ unless rounding modes are ignored. */
static bool rounding_works()
{
    using CGAL::IA_up; // CGAL_IA_MUL and CGAL_IA_DIV name it unqualified
    CGAL::Interval_nt<>::Internal_protector protect;
    return -CGAL_IA_MUL(-1.1, 10.1) != CGAL_IA_MUL(1.1, 10.1) &&
           -CGAL_IA_DIV(-1., 10) != CGAL_IA_DIV(1., 10);
}

extern "C" lrr_status lrr_scene_check(lrr_context *ctx, const char *name, lrr_check_report **out)
{
    *out = nullptr;
    if (!rounding_works())
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "%s: scene check: floating-point rounding modes have no effect here "
                          "(under valgrind?), and CGAL's exact predicates need them",
                          name);
    lrr_check_report *r = static_cast<lrr_check_report *>(std::calloc(1, sizeof *r));
    if (!r)
        return lrr__error(ctx, LRR_ERR_NOMEM, "scene check: out of memory");
    lrr_status st;
    std::size_t n = 0;
    if (is_file(name)) {
        st = lrr__scene_import_raw(ctx, name, &n, &r->vert, &r->rho, &r->emission, &r->face);
    } else {
        lrr_scene *s = nullptr;
        st = lrr_scene_builtin(ctx, name, &s);
        if (st == LRR_OK) {
            n = s->geom.n_tri;
            if ((st = lrr__calloc(ctx, &r->vert, n, 9 * sizeof(float), "check vertices")) ||
                (st = lrr__calloc(ctx, &r->rho, n, 3 * sizeof(float), "check reflectance")) ||
                (st = lrr__calloc(ctx, &r->emission, n, 3 * sizeof(float), "check emission")) ||
                (st = lrr__calloc(ctx, &r->face, n, sizeof(std::size_t), "check faces"))) {
            } else {
                std::memcpy(r->vert, s->geom.vert, n * 9 * sizeof(float));
                std::memcpy(r->rho, s->rho, n * 3 * sizeof(float));
                std::memcpy(r->emission, s->emission, n * 3 * sizeof(float));
                for (std::size_t t = 0; t < n; t++)
                    r->face[t] = t;
            }
            lrr_scene_destroy(s);
        }
    }
    if (st == LRR_OK) {
        for (std::size_t j = 0; j < 9 * n && st == LRR_OK; j++)
            if (!std::isfinite(r->vert[j]))
                st = lrr__error(ctx, LRR_ERR_GEOMETRY, "%s: face %zu: a coordinate is %g", name,
                                r->face[j / 9], (double)r->vert[j]);
    }
    if (st == LRR_OK)
        st = lrr__calloc(ctx, &r->fix, n ? n : 1, 1, "check repair flags");
    if (st != LRR_OK) {
        lrr_check_report_destroy(r);
        return st;
    }
    r->triangles = n;
    try {
        Checker c{n, r->vert, {}, {}, {}, r, {}, ctx, LRR_OK};
        c.run();
        if (c.st != LRR_OK) {
            lrr_check_report_destroy(r);
            return c.st;
        }
        r->n_findings = c.found.size();
        r->findings = static_cast<lrr_check_finding *>(
            std::malloc((c.found.size() ? c.found.size() : 1) * sizeof(lrr_check_finding)));
        if (!r->findings)
            throw std::bad_alloc();
        if (!c.found.empty())
            std::memcpy(r->findings, c.found.data(), c.found.size() * sizeof(lrr_check_finding));
    } catch (const std::bad_alloc &) {
        lrr_check_report_destroy(r);
        return lrr__error(ctx, LRR_ERR_NOMEM, "%s: out of memory checking the scene", name);
    } catch (const std::exception &e) {
        lrr_check_report_destroy(r);
        return lrr__error(ctx, LRR_ERR_GEOMETRY, "%s: scene check failed: %s", name, e.what());
    } catch (...) {
        lrr_check_report_destroy(r);
        return lrr__error(ctx, LRR_ERR_GEOMETRY, "%s: scene check failed", name);
    }
    *out = r;
    return LRR_OK;
}
#else /* !LRR_HAVE_CGAL */
/* configure --without-cgal: no scene check. */
extern "C" lrr_status lrr_scene_check(lrr_context *ctx, const char *name, lrr_check_report **out)
{
    *out = nullptr;
    return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                      "%s: scene check: lrr was built without CGAL (lrr check needs it)", name);
}
#endif
