/* Status codes, error records, callbacks, versions and checked allocation. */
#include "testutil.h"
#include "core/internal.h"

#include <stdint.h>

static void test_strerror(void **state)
{
    (void)state;
    for (int a = LRR_OK; a <= LRR_ERR_BUDGET; a++) {
        const char *sa = lrr_strerror((lrr_status)a);
        assert_non_null(sa);
        assert_string_not_equal(sa, "unknown status");
        for (int b = a + 1; b <= LRR_ERR_BUDGET; b++)
            assert_string_not_equal(sa, lrr_strerror((lrr_status)b));
    }
    assert_string_equal(lrr_strerror((lrr_status)999), "unknown status");
}

typedef struct {
    int calls;
    lrr_status last;
    char msg[256];
} cb_record;

static void record(void *user, lrr_status st, const char *msg)
{
    cb_record *r = user;
    r->calls++;
    r->last = st;
    snprintf(r->msg, sizeof r->msg, "%s", msg);
}

static void test_error_record(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    char msg[64];
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_OK);
    assert_string_equal(msg, "");
    /* the first error since the last read is kept; later ones only reach the callback */
    assert_int_equal(lrr__error(ctx, LRR_ERR_IO, "first %d", 1), LRR_ERR_IO);
    cb_record r = {0};
    lrr_context_set_error_callback(ctx, record, &r);
    assert_int_equal(lrr__error(ctx, LRR_ERR_DIM, "second %s", "x"), LRR_ERR_DIM);
    assert_int_equal(r.calls, 1);
    assert_int_equal(r.last, LRR_ERR_DIM);
    assert_string_equal(r.msg, "second x");
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_IO);
    assert_string_equal(msg, "first 1");
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_OK);
    /* truncation of a long message keeps it NUL-terminated */
    char big[600];
    memset(big, 'a', sizeof big - 1);
    big[sizeof big - 1] = '\0';
    lrr__error(ctx, LRR_ERR_FORMAT, "%s", big);
    char small[8];
    assert_int_equal(lrr_context_last_error(ctx, small, sizeof small), LRR_ERR_FORMAT);
    assert_int_equal(strlen(small), 7);
    /* callback off */
    lrr_context_set_error_callback(ctx, NULL, NULL);
    lrr__error(ctx, LRR_ERR_IO, "x");
    assert_int_equal(r.calls, 2);
    lrr_context_destroy(ctx);
    lrr_context_destroy(NULL);
}

/* Objects keep their context alive: destroying the context first is fine. */
static void test_reference_counting(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_context_destroy(ctx);
    lrr_subdivision bad = {.levels = 42};
    assert_int_equal(lrr_scene_subdivide(s, &bad), LRR_ERR_INVALID_ARG);
    lrr_scene_destroy(s);
}

static void test_version(void **state)
{
    (void)state;
    assert_string_equal(lrr_version_string(), LRR_VERSION_STRING);
    assert_int_equal(lrr_version(), LRR_VERSION);
    assert_int_equal(LRR_VERSION, LRR_VERSION_MAJOR * 10000 + LRR_VERSION_MINOR * 100 +
                                      LRR_VERSION_PATCH);
}

static void test_alloc(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    void *p;
    assert_int_equal(lrr__calloc(ctx, &p, SIZE_MAX / 2, 4, "huge"), LRR_ERR_OVERFLOW);
    assert_null(p);
    char msg[256];
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_OVERFLOW);
    assert_non_null(strstr(msg, "huge"));
    assert_int_equal(lrr__calloc(ctx, &p, (size_t)1 << 61, 1, "too big"), LRR_ERR_NOMEM);
    assert_int_equal(lrr__calloc(ctx, &p, 100, 3, "small"), LRR_OK);
    assert_int_equal((uintptr_t)p % 64, 0);
    for (int i = 0; i < 300; i++)
        assert_int_equal(((unsigned char *)p)[i], 0);
    lrr_aligned_free(p);
    assert_null(lrr_aligned_alloc(0));
    void *q = lrr_aligned_alloc(1);
    assert_int_equal((uintptr_t)q % 64, 0);
    lrr_aligned_free(q);
    lrr_aligned_free(NULL);
    size_t out;
    assert_false(lrr__mul_size(SIZE_MAX, 2, &out));
    assert_true(lrr__mul_size(3, 5, &out));
    assert_int_equal(out, 15);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_strerror),
        cmocka_unit_test(test_error_record),
        cmocka_unit_test(test_reference_counting),
        cmocka_unit_test(test_version),
        cmocka_unit_test(test_alloc),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
