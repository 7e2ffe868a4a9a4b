/*
 * Fuzz target: the light-probe loaders (lrr_probe_load): Radiance RGBE through stb_image and
 * OpenEXR through lib/probe/exr.cpp, then the cheap whole-probe reductions on what loaded.
 * An input starting with OpenEXR's magic number (76 2f 31 01) is written as probe.exr (the
 * loader picks OpenEXR by the extension), anything else as probe.hdr.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "lrr.h"

#define MAX_INPUT (256u << 10)

static void use_probe(const lrr_probe *probe)
{
    size_t w = 0, h = 0;
    lrr_probe_size(probe, &w, &h);
    if (h == 0 || w != 2 * h)
        fuzz_fail("a loaded probe of %zu×%zu pixels", w, h);
    float sh[27];
    lrr_status st = lrr_probe_sh9(probe, sh);
    if (st != LRR_OK && st != LRR_ERR_INVALID_ARG) /* radiances near FLT_MAX overflow */
        fuzz_fail("lrr_probe_sh9 failed on a loaded probe: %s", lrr_strerror(st));
    for (int i = 0; st == LRR_OK && i < 27; i++)
        if (!isfinite(sh[i]))
            fuzz_fail("SH9 coefficient %d is %g", i, (double)sh[i]);
    lrr_light lights[4];
    if (w * h >= 4 && lrr_probe_median_cut(probe, 4, lights) != LRR_OK)
        fuzz_fail("lrr_probe_median_cut failed on a loaded probe");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_init();
    if (size > MAX_INPUT)
        return 0;
    static const uint8_t exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
    const char *name = size >= 4 && memcmp(data, exr_magic, 4) == 0 ? "probe.exr" : "probe.hdr";
    const char *path = fuzz_write(name, data, size);

    lrr_context *ctx = NULL;
    if (lrr_context_create(&ctx) != LRR_OK)
        fuzz_fail("lrr_context_create failed");
    lrr_probe *probe = NULL;
    lrr_status st = lrr_probe_load(ctx, path, &probe);
    char msg[512];
    lrr_status recorded = lrr_context_last_error(ctx, msg, sizeof msg);
    if (st == LRR_OK) {
        if (!probe)
            fuzz_fail("lrr_probe_load returned LRR_OK without a probe");
        use_probe(probe);
    } else if (probe || recorded == LRR_OK || !msg[0]) {
        fuzz_fail("lrr_probe_load failed (%s) %s", lrr_strerror(st),
                  probe ? "but returned a probe" : "without a message");
    }
    lrr_probe_destroy(probe);
    lrr_context_destroy(ctx);
    fuzz_remove(name);
    return 0;
}
