/* lrr_operator_save when writing fails or the process dies (include/lrr.h promises: path is
 * untouched or the complete new file; a failure names path, step and cause and removes the
 * temporary file; a killed process may leave its temporary file behind).
 *   - every I/O step of one save fails in turn (the test-only hook lrr__context_set_io_hook:
 *     create, each block written, flush, fsync, close, rename), with ENOSPC and with EIO,
 *     with and without an existing file under the final name;
 *   - a real file-size limit (setrlimit RLIMIT_FSIZE with SIGXFSZ ignored, in a forked
 *     child, so write() fails with EFBIG) at many sizes up to the file's;
 *   - a child killed by SIGKILL at every step of the save (the hook raises it), and children
 *     killed at random times while saving a 16 MB operator over and over;
 *   - a read-only directory (as root: in a child that drops to uid 65534, since root may
 *     write anywhere). */
#include "testutil.h"
#include "operator/operator.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>

#define MAX_STEPS 64

static struct {
    lrr_context *ctx;
    lrr_operator *small, *big; /* different contents, so their files differ */
    char dir[256], path[300];
    unsigned char *small_bytes, *big_bytes;
    size_t small_len, big_len;
    unsigned long steps;              /* I/O steps of one save of `big` */
    char step_name[MAX_STEPS + 1][32]; /* 1-based */
} F;

/* ------------------------------------------------------------ helpers */
static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long sz = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(sz > 0 ? (size_t)sz : 1);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)sz, f), (size_t)sz);
    fclose(f);
    *len = (size_t)sz;
    return b;
}

static void spit(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

/* Temporary files next to F.path: returns their count, the first one's name in first. */
static int temp_files(char *first, size_t len)
{
    char prefix[64];
    snprintf(prefix, sizeof prefix, "%s.tmp.", strrchr(F.path, '/') + 1);
    DIR *d = opendir(F.dir);
    assert_non_null(d);
    int count = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strncmp(e->d_name, prefix, strlen(prefix)) == 0 &&
            strlen(e->d_name) == strlen(prefix) + 6 && count++ == 0 && first)
            snprintf(first, len, "%s/%s", F.dir, e->d_name);
    closedir(d);
    return count;
}

/* The state under the final name: 0 absent, 1 the small file, 2 the big file; fails the
 * test on anything else (a partial or mixed file). */
static int final_state(const char *when)
{
    size_t len;
    unsigned char *b = slurp(F.path, &len);
    if (!b) {
        assert_int_equal(errno, ENOENT);
        return 0;
    }
    int which = len == F.small_len && memcmp(b, F.small_bytes, len) == 0   ? 1
                : len == F.big_len && memcmp(b, F.big_bytes, len) == 0 ? 2
                                                                       : -1;
    free(b);
    if (which < 0)
        fail_msg("%s: %s holds %zu bytes that are neither the old nor the new file", when,
                 F.path, len);
    return which;
}

/* Puts the small operator's file under the final name (prior = 1) or removes it (0). */
static void set_prior(int prior)
{
    if (prior)
        spit(F.path, F.small_bytes, F.small_len);
    else if (remove(F.path) != 0)
        assert_int_equal(errno, ENOENT);
}

/* An operator of the subdivided Cornell box with made-up contents (no hemicubes: fast, and
 * any finite values in range load back). */
static lrr_operator *made_up(size_t patches, unsigned levels, float scale)
{
    lrr_scene *scene;
    LRR_CHECK(F.ctx, lrr_scene_cornell_box(F.ctx, 0, &scene));
    lrr_subdivision sub = {.target_patches = patches, .levels = levels};
    LRR_CHECK(F.ctx, lrr_scene_subdivide(scene, &sub));
    lrr_operator *op;
    LRR_CHECK(F.ctx, lrr__operator_new(F.ctx, &scene->geom, LRR_STORAGE_F32, &op));
    lrr_scene_destroy(scene);
    for (size_t i = 0; i < 3 * op->n; i++)
        op->rho[i] = 0.5f;
    for (size_t i = 0; i < op->n * op->k; i++)
        op->fbar[i] = scale * (float)((i * 2654435761u) % 1000) * 1e-6f;
    for (size_t c = 0; c < 3; c++)
        for (size_t p = 0; p < op->k; p++)
            op->m[c * op->k * op->k + p * op->k + p] = 1.0f;
    op->hemicube_resolution = 16;
    return op;
}

