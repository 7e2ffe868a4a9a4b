/*
 * Shared by the fuzz targets (tests/fuzz/fuzz_*.c): each defines LLVMFuzzerTestOneInput, which
 * libFuzzer drives (--enable-fuzzing, `make fuzz-smoke`) and tests/fuzz/replay.c feeds the
 * seed corpus and the regressions to in `make check`.
 *
 * The library reads files, so a target writes its input to a file in a private directory
 * (mkdtemp, once per process, removed at exit) and removes it again before returning: no
 * state carries over from one input to the next.
 */
#ifndef LRR_FUZZ_H
#define LRR_FUZZ_H

#include <stddef.h>
#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* One-time set-up: the private directory, and one OpenMP thread (the inputs are tiny; a
 * thread pool per process only adds noise to the fuzzer's timing). */
void fuzz_init(void);

/* Writes size bytes to the file `name` in the private directory and returns its path (owned
 * by fuzz.c, valid until the next fuzz_write with the same name). Aborts on an I/O failure:
 * that is the machine's problem, not a finding. */
const char *fuzz_write(const char *name, const void *data, size_t size);

/* Removes the file `name` from the private directory (no error if absent). */
void fuzz_remove(const char *name);

/* Reports a broken invariant the sanitizers cannot see and aborts, so libFuzzer saves the
 * input as a crash. */
void fuzz_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));

#endif /* LRR_FUZZ_H */
