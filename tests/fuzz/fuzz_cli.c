/*
 * Fuzz target: the `lrr` tool's command lines (every subcommand's option parsing and
 * checks), through lrr_cli_main with parse_only set, so nothing is read, written or computed
 * (tools/lrr.c is built into this target with -DLRR_CLI_NO_MAIN).
 *
 * Input: the arguments after "lrr", one per line (a final newline is optional; no NUL
 * bytes inside an argument, since argv strings cannot hold them).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "fuzz.h"

#define MAX_INPUT 4096
#define MAX_ARGS 64

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_init();
    if (size > MAX_INPUT)
        return 0;
    /* Each argument its own allocation, so ASan catches a parser reading past one. */
    char *argv[MAX_ARGS + 2];
    int argc = 0;
    if (!(argv[argc++] = strdup("lrr")))
        fuzz_fail("out of memory");
    size_t start = 0;
    for (size_t i = 0; size > 0 && i <= size && argc <= MAX_ARGS; i++) {
        if (i < size && data[i] != '\n')
            continue;
        if (i == size && start == size && size > 0)
            break; /* the final newline ends the last argument, it does not start one */
        size_t len = i - start;
        char *arg = malloc(len + 1);
        if (!arg)
            fuzz_fail("out of memory");
        memcpy(arg, data + start, len);
        arg[len] = '\0'; /* an embedded NUL just ends the argument early, as in a real argv */
        argv[argc++] = arg;
        start = i + 1;
    }
    argv[argc] = NULL;
    /* getopt permutes argv: keep the pointers to free them */
    char *owned[MAX_ARGS + 2];
    memcpy(owned, argv, sizeof(char *) * (size_t)argc);
    /* The tool's help texts and usage messages would flood the fuzzer's output and slow it
     * down: send them to /dev/null for the call (glibc's stdout and stderr are assignable
     * variables; the sanitizers and libFuzzer report through their own descriptors). */
    static FILE *devnull;
    if (!devnull && !(devnull = fopen("/dev/null", "w")))
        fuzz_fail("cannot open /dev/null");
    FILE *out = stdout, *err = stderr;
    stdout = stderr = devnull;
    int rc = lrr_cli_main(argc, argv, 1);
    fflush(devnull);
    stdout = out;
    stderr = err;
    if (rc != CLI_EXIT_OK && rc != CLI_EXIT_FAIL && rc != CLI_EXIT_USAGE)
        fuzz_fail("lrr_cli_main returned %d for a command line", rc);
    for (int i = 0; i < argc; i++)
        free(owned[i]);
    return 0;
}
