/* Textured materials within the scene stage (texture.c; docs/METHOD.md "Textures"): a
 * texture is linear RGB already multiplied by its material's factor (reflectance textures
 * also clamped below 1), and a textured triangle carries the UVs of its corners. Only
 * scene.c, import.c and texture.c see this; later stages get per-subpatch rho and E from
 * lrr_scene_subpatches. */
#ifndef LRR_SCENE_TEXTURE_H
#define LRR_SCENE_TEXTURE_H

#include "scene/scene.h"

/* glTF sampler wrap modes (assimp's aiTextureMapMode Wrap, Clamp, Mirror). */
enum { LRR__WRAP_REPEAT = 0, LRR__WRAP_CLAMP = 1, LRR__WRAP_MIRROR = 2 };
#define LRR__NO_TEXTURE UINT32_MAX
/* The largest reflectance the scene accepts: the float just below 1. */
#define LRR__RHO_MAX 0x1.fffffep-1f

typedef struct lrr__texture {
    size_t w, h;
    float *rgb;   /* w×h×3, row 0 at the top of the image (v = 1) */
    int wrap[2];  /* LRR__WRAP_* along u and v */
} lrr__texture;

/* Per triangle (the scene's kept triangles, in order): which texture gives rho and E (or
 * LRR__NO_TEXTURE: the flat colour) and the (u, v) of each corner. */
struct lrr__scene_textures {
    size_t n_tex;
    lrr__texture *tex;
    size_t n_tri;
    float *uv;              /* n_tri×6 */
    uint32_t *rho_tex;      /* n_tri */
    uint32_t *em_tex;       /* n_tri */
    size_t clamped_texels;  /* reflectance texels with a channel (× factor) >= 1, clamped */
};

void lrr__scene_textures_free(lrr__scene_textures *t);

/* Decodes an image (PNG, JPEG, … through stb_image) from memory into linear RGB times
 * factor[3]: 8- and 16-bit images are sRGB-decoded, Radiance .hdr is taken as linear. With
 * clamp, values >= 1 become LRR__RHO_MAX, and texels with such a channel are counted in
 * *clamped. `what` names the
 * texture in errors (file, material). */
lrr_status lrr__texture_decode(lrr_context *ctx, const unsigned char *data, size_t len,
                               const float factor[3], bool clamp, const char *what,
                               lrr__texture *out, size_t *clamped);
/* Same from an uncompressed BGRA8 array (assimp's embedded raw textures), sRGB. */
lrr_status lrr__texture_from_bgra(lrr_context *ctx, const unsigned char *bgra, size_t w,
                                  size_t h, const float factor[3], bool clamp,
                                  const char *what, lrr__texture *out, size_t *clamped);

/* The mean of the texture over the UV triangle uv[6] (texels as constant squares, wrapped),
 * in double: exact texel-area integration when the triangle's bounding box covers at most
 * LRR__TEXEL_EXACT_MAX texels, else the midpoint rule on LRR__TEXEL_SAMPLES² equal
 * sub-triangles; both cost about 4096 texel visits at most, so a subpatch costs ~0.1 ms
 * whatever its texture. */
#define LRR__TEXEL_EXACT_MAX 4096
#define LRR__TEXEL_SAMPLES 64
/* Images beyond 8192² texels are refused (decoding one takes 4 + 12 bytes a texel). */
#define LRR__TEXELS_MAX (1u << 26)
void lrr__texture_mean(const lrr__texture *t, const double uv[6], double out[3]);
/* Always exact, whatever the texel count (for the tests' accuracy figure). */
void lrr__texture_mean_exact(const lrr__texture *t, const double uv[6], double out[3]);
/* Same, forcing the midpoint rule with m² sub-triangles (for the tests' accuracy figure). */
void lrr__texture_mean_sampled(const lrr__texture *t, const double uv[6], unsigned m,
                               double out[3]);

/* The UV triangle of the quadtree node `local` at `depth` of a triangle with corner UVs
 * uv[6] (the same child order as the geometry, scene.h). */
void lrr__subtriangle_uv(const float uv[6], unsigned depth, size_t local, double out[6]);

/* Takes ownership of *t (zeroed): per input triangle arrays of n_in triangles (vert_in as
 * given to lrr__scene_from_arrays) are reduced to the triangles the scene kept. On failure
 * *t is freed. */
lrr_status lrr__scene_attach_textures(lrr_scene *s, size_t n_in, const float *vert_in,
                                      lrr__scene_textures *t);
#endif
