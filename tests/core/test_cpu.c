/* The one CPU dispatch (lib/core/cpu.c): LRR_SIMD takes the same names in the form-factor
 * build and in the solver, refuses an unknown one in both with the valid names in the
 * message, refuses a level this CPU lacks, and the hemicube's SIMD tables give F̄ byte for
 * byte the scalar path's (raster and ray-cast form factors, uniform and cluster
 * hierarchies). */
#include "testutil.h"
#include "core/cpu.h"
#include "operator/operator.h"

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

static const char *const names[] = {"c", "avx2", "avx2+prefetch", "avx512", "avx512+prefetch"};
enum { NAMES = sizeof names / sizeof names[0] };

/* Whether this CPU runs the level of names[i], from the CPU's features read here (not
 * through lrr__cpu_supports): AVX2 needs FMA and F16C too, AVX-512 F and VL on top. */
static int cpu_runs(int i)
{
    if (i == 0)
        return 1;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_cpu_init();
    unsigned a, b, c, d;
    const int f16c = __get_cpuid(1, &a, &b, &c, &d) && (c & bit_F16C);
    const int avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && f16c;
    if (i <= 2)
        return avx2;
    return avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl");
#else
    return 0;
#endif
}

/* A Cornell box of ~40 patches of 4 subpatches (or 60 clusters of ~160 subpatches),
 * hemicube R 32, by the given form-factor method. */
static lrr_status build(lrr_context *ctx, int method, int clusters, lrr_operator **op)
{
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_cornell_box(ctx, 0, &s));
    /* clusters: the scene's patches are the subpatches (levels 0) */
    lrr_subdivision sd = {.target_patches = clusters ? 160 : 40, .levels = clusters ? 0 : 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_build_options o = {.hemicube_resolution = 32, .seed = 7, .formfactor_method = method};
    if (clusters) {
        o.hierarchy = LRR_HIERARCHY_CLUSTER;
        o.adaptive_patches = 60;
    }
    lrr_status st = lrr_operator_build(s, &o, op);
    lrr_scene_destroy(s);
    return st;
}

/* The last error's status and message on ctx, the message into msg. */
static lrr_status last(lrr_context *ctx, char *msg, size_t len)
{
    msg[0] = 0;
    return lrr_context_last_error(ctx, msg, len);
}