/* ------------------------------------------------------------ hooks */
static int record_steps(void *user, unsigned long step, const char *what)
{
    (void)user;
    if (step <= MAX_STEPS)
        snprintf(F.step_name[step], sizeof F.step_name[step], "%s", what);
    F.steps = step;
    return 0;
}

typedef struct fault {
    unsigned long at;
    int err; /* errno to inject; 0: raise SIGKILL */
} fault;

static int inject(void *user, unsigned long step, const char *what)
{
    (void)what;
    const fault *f = user;
    if (step != f->at)
        return 0;
    if (f->err == 0)
        raise(SIGKILL);
    return f->err;
}

/* What the message says for a failure at this step. */
static const char *step_phrase(const char *what)
{
    if (!strcmp(what, "create"))
        return "cannot create temporary file";
    if (!strcmp(what, "rename"))
        return "cannot rename the temporary file onto it";
    return "cannot write temporary file";
}

/* ------------------------------------------------------------ fixtures */
static int setup(void **state)
{
    (void)state;
    if (lrr_context_create(&F.ctx))
        return -1;
    const char *root = getenv("LRR_TEST_TMP");
    snprintf(F.dir, sizeof F.dir, "%s/save_faults.XXXXXX", root && *root ? root : "/tmp");
    if (!mkdtemp(F.dir))
        return -1;
    snprintf(F.path, sizeof F.path, "%s/op.lrr", F.dir);
    F.small = made_up(24, 1, 1.0f);
    F.big = made_up(500, 2, 2.0f); /* n = 7968, k = 498: F̄ alone is 15.9 MB */
    if (lrr_operator_save(F.small, F.path))
        return -1;
    F.small_bytes = slurp(F.path, &F.small_len);
    lrr__context_set_io_hook(F.ctx, record_steps, NULL);
    if (lrr_operator_save(F.big, F.path))
        return -1;
    lrr__context_set_io_hook(F.ctx, NULL, NULL);
    F.big_bytes = slurp(F.path, &F.big_len);
    remove(F.path);
    return F.small_bytes && F.big_bytes && F.steps >= 8 && F.steps <= MAX_STEPS ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char tmp[512];
    while (temp_files(tmp, sizeof tmp) > 0)
        remove(tmp);
    remove(F.path);
    rmdir(F.dir);
    free(F.small_bytes);
    free(F.big_bytes);
    lrr_operator_destroy(F.small);
    lrr_operator_destroy(F.big);
    lrr_context_destroy(F.ctx);
    return 0;
}

/* ------------------------------------------------------------ tests */
static void test_steps(void **state)
{
    (void)state;
    /* create, header, table, sections with padding, flush, fsync, close, rename, dir sync */
    assert_string_equal(F.step_name[1], "create");
    assert_string_equal(F.step_name[F.steps - 4], "flush");
    assert_string_equal(F.step_name[F.steps - 3], "fsync");
    assert_string_equal(F.step_name[F.steps - 2], "close");
    assert_string_equal(F.step_name[F.steps - 1], "rename");
    assert_string_equal(F.step_name[F.steps], "sync directory");
    for (unsigned long s = 2; s < F.steps - 5; s++)
        assert_string_equal(F.step_name[s], "write");
    print_message("one save of %zu bytes: %lu I/O steps\n", F.big_len, F.steps);
}

