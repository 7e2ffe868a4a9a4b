/*
 * Runs a fuzz target without libFuzzer: feeds it every file of its seed corpus and of its
 * regressions (tests/fuzz/TARGET/seeds and .../regressions, FUZZ_TARGET_DIR at build time),
 * or the files and directories named on the command line. Built with any compiler as a
 * `make check` test, so every CI run replays the crashes found so far; a crash fails the
 * test (under --enable-sanitizers the sanitizers report it).
 *
 *   tests/fuzz/replay_scene crash-1234abcd     reproduce one input
 */
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz.h"

#ifndef FUZZ_TARGET_DIR
#error "FUZZ_TARGET_DIR (the target's directory of seeds and regressions) must be defined"
#endif

/* Exit status of a test the harness should report as a hard error (automake). */
#define EXIT_HARD_ERROR 99

static int run_file(const char *path, size_t *count)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "replay: %s: %s\n", path, strerror(errno));
        return -1;
    }
    size_t cap = 4096, len = 0;
    unsigned char *buf = malloc(cap);
    size_t got;
    while (buf && (got = fread(buf + len, 1, cap - len, f)) > 0) {
        len += got;
        if (len == cap) {
            unsigned char *bigger = cap <= SIZE_MAX / 2 ? realloc(buf, cap * 2) : NULL;
            if (!bigger) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = bigger;
            cap *= 2;
        }
    }
    int err = !buf || ferror(f);
    fclose(f);
    if (err) {
        free(buf);
        fprintf(stderr, "replay: %s: cannot read\n", path);
        return -1;
    }
    printf("replay: %s (%zu bytes)\n", path, len);
    fflush(stdout);
    /* libFuzzer passes a buffer of exactly `size` bytes: copy so ASan sees overreads */
    unsigned char *exact = malloc(len ? len : 1);
    if (!exact) {
        free(buf);
        return -1;
    }
    memcpy(exact, buf, len);
    free(buf);
    LLVMFuzzerTestOneInput(exact, len);
    free(exact);
    (*count)++;
    return 0;
}

static int compare_names(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Every regular file in dir, in name order (hidden files skipped); a missing directory holds
 * nothing. */
static int run_dir(const char *dir, size_t *count)
{
    DIR *d = opendir(dir);
    if (!d)
        return errno == ENOENT ? 0 : -1;
    char **names = NULL;
    size_t n = 0, cap = 0;
    int rc = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        if (n == cap) {
            char **bigger = realloc(names, (cap = cap ? 2 * cap : 64) * sizeof *names);
            if (!bigger) {
                rc = -1;
                break;
            }
            names = bigger;
        }
        size_t len = strlen(dir) + strlen(e->d_name) + 2;
        if (!(names[n] = malloc(len))) {
            rc = -1;
            break;
        }
        snprintf(names[n++], len, "%s/%s", dir, e->d_name);
    }
    closedir(d);
    if (rc == 0 && n > 1)
        qsort(names, n, sizeof *names, compare_names);
    for (size_t i = 0; i < n; i++) {
        struct stat st;
        if (rc == 0 && stat(names[i], &st) == 0 && S_ISREG(st.st_mode))
            rc = run_file(names[i], count);
        free(names[i]);
    }
    free(names);
    return rc;
}

static int run_path(const char *path, size_t *count)
{
    struct stat st;
    if (stat(path, &st) != 0) {
        fprintf(stderr, "replay: %s: %s\n", path, strerror(errno));
        return -1;
    }
    return S_ISDIR(st.st_mode) ? run_dir(path, count) : run_file(path, count);
}

int main(int argc, char *argv[])
{
    size_t count = 0;
    int rc = 0;
    fuzz_init();
    if (argc > 1) {
        for (int i = 1; i < argc && rc == 0; i++)
            rc = run_path(argv[i], &count);
    } else {
        rc = run_dir(FUZZ_TARGET_DIR "/seeds", &count);
        if (rc == 0 && count == 0) {
            fprintf(stderr, "replay: no seeds in %s/seeds\n", FUZZ_TARGET_DIR);
            return EXIT_HARD_ERROR;
        }
        if (rc == 0)
            rc = run_dir(FUZZ_TARGET_DIR "/regressions", &count);
    }
    if (rc != 0)
        return EXIT_HARD_ERROR;
    printf("replay: %zu input(s) ran without a crash\n", count);
    return 0;
}
