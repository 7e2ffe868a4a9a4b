/* The one CPU dispatch (cpu.h): the CPU's instruction sets and the environment's LRR_SIMD,
 * read on each call (a few CPUID reads; consumers keep the answer in their own objects).
 *
 * Levels nest (AVX-512 implies the AVX2 level), so one name picks every consumer's variant:
 * the solver's kernels need AVX2 with FMA and F16C (the 16-bit rows), the hemicube's
 * eight-lane steps AVX-512 F with VL (256-bit masked integer stores). Without LRR_SIMD the
 * widest level runs: AVX-512 with 8-row groups beats AVX2 in the solver at every size
 * measured (k = 216 and 864, n = 3456 to 221184; realtime_avx2.c's ROWS_AVX2), and
 * eight hemicube lanes beat four (Cornell 216/2, one thread, R 64 0.370 against 0.394 s,
 * docs/METHOD.md "Form factors"). */
#include "config.h"
#include "core/cpu.h"

#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#define LRR_X86 1
#include <cpuid.h>
#endif

#ifdef LRR_X86
/* F16C is CPUID leaf 1, ECX bit 29, read directly: clang before 16 rejects "f16c" in
 * __builtin_cpu_supports (the --enable-fuzzing build uses clang). */
static int has_f16c(void)
{
    unsigned a, b, c, d;
    return __get_cpuid(1, &a, &b, &c, &d) && (c & bit_F16C) != 0;
}
#endif

int lrr__cpu_supports(lrr__isa isa)
{
#ifdef LRR_X86
    __builtin_cpu_init();
    const int avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
                     has_f16c();
    if (isa == LRR__ISA_AVX2)
        return avx2;
    if (isa == LRR__ISA_AVX512)
        return avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl");
#endif
    return isa == LRR__ISA_C;
}

/* Software prefetch in the solver's panels where it is measured to pay: Intel (0.95× the
 * read loop in f32 against 1.15× without, 1.01× against 1.47× in f16, panel_kernel.c). AMD's
 * hardware prefetcher keeps the panels at 0.84× without it, and the row kernels' own
 * prefetch is slower there. */
static int wants_prefetch(void)
{
#ifdef LRR_X86
    __builtin_cpu_init();
    return __builtin_cpu_is("intel");
#else
    return 0;
#endif
}

static const struct {
    const char *name;
    lrr__isa isa;
    int prefetch;
} names[] = {
    {"c", LRR__ISA_C, 0},
    {"avx2", LRR__ISA_AVX2, 0},
    {"avx2+prefetch", LRR__ISA_AVX2, 1},
    {"avx512", LRR__ISA_AVX512, 0},
    {"avx512+prefetch", LRR__ISA_AVX512, 1},
};

lrr_status lrr__cpu_parse(lrr_context *ctx, const char *name, lrr__cpu_choice *out)
{
    if (!name || !*name) {
        out->isa = lrr__cpu_supports(LRR__ISA_AVX512) ? LRR__ISA_AVX512
                   : lrr__cpu_supports(LRR__ISA_AVX2) ? LRR__ISA_AVX2
                                                       : LRR__ISA_C;
        out->prefetch = out->isa != LRR__ISA_C && wants_prefetch();
        return LRR_OK;
    }
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcmp(names[i].name, name) == 0) {
            if (!lrr__cpu_supports(names[i].isa))
                return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                                  "LRR_SIMD=%s: this CPU lacks the instructions", name);
            out->isa = names[i].isa;
            out->prefetch = names[i].prefetch;
            return LRR_OK;
        }
    return lrr__error(ctx, LRR_ERR_INVALID_ARG, "LRR_SIMD=%s: not one of " LRR__CPU_NAMES,
                      name);
}

lrr_status lrr__cpu_choose(lrr_context *ctx, lrr__cpu_choice *out)
{
    return lrr__cpu_parse(ctx, getenv("LRR_SIMD"), out);
}