static void test_fail_every_step(void **state)
{
    (void)state;
    static const int errs[] = {ENOSPC, EIO};
    unsigned swept = 0;
    for (int prior = 0; prior < 2; prior++)
        for (size_t e = 0; e < sizeof errs / sizeof errs[0]; e++)
            for (unsigned long at = 1; at <= F.steps; at++) {
                set_prior(prior);
                fault f = {at, errs[e]};
                lrr__context_set_io_hook(F.ctx, inject, &f);
                lrr_status st = lrr_operator_save(F.big, F.path);
                lrr__context_set_io_hook(F.ctx, NULL, NULL);
                char msg[512];
                lrr_status rec = lrr_context_last_error(F.ctx, msg, sizeof msg);
                const char *what = F.step_name[at];
                char when[128];
                snprintf(when, sizeof when, "%s at step %lu (%s)", strerror(errs[e]), at, what);
                if (at == F.steps) {
                    /* after the rename: the directory sync is best effort */
                    assert_int_equal(st, LRR_OK);
                    assert_int_equal(final_state(when), 2);
                } else {
                    if (st != LRR_ERR_IO || rec != LRR_ERR_IO)
                        fail_msg("%s: returned %s", when, lrr_strerror(st));
                    if (!strstr(msg, F.path) || !strstr(msg, strerror(errs[e])) ||
                        !strstr(msg, step_phrase(what)))
                        fail_msg("%s: message \"%s\" does not name the path, the step and the "
                                 "cause",
                                 when, msg);
                    assert_int_equal(final_state(when), prior);
                }
                if (temp_files(NULL, 0) != 0)
                    fail_msg("%s: a temporary file was left behind", when);
                swept++;
            }
    print_message("failed saves: %u (every step of %lu, ENOSPC and EIO, with and without an "
                  "old file)\n",
                  swept, F.steps);
}

/* A sparse operator, saved as strips (version 5, lib/file/strips.c, whose pieces go through
 * the same writer): every I/O step of its save fails in turn; the final name then holds
 * nothing (or, once renamed, the complete file) and no temporary file remains. */
static void test_fail_every_step_strips(void **state)
{
    (void)state;
    lrr_operator *op = made_up(500, 1, 1.0f);
    for (size_t i = 0; i < op->n * op->k; i++) /* one column in 16 per tile of 16 rows */
        if ((i % op->k) % 16 != (i / op->k / 16) % 16)
            op->fbar[i] = 0.0f;
    const unsigned long big_steps = F.steps;
    set_prior(0);
    lrr__context_set_io_hook(F.ctx, record_steps, NULL);
    LRR_CHECK(F.ctx, lrr_operator_save(op, F.path));
    lrr__context_set_io_hook(F.ctx, NULL, NULL);
    const unsigned long steps = F.steps;
    F.steps = big_steps;
    size_t len, got_len;
    unsigned char *want = slurp(F.path, &len);
    assert_non_null(want);
    assert_int_equal(want[8], 5);
    assert_true(steps >= 8);
    for (unsigned long at = 1; at <= steps; at++) {
        set_prior(0);
        fault f = {at, ENOSPC};
        lrr__context_set_io_hook(F.ctx, inject, &f);
        lrr_status st = lrr_operator_save(op, F.path);
        lrr__context_set_io_hook(F.ctx, NULL, NULL);
        char msg[512];
        lrr_context_last_error(F.ctx, msg, sizeof msg);
        unsigned char *got = slurp(F.path, &got_len);
        if (at == steps) { /* the directory sync after the rename is best effort */
            assert_int_equal(st, LRR_OK);
            assert_true(got && got_len == len && memcmp(got, want, len) == 0);
        } else if (st != LRR_ERR_IO || got || !strstr(msg, F.path) ||
                   !strstr(msg, strerror(ENOSPC))) {
            fail_msg("strips, ENOSPC at step %lu: %s, \"%s\", %s", at, lrr_strerror(st), msg,
                     got ? "a file under the final name" : "no file");
        }
        if (temp_files(NULL, 0) != 0)
            fail_msg("strips, ENOSPC at step %lu: a temporary file was left behind", at);
        free(got);
    }
    print_message("failed sparse saves: %lu (every step)\n", steps);
    remove(F.path);
    free(want);
    lrr_operator_destroy(op);
}

/* Runs fn in a child and returns its wait status; the child's status and message come back
 * through a pipe into *st and msg. */
