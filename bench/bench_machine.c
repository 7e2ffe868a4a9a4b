/*
 * lrr-bench: the machine description every command prints first (CPU, caches, threads,
 * OpenBLAS, lrr version, date, load) and the last-level cache size that the bandwidth
 * buffer and the real-time table's cache column use.
 */
#include <omp.h>
#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bench.h"

/* ------------------------------------------------------------------ machine description */
static void cpu_model(char *buf, size_t len)
{
    snprintf(buf, len, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "model name", 10) != 0)
            continue;
        char *colon = strchr(line, ':');
        if (!colon)
            continue;
        colon++;
        while (*colon == ' ' || *colon == '\t')
            colon++;
        colon[strcspn(colon, "\n")] = '\0';
        snprintf(buf, len, "%s", colon);
        break;
    }
    fclose(f);
}

/* One data or unified cache level: level 1-3, size in bytes. */
typedef struct cache_level {
    int level, data; /* data: 1 for a data cache, 0 for a unified one */
    size_t bytes;
} cache_level;

#define MAX_CACHES 8

/* The first word of cpu0's cache file index<i>/<name> into buf; 0 on success. */
static int sysfs_cache_word(int i, const char *name, char *buf)
{
    char path[96];
    snprintf(path, sizeof path, "/sys/devices/system/cpu/cpu0/cache/index%d/%s", i, name);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    int ok = fscanf(f, "%31s", buf) == 1;
    fclose(f);
    return ok ? 0 : -1;
}

/* Caches from sysfs (cpu0's view; the size a core sees), instruction caches left out;
 * returns how many. */
static int caches_sysfs(cache_level *c)
{
    int count = 0;
    for (int i = 0; i < MAX_CACHES; i++) {
        char level[32], type[32], size[32], *end;
        if (sysfs_cache_word(i, "level", level) || sysfs_cache_word(i, "type", type) ||
            sysfs_cache_word(i, "size", size))
            break;
        if (strcmp(type, "Instruction") == 0)
            continue;
        unsigned long long v = strtoull(size, &end, 10);
        v <<= *end == 'K' ? 10 : *end == 'M' ? 20 : 0;
        c[count++] = (cache_level){atoi(level), strcmp(type, "Data") == 0, (size_t)v};
    }
    return count;
}

/* AMD's older cache leaves, where 0x8000001D answers zeros (this project's VM: topoext is
 * not passed through): L1d in 0x80000005 ECX[31:24] KiB, L2 in 0x80000006 ECX[31:16] KiB,
 * L3 in 0x80000006 EDX[31:18] × 512 KiB. */
static int caches_amd_legacy(cache_level *c)
{
    int count = 0;
#if defined(__x86_64__) || defined(__i386__)
    unsigned a, b, cx, d;
    if (__get_cpuid_max(0x80000000u, NULL) < 0x80000006u)
        return 0;
    __cpuid(0x80000005u, a, b, cx, d);
    if (cx >> 24)
        c[count++] = (cache_level){1, 1, (size_t)(cx >> 24) << 10};
    __cpuid(0x80000006u, a, b, cx, d);
    if (cx >> 16)
        c[count++] = (cache_level){2, 0, (size_t)(cx >> 16) << 10};
    if (d >> 18)
        c[count++] = (cache_level){3, 0, (size_t)(d >> 18) << 19};
#else
    (void)c;
#endif
    return count;
}

/* Caches from cpuid where sysfs is silent (a VM without /sys/.../cache, as this project's
 * shared VM): the deterministic cache parameters, leaf 4 on Intel, 0x8000001D on AMD
 * (type, level; size = ways · partitions · line · sets), else AMD's older leaves. *leaf
 * gets the leaf used. */
static int caches_cpuid(cache_level *c, unsigned *leaf)
{
    int count = 0;
#if defined(__x86_64__) || defined(__i386__)
    unsigned a, b, cx, d;
    char vendor[13] = "";
    if (!__get_cpuid(0, &a, &b, &cx, &d))
        return 0;
    memcpy(vendor, &b, 4), memcpy(vendor + 4, &d, 4), memcpy(vendor + 8, &cx, 4);
    const int amd = strcmp(vendor, "AuthenticAMD") == 0;
    *leaf = amd ? 0x8000001Du : 4u;
    if (__get_cpuid_max(*leaf & 0x80000000u, NULL) >= *leaf)
        for (unsigned i = 0; i < 16 && count < MAX_CACHES; i++) {
            __cpuid_count(*leaf, i, a, b, cx, d);
            unsigned type = a & 0x1f;
            if (type == 0)
                break;
            if (type == 2) /* instruction */
                continue;
            size_t ways = (b >> 22) + 1, parts = ((b >> 12) & 0x3ff) + 1, line = (b & 0xfff) + 1;
            c[count++] = (cache_level){(int)((a >> 5) & 7), type == 1,
                                       ways * parts * line * ((size_t)cx + 1)};
        }
    if (!count && amd) {
        *leaf = 0x80000006u;
        count = caches_amd_legacy(c);
    }
#else
    (void)c, (void)leaf;
#endif
    return count;
}

