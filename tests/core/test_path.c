/* Every path the library opens for reading is checked before it can block: a FIFO without a
 * writer, /dev/zero and a directory are refused at once with "not a regular file" (or the
 * directory's own words), by lrr__open_regular itself and by each opener that uses it:
 * scene files, the files assimp opens for them (.mtl, .bin), textures, .lrr files and light
 * probes. alarm() turns a regression (open() waiting for a writer) into a failure. */
#include "testutil.h"
#include "core/path.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

/* A test that blocks more than this is killed by SIGALRM; each one takes milliseconds. */
#define HANG_SECONDS 20

typedef struct scratch {
    char dir[512];
    lrr_context *ctx;
} scratch;

static void at(const scratch *s, const char *name, char *buf, size_t len)
{
    snprintf(buf, len, "%s/%s", s->dir, name);
}

static void write_text(const scratch *s, const char *name, const char *text)
{
    char p[640];
    at(s, name, p, sizeof p);
    FILE *f = fopen(p, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

static void make_fifo(const scratch *s, const char *name)
{
    char p[640];
    at(s, name, p, sizeof p);
    assert_int_equal(mkfifo(p, 0600), 0);
}

static int setup(void **state)
{
    scratch *s = calloc(1, sizeof *s);
    assert_non_null(s);
    tu_tmp_path(s->dir, sizeof s->dir, "test_path");
    assert_int_equal(mkdir(s->dir, 0700), 0);
    assert_int_equal(lrr_context_create(&s->ctx), LRR_OK);
    *state = s;
    alarm(HANG_SECONDS);
    return 0;
}

static int teardown(void **state)
{
    scratch *s = *state;
    alarm(0);
    static const char *const names[] = {"f.obj", "f.lrr", "f.hdr", "f.exr", "f.gltf",
                                        "m.obj", "m.mtl", "t.obj", "t.mtl", "t.png",
                                        "b.gltf", "b.bin", "r.txt", "d", "sock"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
        char p[640];
        at(s, names[i], p, sizeof p);
        remove(p);
    }
    assert_int_equal(rmdir(s->dir), 0);
    lrr_context_destroy(s->ctx);
    free(s);
    return 0;
}

/* status and a message holding each of want1 and want2 (NULL: not checked) */
static void expect_error(lrr_context *ctx, lrr_status got, lrr_status want, const char *want1,
                         const char *want2)
{
    assert_int_equal(got, want);
    char msg[1024];
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), want);
    if (want1 && !strstr(msg, want1))
        fail_msg("'%s' does not say '%s'", msg, want1);
    if (want2 && !strstr(msg, want2))
        fail_msg("'%s' does not say '%s'", msg, want2);
}

static void test_helper(void **state)
{
    scratch *s = *state;
    char p[640];
    FILE *f = (FILE *)1;
    make_fifo(s, "f.obj");
    at(s, "f.obj", p, sizeof p);
    assert_int_equal(lrr__open_regular(p, &f, NULL), LRR__NOT_REGULAR);
    assert_null(f);
    assert_int_equal(lrr__stat_regular(p, NULL), LRR__NOT_REGULAR);
    assert_int_equal(lrr__open_regular("/dev/zero", &f, NULL), LRR__NOT_REGULAR);
    assert_int_equal(lrr__stat_regular("/dev/null", NULL), LRR__NOT_REGULAR);
    at(s, "d", p, sizeof p);
    assert_int_equal(mkdir(p, 0700), 0);
    assert_int_equal(lrr__open_regular(p, &f, NULL), EISDIR);
    assert_int_equal(lrr__stat_regular(p, NULL), EISDIR);
    /* a socket: open() fails (ENXIO), the same words all the same */
    at(s, "sock", p, sizeof p);
    int sk = socket(AF_UNIX, SOCK_STREAM, 0);
    assert_true(sk >= 0);
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    if (strlen(p) < sizeof sa.sun_path) {
        memcpy(sa.sun_path, p, strlen(p) + 1);
        assert_int_equal(bind(sk, (const struct sockaddr *)&sa, sizeof sa), 0);
        assert_int_equal(lrr__open_regular(p, &f, NULL), LRR__NOT_REGULAR);
        assert_int_equal(lrr__stat_regular(p, NULL), LRR__NOT_REGULAR);
        remove(p);
    }
    close(sk);
    at(s, "missing", p, sizeof p);
    assert_int_equal(lrr__open_regular(p, &f, NULL), ENOENT);
    /* a regular file opens, blocking reads (O_NONBLOCK cleared), its size in st */
    write_text(s, "r.txt", "abc");
    at(s, "r.txt", p, sizeof p);
    struct stat st;
    assert_int_equal(lrr__open_regular(p, &f, &st), 0);
    assert_int_equal(st.st_size, 3);
    char buf[4] = "";
    assert_int_equal(fread(buf, 1, 3, f), 3);
    assert_string_equal(buf, "abc");
    assert_int_equal(fcntl(fileno(f), F_GETFL) & O_NONBLOCK, 0);
    fclose(f);
}