typedef lrr_status (*child_fn)(void *arg);
static int in_child(child_fn fn, void *arg, lrr_status *st, char *msg, size_t len)
{
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    fflush(NULL);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        close(fds[0]);
        lrr_status s = fn(arg);
        char m[512];
        lrr_context_last_error(F.ctx, m, sizeof m);
        int code = (int)s;
        if (write(fds[1], &code, sizeof code) != sizeof code ||
            write(fds[1], m, strlen(m) + 1) < 0)
            _exit(2);
        _exit(0);
    }
    close(fds[1]);
    int code = -1;
    ssize_t got = read(fds[0], &code, sizeof code);
    size_t used = 0;
    ssize_t r;
    msg[0] = '\0';
    while (used + 1 < len && (r = read(fds[0], msg + used, len - used - 1)) > 0)
        used += (size_t)r;
    msg[used] = '\0';
    close(fds[0]);
    int status;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    *st = got == sizeof code ? (lrr_status)code : (lrr_status)-1;
    return status;
}

static lrr_status save_limited(void *arg)
{
    rlim_t limit = *(const rlim_t *)arg;
    signal(SIGXFSZ, SIG_IGN);
    struct rlimit rl;
    getrlimit(RLIMIT_FSIZE, &rl);
    rl.rlim_cur = limit;
    if (setrlimit(RLIMIT_FSIZE, &rl) != 0)
        return (lrr_status)100;
    return lrr_operator_save(F.big, F.path);
}

static void test_file_size_limit(void **state)
{
    (void)state;
    const rlim_t limits[] = {0, 1, 64, 4095, 4096, 65536, 1 << 20, F.big_len / 2,
                             F.big_len - 4096, F.big_len - 1, F.big_len};
    unsigned swept = 0;
    for (int prior = 0; prior < 2; prior++)
        for (size_t i = 0; i < sizeof limits / sizeof limits[0]; i++) {
            set_prior(prior);
            lrr_status st;
            char msg[512], when[96];
            int status = in_child(save_limited, (void *)&limits[i], &st, msg, sizeof msg);
            snprintf(when, sizeof when, "file-size limit %llu", (unsigned long long)limits[i]);
            assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
            if (limits[i] >= F.big_len) {
                assert_int_equal(st, LRR_OK);
                assert_int_equal(final_state(when), 2);
            } else {
                if (st != LRR_ERR_IO || !strstr(msg, F.path) || !strstr(msg, strerror(EFBIG)))
                    fail_msg("%s: %s, \"%s\"", when, lrr_strerror(st), msg);
                assert_int_equal(final_state(when), prior);
            }
            assert_int_equal(temp_files(NULL, 0), 0);
            swept++;
        }
    print_message("file-size limits: %u saves, EFBIG named in every failure\n", swept);
}

static lrr_status save_killed(void *arg)
{
    lrr__context_set_io_hook(F.ctx, inject, arg);
    return lrr_operator_save(F.big, F.path);
}

/* After a kill: the final name holds the old or the new file whole; a temporary file left
 * behind holds a prefix of the new file (what reached the kernel before the kill). */
static int check_after_kill(const char *when, int prior)
{
    int state = final_state(when);
    if (state != prior && state != 2)
        fail_msg("%s: the final name went from state %d to %d", when, prior, state);
    char tmp[512];
    int temps = temp_files(tmp, sizeof tmp);
    assert_true(temps <= 1);
    if (temps) {
        size_t len;
        unsigned char *b = slurp(tmp, &len);
        assert_non_null(b);
        if (len > F.big_len || memcmp(b, F.big_bytes, len) != 0)
            fail_msg("%s: the temporary file (%zu bytes) is not a prefix of the file", when,
                     len);
        free(b);
        assert_int_equal(remove(tmp), 0);
    }
    if (state) {
        /* and it loads */
        lrr_operator *op;
        LRR_CHECK(F.ctx, lrr_operator_load(F.ctx, F.path, &op));
        lrr_operator_destroy(op);
    }
    return temps;
}

