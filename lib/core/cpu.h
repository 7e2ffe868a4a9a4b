/* The one CPU dispatch of the library: which SIMD instruction set its kernels use (the
 * solver's row and panel kernels, solve/realtime_kernel.c; the hemicube rasteriser's pixel
 * steps, formfactor/hemicube_avx2.c and hemicube_avx512.c). The features are read from the
 * CPU on each call (a few CPUID reads) and the environment's LRR_SIMD parsed there; each
 * consumer keeps the answer in its own object (a solver, a form-factor build) and picks its
 * table of functions once from it, so the library holds no mutable global state. */
#ifndef LRR_CORE_CPU_H
#define LRR_CORE_CPU_H

#include "core/internal.h"

/* Instruction-set levels, each a superset of the ones below it. */
typedef enum {
    LRR__ISA_C = 0,      /* portable C */
    LRR__ISA_AVX2 = 1,   /* AVX2 with FMA and F16C */
    LRR__ISA_AVX512 = 2, /* that and AVX-512 F and VL */
} lrr__isa;

typedef struct {
    lrr__isa isa;
    int prefetch; /* the solver's software-prefetch twins (panel_kernel.c) */
} lrr__cpu_choice;

/* Every name LRR_SIMD accepts, as the error messages list them. */
#define LRR__CPU_NAMES "c, avx2, avx2+prefetch, avx512, avx512+prefetch"

/* Whether this CPU runs isa. Thread safety: any thread. */
int lrr__cpu_supports(lrr__isa isa);
/* The choice for LRR_SIMD = name: "c", "avx2", "avx512", the last two also with
 * "+prefetch". NULL or "" gives the widest level this CPU runs, with prefetch on Intel CPUs.
 * An unknown name is LRR_ERR_INVALID_ARG, a level this CPU lacks LRR_ERR_UNSUPPORTED, each
 * with a message on ctx. Thread safety: any thread. */
lrr_status lrr__cpu_parse(lrr_context *ctx, const char *name, lrr__cpu_choice *out);
/* lrr__cpu_parse of the environment's LRR_SIMD (the one place lib/ reads it). */
lrr_status lrr__cpu_choose(lrr_context *ctx, lrr__cpu_choice *out);

#endif