/* The caches, sysfs first, cpuid as the fallback; *source names the one used. */
static int caches_of(cache_level *c, const char **source)
{
    static char leaf_name[32];
    unsigned leaf = 0;
    int count = caches_sysfs(c);
    *source = "sysfs";
    if (count)
        return count;
    count = caches_cpuid(c, &leaf);
    snprintf(leaf_name, sizeof leaf_name, leaf == 0x80000006u ? "cpuid leaves 0x80000005/6"
                                                              : "cpuid leaf 0x%X", leaf);
    *source = count ? leaf_name : "none";
    return count;
}

/* "caches: L1d 48K, L2 1024K, L3 32768K (sysfs)" */
static void print_caches(void)
{
    cache_level c[MAX_CACHES];
    const char *source;
    int count = caches_of(c, &source);
    char line[200] = "";
    for (int i = 0; i < count; i++) {
        size_t len = strlen(line);
        snprintf(line + len, sizeof line - len, "%sL%d%s %zuK", len ? ", " : "", c[i].level,
                 c[i].data ? "d" : "", c[i].bytes >> 10);
    }
    if (count)
        printf("caches: %s (%s)\n", line, source);
    else
        printf("caches: unknown\n");
}

/* " (AMD family 26 model 2 stepping 1)" from cpuid leaves 0 and 1 (display family and model:
 * the extended fields added as the SDM and the APM say), "" where there is no cpuid. */
static void cpu_signature(char *buf, size_t len)
{
    buf[0] = '\0';
#if defined(__x86_64__) || defined(__i386__)
    unsigned a, b, c, d;
    char vendor[13] = "";
    if (!__get_cpuid(0, &a, &b, &c, &d))
        return;
    memcpy(vendor, &b, 4), memcpy(vendor + 4, &d, 4), memcpy(vendor + 8, &c, 4);
    if (!__get_cpuid(1, &a, &b, &c, &d))
        return;
    unsigned family = (a >> 8) & 0xf, model = (a >> 4) & 0xf;
    if (family == 0xf)
        family += (a >> 20) & 0xff;
    if (family == 6 || family >= 0xf)
        model += ((a >> 16) & 0xf) << 4;
    const char *v = strcmp(vendor, "GenuineIntel") == 0   ? "Intel"
                    : strcmp(vendor, "AuthenticAMD") == 0 ? "AMD"
                                                          : vendor;
    snprintf(buf, len, " (%s family %u model %u stepping %u)", v, family, model, a & 0xf);
#else
    (void)len;
#endif
}

void bench_print_machine(void)
{
    char cpu[256], date[64];
    cpu_model(cpu, sizeof cpu);
    time_t t = time(NULL);
    struct tm tm;
    localtime_r(&t, &tm);
    strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S %z", &tm);
    char sig[96];
    cpu_signature(sig, sizeof sig);
    printf("cpu: %s%s\n", cpu, sig);
    print_caches();
    printf("cores_online: %ld\n", sysconf(_SC_NPROCESSORS_ONLN));
    printf("threads_openmp: %d\n", omp_get_max_threads());
    printf("threads_openblas: %d\n", openblas_get_num_threads());
    printf("openblas: %s\n", openblas_get_config());
    const char *ct = getenv("OPENBLAS_CORETYPE");
    if (ct)
        printf("openblas_core: %s (OPENBLAS_CORETYPE=%s)\n", openblas_get_corename(), ct);
    else
        printf("openblas_core: %s\n", openblas_get_corename());
    printf("lrr: %s\n", lrr_version_string());
    printf("date: %s\n", date);
    /* timings on a shared machine mean little when it is busy: say how busy it was */
    FILE *f = fopen("/proc/loadavg", "r");
    double l1, l5, l15;
    if (f && fscanf(f, "%lf %lf %lf", &l1, &l5, &l15) == 3)
        printf("load_average: %.2f %.2f %.2f\n", l1, l5, l15);
    if (f)
        fclose(f);
}

/* Size of the last-level cache in bytes (the largest cache sysfs lists), 0 if unknown.
 * sysfs only, not cpuid: under a hypervisor cpuid says what the host chooses (this
 * project's VM: an L3 of 508 MiB from leaf 0x80000006, more than the 32 MiB one Zen 5 core
 * complex shares), and the bandwidth buffer (4 × the LLC) and the cache-resident floors
 * would follow it. */
size_t bench_llc_bytes(void)
{
    cache_level c[MAX_CACHES];
    size_t best = 0;
    for (int i = caches_sysfs(c) - 1; i >= 0; i--)
        if (c[i].bytes > best)
            best = c[i].bytes;
    return best;
}