static void test_parse(void **state)
{
    (void)state;
    lrr_context *ctx;
    assert_int_equal(lrr_context_create(&ctx), LRR_OK);
    char msg[512];
    for (int i = 0; i < NAMES; i++) {
        lrr__cpu_choice ch;
        const lrr_status st = lrr__cpu_parse(ctx, names[i], &ch);
        if (cpu_runs(i)) {
            assert_int_equal(st, LRR_OK);
            assert_int_equal(ch.isa, i == 0   ? LRR__ISA_C
                                     : i <= 2 ? LRR__ISA_AVX2
                                              : LRR__ISA_AVX512);
            assert_int_equal(ch.prefetch, strstr(names[i], "+prefetch") != NULL);
        } else {
            assert_int_equal(st, LRR_ERR_UNSUPPORTED);
            assert_int_equal(last(ctx, msg, sizeof msg), LRR_ERR_UNSUPPORTED);
            assert_non_null(strstr(msg, "lacks"));
        }
    }
    /* unset or empty: the widest level this CPU runs */
    lrr__cpu_choice ch;
    assert_int_equal(lrr__cpu_parse(ctx, NULL, &ch), LRR_OK);
    assert_int_equal(ch.isa, cpu_runs(3)   ? LRR__ISA_AVX512
                             : cpu_runs(1) ? LRR__ISA_AVX2
                                           : LRR__ISA_C);
    assert_int_equal(lrr__cpu_parse(ctx, "", &ch), LRR_OK);
    /* names differ from a valid one by case, a suffix or a prefix */
    const char *bad[] = {"AVX2", "avx2+", "avx512f", "sse2", "avx2+prefetch ", "+prefetch"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_int_equal(lrr__cpu_parse(ctx, bad[i], &ch), LRR_ERR_INVALID_ARG);
        assert_int_equal(last(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
        assert_non_null(strstr(msg, "c, avx2, avx2+prefetch, avx512, avx512+prefetch"));
    }
    lrr_context_destroy(ctx);
}

/* LRR_SIMD through the public API: the form-factor build and the solver accept and refuse
 * the same names, with the same messages. */
static void test_environment(void **state)
{
    (void)state;
    lrr_context *ctx;
    assert_int_equal(lrr_context_create(&ctx), LRR_OK);
    char msg[512];
    unsetenv("LRR_SIMD");
    lrr_operator *base;
    LRR_CHECK(ctx, build(ctx, LRR_FORMFACTOR_RASTER, 0, &base));
    for (int method = LRR_FORMFACTOR_RASTER; method <= LRR_FORMFACTOR_RAYCAST; method++) {
        setenv("LRR_SIMD", "bogus", 1);
        lrr_operator *op = (lrr_operator *)0x1;
        assert_int_equal(build(ctx, method, 0, &op), LRR_ERR_INVALID_ARG);
        assert_null(op);
        assert_int_equal(last(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
        assert_non_null(strstr(msg, "LRR_SIMD=bogus: not one of c, avx2, avx2+prefetch, "
                                    "avx512, avx512+prefetch"));
    }
    for (int backend = LRR_BACKEND_CPU; backend <= LRR_BACKEND_OPENCL; backend++) {
        lrr_solver *sv = (lrr_solver *)0x1;
        assert_int_equal(lrr_solver_create(base, backend, &sv), LRR_ERR_INVALID_ARG);
        assert_null(sv);
        assert_int_equal(last(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
        assert_non_null(strstr(msg, "LRR_SIMD=bogus: not one of c, avx2, avx2+prefetch, "
                                    "avx512, avx512+prefetch"));
    }
    for (int i = 0; i < NAMES; i++) {
        setenv("LRR_SIMD", names[i], 1);
        const lrr_status want = cpu_runs(i) ? LRR_OK : LRR_ERR_UNSUPPORTED;
        lrr_operator *op = NULL;
        assert_int_equal(build(ctx, LRR_FORMFACTOR_RASTER, 0, &op), want);
        lrr_solver *sv = NULL;
        assert_int_equal(lrr_solver_create(base, LRR_BACKEND_CPU, &sv), want);
        if (want) {
            assert_int_equal(last(ctx, msg, sizeof msg), LRR_ERR_UNSUPPORTED);
            assert_non_null(strstr(msg, "this CPU lacks the instructions"));
            print_message("LRR_SIMD=%s: not on this CPU, refused\n", names[i]);
        } else {
            assert_string_equal(lrr_solver_kernel(sv), names[i]);
        }
        lrr_solver_destroy(sv);
        lrr_operator_destroy(op);
    }
    unsetenv("LRR_SIMD");
    lrr_operator_destroy(base);
    lrr_context_destroy(ctx);
}

/* F̄ of every level this CPU runs, byte for byte LRR_SIMD=c's: the raster hemicube (uniform
 * and cluster hierarchies: the flat and the searched leaf-to-patch paths) and the ray-cast
 * one (whose pixels take no SIMD step, but whose build reads the same choice). */
static void test_fbar_identical(void **state)
{
    (void)state;
    lrr_context *ctx;
    assert_int_equal(lrr_context_create(&ctx), LRR_OK);
    const int cases[][2] = {{LRR_FORMFACTOR_RASTER, 0},
                            {LRR_FORMFACTOR_RASTER, 1},
                            {LRR_FORMFACTOR_RAYCAST, 0}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        setenv("LRR_SIMD", "c", 1);
        lrr_operator *ref;
        LRR_CHECK(ctx, build(ctx, cases[c][0], cases[c][1], &ref));
        for (int i = 1; i < NAMES; i += 2) { /* avx2, avx512 (prefetch is the solver's) */
            if (!cpu_runs(i))
                continue;
            setenv("LRR_SIMD", names[i], 1);
            lrr_operator *op;
            LRR_CHECK(ctx, build(ctx, cases[c][0], cases[c][1], &op));
            assert_int_equal(op->n, ref->n);
            assert_int_equal(op->k, ref->k);
            assert_memory_equal(op->fbar, ref->fbar, op->n * op->k * sizeof *op->fbar);
            print_message("method %d clusters %d: F̄ (%zu × %zu) of %s = c's\n", cases[c][0],
                          cases[c][1], op->n, op->k, names[i]);
            lrr_operator_destroy(op);
        }
        lrr_operator_destroy(ref);
    }
    unsetenv("LRR_SIMD");
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse),
        cmocka_unit_test(test_environment),
        cmocka_unit_test(test_fbar_identical),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