static void test_kill_every_step(void **state)
{
    (void)state;
    unsigned swept = 0, left = 0;
    for (int prior = 0; prior < 2; prior++)
        for (unsigned long at = 1; at <= F.steps; at++) {
            set_prior(prior);
            fault f = {at, 0};
            lrr_status st;
            char msg[512], when[96];
            int status = in_child(save_killed, &f, &st, msg, sizeof msg);
            snprintf(when, sizeof when, "SIGKILL at step %lu (%s)", at, F.step_name[at]);
            if (!WIFSIGNALED(status) || WTERMSIG(status) != SIGKILL)
                fail_msg("%s: the child was not killed (status %d)", when, status);
            int temps = check_after_kill(when, prior);
            /* before the rename: the old state; after it (the directory sync): the new file */
            int want = at == F.steps ? 2 : prior;
            assert_int_equal(final_state(when), want);
            /* a temporary file exists from its creation to the rename */
            assert_int_equal(temps, at > 1 && at < F.steps);
            left += (unsigned)temps;
            swept++;
        }
    print_message("killed saves: %u (every step, with and without an old file); %u left a "
                  "temporary file behind\n",
                  swept, left);
}

static lrr_status save_forever(void *arg)
{
    (void)arg;
    for (;;) {
        lrr_status st = lrr_operator_save(F.big, F.path);
        if (st)
            return st;
    }
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static void test_kill_random(void **state)
{
    (void)state;
    /* one save's duration sets the range of the kill times */
    set_prior(0);
    double t0 = now();
    LRR_CHECK(F.ctx, lrr_operator_save(F.big, F.path));
    double save_s = now() - t0;
    unsigned seen[3] = {0, 0, 0}, left = 0;
    srand(12345);
    const int kills = 12;
    for (int i = 0; i < kills; i++) {
        int prior = i % 2;
        set_prior(prior);
        fflush(NULL);
        pid_t pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
            save_forever(NULL);
            _exit(1);
        }
        double wait_s = 3.5 * save_s * (double)rand() / RAND_MAX;
        struct timespec ts = {(time_t)wait_s, (long)(1e9 * (wait_s - (time_t)wait_s))};
        nanosleep(&ts, NULL);
        assert_int_equal(kill(pid, SIGKILL), 0);
        int status;
        assert_int_equal(waitpid(pid, &status, 0), pid);
        char when[96];
        snprintf(when, sizeof when, "SIGKILL after %.1f ms", 1e3 * wait_s);
        if (!WIFSIGNALED(status) || WTERMSIG(status) != SIGKILL)
            fail_msg("%s: the child ended otherwise (status %d)", when, status);
        left += (unsigned)check_after_kill(when, prior);
        seen[final_state(when)]++;
    }
    print_message("random kills: %d (one save takes %.1f ms): final name absent %u, old %u, "
                  "new %u; %u temporary files left behind\n",
                  kills, 1e3 * save_s, seen[0], seen[1], seen[2], left);
}

static lrr_status save_as_nobody(void *arg)
{
    const char *path = arg;
    if (geteuid() == 0 && (setgid(65534) != 0 || setuid(65534) != 0))
        return (lrr_status)101;
    return lrr_operator_save(F.small, path);
}

static void test_read_only_dir(void **state)
{
    (void)state;
    /* under /tmp (mode 1777) so that uid 65534 can reach it */
    char dir[64] = "/tmp/lrr_readonly_XXXXXX", path[96];
    assert_non_null(mkdtemp(dir));
    assert_int_equal(chmod(dir, 0555), 0);
    snprintf(path, sizeof path, "%s/op.lrr", dir);
    lrr_status st;
    char msg[512];
    int status = in_child(save_as_nobody, path, &st, msg, sizeof msg);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    if (st == (lrr_status)101) {
        rmdir(dir);
        print_message("read-only directory: cannot drop root privileges here, skipped\n");
        skip();
    }
    if (st != LRR_ERR_IO || !strstr(msg, path) || !strstr(msg, strerror(EACCES)) ||
        !strstr(msg, "cannot create temporary file"))
        fail_msg("read-only directory: %s, \"%s\"", lrr_strerror(st), msg);
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *e;
    int entries = 0;
    while ((e = readdir(d)))
        entries += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    assert_int_equal(entries, 0);
    assert_int_equal(rmdir(dir), 0);
    print_message("read-only directory: %s\n", msg);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_steps),           cmocka_unit_test(test_fail_every_step),
        cmocka_unit_test(test_fail_every_step_strips),
        cmocka_unit_test(test_file_size_limit), cmocka_unit_test(test_kill_every_step),
        cmocka_unit_test(test_kill_random),     cmocka_unit_test(test_read_only_dir),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