static void test_operator_file(void **state)
{
    scratch *s = *state;
    char p[640];
    make_fifo(s, "f.lrr");
    at(s, "f.lrr", p, sizeof p);
    lrr_operator *op = NULL;
    expect_error(s->ctx, lrr_operator_load(s->ctx, p, &op), LRR_ERR_IO, p,
                 LRR__NOT_REGULAR_TEXT);
    expect_error(s->ctx, lrr_operator_load(s->ctx, "/dev/zero", &op), LRR_ERR_IO, "/dev/zero",
                 LRR__NOT_REGULAR_TEXT);
    assert_null(op);
}

static void test_scene_files(void **state)
{
    scratch *s = *state;
    TU_REQUIRE("assimp");
    char p[640];
    lrr_scene *sc = NULL;
    static const char *const fifos[] = {"f.obj", "f.gltf"};
    for (size_t i = 0; i < 2; i++) {
        make_fifo(s, fifos[i]);
        at(s, fifos[i], p, sizeof p);
        expect_error(s->ctx, lrr_scene_load(s->ctx, p, &sc), LRR_ERR_IO, p,
                     LRR__NOT_REGULAR_TEXT);
    }
    expect_error(s->ctx, lrr_scene_load(s->ctx, "/dev/zero", &sc), LRR_ERR_IO, "/dev/zero",
                 LRR__NOT_REGULAR_TEXT);
    assert_null(sc);
}

static const char quad_obj[] = "mtllib %s.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\n"
                               "vt 1 0\nvt 1 1\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3 4/4\n";

/* The files a scene names: assimp opens the .mtl and the .bin, lrr the texture. */
static void test_named_files(void **state)
{
    scratch *s = *state;
    TU_REQUIRE("assimp");
    char text[512], p[640];
    lrr_scene *sc = NULL;
    snprintf(text, sizeof text, quad_obj, "m");
    write_text(s, "m.obj", text);
    make_fifo(s, "m.mtl");
    at(s, "m.obj", p, sizeof p);
    expect_error(s->ctx, lrr_scene_load(s->ctx, p, &sc), LRR_ERR_IO, "m.mtl",
                 LRR__NOT_REGULAR_TEXT);

    snprintf(text, sizeof text, quad_obj, "t");
    write_text(s, "t.obj", text);
    write_text(s, "t.mtl", "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\nmap_Kd t.png\n");
    make_fifo(s, "t.png");
    at(s, "t.obj", p, sizeof p);
    expect_error(s->ctx, lrr_scene_load(s->ctx, p, &sc), LRR_ERR_IO, "t.png",
                 LRR__NOT_REGULAR_TEXT);

    write_text(s, "b.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"b.bin\","
               "\"byteLength\":36}],\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
               "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,"
               "\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}],\"meshes\":[{"
               "\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],\"nodes\":[{\"mesh\":0}],"
               "\"scenes\":[{\"nodes\":[0]}],\"scene\":0}");
    make_fifo(s, "b.bin");
    at(s, "b.gltf", p, sizeof p);
    expect_error(s->ctx, lrr_scene_load(s->ctx, p, &sc), LRR_ERR_IO, "b.bin",
                 LRR__NOT_REGULAR_TEXT);
    assert_null(sc);
}

static void test_probes(void **state)
{
    scratch *s = *state;
    char p[640];
    lrr_probe *pr = NULL;
    make_fifo(s, "f.hdr");
    at(s, "f.hdr", p, sizeof p);
    expect_error(s->ctx, lrr_probe_load(s->ctx, p, &pr), LRR_ERR_IO, p, LRR__NOT_REGULAR_TEXT);
    if (tu_has_feature("openexr")) {
        make_fifo(s, "f.exr");
        at(s, "f.exr", p, sizeof p);
        expect_error(s->ctx, lrr_probe_load(s->ctx, p, &pr), LRR_ERR_IO, p,
                     LRR__NOT_REGULAR_TEXT);
    }
    expect_error(s->ctx, lrr_probe_load(s->ctx, "/dev/zero", &pr), LRR_ERR_IO, "/dev/zero",
                 LRR__NOT_REGULAR_TEXT);
    assert_null(pr);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_helper, setup, teardown),
        cmocka_unit_test_setup_teardown(test_operator_file, setup, teardown),
        cmocka_unit_test_setup_teardown(test_scene_files, setup, teardown),
        cmocka_unit_test_setup_teardown(test_named_files, setup, teardown),
        cmocka_unit_test_setup_teardown(test_probes, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
