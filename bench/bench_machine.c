/*
 * lrr-bench: the machine description every command prints first (CPU, caches, threads,
 * OpenBLAS, lrr version, date, load) and the last-level cache size that the bandwidth
 * buffer and the real-time table's cache column use.
 */
#include <omp.h>
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

/* "caches: L1d 48K, L2 1024K, L3 32768K" from sysfs (cpu0's view; the size a core sees) */
static void print_caches(void)
{
    char line[160] = "", path[96], level[16], type[32], size[32];
    for (int i = 0; i < 8; i++) {
        FILE *f;
        int ok = 1;
        const char *want[3] = {"level", "type", "size"};
        char *out[3] = {level, type, size};
        for (int j = 0; j < 3 && ok; j++) {
            snprintf(path, sizeof path, "/sys/devices/system/cpu/cpu0/cache/index%d/%s", i,
                     want[j]);
            ok = (f = fopen(path, "r")) && fscanf(f, "%15s", out[j]) == 1;
            if (f)
                fclose(f);
        }
        if (!ok)
            break;
        if (strcmp(type, "Instruction") == 0)
            continue;
        size_t len = strlen(line);
        snprintf(line + len, sizeof line - len, "%sL%s%s %s", len ? ", " : "", level,
                 strcmp(type, "Data") == 0 ? "d" : "", size);
    }
    printf("caches: %s\n", line[0] ? line : "unknown");
}

void bench_print_machine(void)
{
    char cpu[256], date[64];
    cpu_model(cpu, sizeof cpu);
    time_t t = time(NULL);
    struct tm tm;
    localtime_r(&t, &tm);
    strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S %z", &tm);
    printf("cpu: %s\n", cpu);
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

/* Size of the last-level cache in bytes (the highest cache index sysfs lists), 0 if unknown. */
size_t bench_llc_bytes(void)
{
    size_t best = 0;
    for (int i = 0; i < 8; i++) {
        char path[96];
        snprintf(path, sizeof path, "/sys/devices/system/cpu/cpu0/cache/index%d/size", i);
        FILE *f = fopen(path, "r");
        if (!f)
            continue;
        unsigned long long v = 0;
        char unit = 0;
        if (fscanf(f, "%llu%c", &v, &unit) >= 1) {
            if (unit == 'K')
                v <<= 10;
            else if (unit == 'M')
                v <<= 20;
            if (v > best)
                best = (size_t)v;
        }
        fclose(f);
    }
    return best;
}
