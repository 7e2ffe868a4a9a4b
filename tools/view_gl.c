/* The viewer's OpenGL 3.3 core half: every subpatch a triangle of its own whose colour is
 * its radiosity, fetched in the fragment shader from a texture buffer (one upload of n×3
 * floats per relight, no per-vertex expansion), tone mapped as lrr render's PNGs (exposure,
 * the extended Reinhard curve white at 6 (lib/output/render.c TONE_WHITE), the sRGB curve:
 * the automatic exposure's 0.18 key then looks the same in both). Drawn offscreen, so a screenshot never depends on the
 * window being mapped (Xvfb, hidden windows), then blitted to the window. */
#include "view_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* every stb function static: no symbol clashes with the copy liblrr links */
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-prototypes"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wsign-compare"
#include <stb_image_write.h>
#pragma GCC diagnostic pop

/* Colours come from a texture buffer of RGB triples (R32F: GL 3.3 has no RGB32F buffer
 * format): flat, triple gl_VertexID / 3 (the subpatch's B); smooth, the vertex's welded
 * corner, interpolated across the triangle. */
static const char scene_vs[] =
    "#version 330 core\n"
    "layout(location = 0) in vec3 pos;\n"
    "layout(location = 1) in uint corner;\n"
    "uniform mat4 mvp;\n"
    "uniform int smooth_on;\n"
    "uniform samplerBuffer bsamp;\n"
    "out vec3 b;\n"
    "void main() {\n"
    "  int t = 3 * (smooth_on != 0 ? int(corner) : gl_VertexID / 3);\n"
    "  b = vec3(texelFetch(bsamp, t).r, texelFetch(bsamp, t + 1).r, texelFetch(bsamp, t + 2).r);\n"
    "  gl_Position = mvp * vec4(pos, 1.0);\n"
    "}\n";

static const char scene_fs[] =
    "#version 330 core\n"
    "in vec3 b;\n"
    "uniform float exposure;\n"
    "out vec4 frag;\n"
    "void main() {\n"
    "  vec3 x = exposure * b;\n"
    "  vec3 c = clamp(x * (1.0 + x / 36.0) / (1.0 + x), 0.0, 1.0);\n"
    "  vec3 s = mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055,\n"
    "               step(vec3(0.0031308), c));\n"
    "  frag = vec4(s, 1.0);\n"
    "}\n";

static const char marker_vs[] =
    "#version 330 core\n"
    "layout(location = 0) in vec3 pos;\n"
    "uniform mat4 mvp;\n"
    "void main() { gl_Position = mvp * vec4(pos, 1.0); gl_PointSize = 9.0; }\n";

static const char marker_fs[] =
    "#version 330 core\n"
    "uniform vec3 colour;\n"
    "out vec4 frag;\n"
    "void main() { frag = vec4(colour, 1.0); }\n";

static GLuint compile(GLenum kind, const char *src)
{
    GLuint s = glCreateShader(kind);
    glShaderSource(s, 1, &src, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[1024] = "";
        glGetShaderInfoLog(s, sizeof log, NULL, log);
        fprintf(stderr, "lrr view: a shader does not compile: %s\n", log);
        glDeleteShader(s);
        return 0;
    }
    return s;
}

static GLuint program(const char *vs, const char *fs)
{
    GLuint v = compile(GL_VERTEX_SHADER, vs), f = compile(GL_FRAGMENT_SHADER, fs), p = 0;
    if (v && f) {
        p = glCreateProgram();
        glAttachShader(p, v);
        glAttachShader(p, f);
        glLinkProgram(p);
        GLint ok = 0;
        glGetProgramiv(p, GL_LINK_STATUS, &ok);
        if (!ok) {
            char log[1024] = "";
            glGetProgramInfoLog(p, sizeof log, NULL, log);
            fprintf(stderr, "lrr view: the shaders do not link: %s\n", log);
            glDeleteProgram(p);
            p = 0;
        }
    }
    glDeleteShader(v);
    glDeleteShader(f);
    return p;
}

/* (Re)allocates the offscreen colour and depth buffers at w×h; 0 or -1. */
static int resize_fbo(view_gl *g, int w, int h)
{
    glBindRenderbuffer(GL_RENDERBUFFER, g->color_rb);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
    glBindRenderbuffer(GL_RENDERBUFFER, g->depth_rb);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
    glBindFramebuffer(GL_FRAMEBUFFER, g->fbo);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g->color_rb);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, g->depth_rb);
    int ok = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (!ok) {
        fprintf(stderr, "lrr view: a %d×%d offscreen framebuffer is not supported\n", w, h);
        return -1;
    }
    g->fb_w = w;
    g->fb_h = h;
    return 0;
}

/* The triangles and their corners' ids into vertex buffers, the colour texture buffer
 * (room for the larger of n and m triples); 0 or -1. */
static int upload_mesh(view_gl *g, const float *vtx, const uint32_t *corner, size_t m)
{
    GLint max_texels = 0;
    glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &max_texels);
    g->texels = g->n > m ? g->n : m;
    if ((double)max_texels < 3.0 * g->texels) {
        fprintf(stderr, "lrr view: %zu colours need a texture buffer of %zu texels; this "
                        "GL allows %d\n", g->texels, 3 * g->texels, (int)max_texels);
        return -1;
    }
    glGenVertexArrays(1, &g->vao);
    glBindVertexArray(g->vao);
    glGenBuffers(1, &g->vbo);
    glBindBuffer(GL_ARRAY_BUFFER, g->vbo);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(g->n * 9 * sizeof *vtx), vtx, GL_STATIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, NULL);
    glGenBuffers(1, &g->corner_vbo);
    glBindBuffer(GL_ARRAY_BUFFER, g->corner_vbo);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(g->n * 3 * sizeof *corner), corner,
                 GL_STATIC_DRAW);
    glEnableVertexAttribArray(1);
    glVertexAttribIPointer(1, 1, GL_UNSIGNED_INT, 0, NULL);
    glGenBuffers(1, &g->bbuf);
    glBindBuffer(GL_TEXTURE_BUFFER, g->bbuf);
    glBufferData(GL_TEXTURE_BUFFER, (GLsizeiptr)(g->texels * 3 * sizeof(float)), NULL,
                 GL_DYNAMIC_DRAW);
    glGenTextures(1, &g->btex);
    glBindTexture(GL_TEXTURE_BUFFER, g->btex);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_R32F, g->bbuf);
    return glGetError() == GL_NO_ERROR ? 0 : -1;
}

int view_gl_init(view_gl *g, const float *vtx, size_t n, const uint32_t *corner, size_t m,
                 int w, int h)
{
    memset(g, 0, sizeof *g);
    g->n = n;
    g->prog = program(scene_vs, scene_fs);
    g->marker_prog = program(marker_vs, marker_fs);
    if (!g->prog || !g->marker_prog)
        return -1;
    g->u_mvp = glGetUniformLocation(g->prog, "mvp");
    g->u_exposure = glGetUniformLocation(g->prog, "exposure");
    g->u_bsamp = glGetUniformLocation(g->prog, "bsamp");
    g->u_smooth = glGetUniformLocation(g->prog, "smooth_on");
    g->u_marker_mvp = glGetUniformLocation(g->marker_prog, "mvp");
    if (upload_mesh(g, vtx, corner, m) != 0) {
        fprintf(stderr, "lrr view: cannot upload the mesh (GL error)\n");
        return -1;
    }
    glGenVertexArrays(1, &g->marker_vao);
    glBindVertexArray(g->marker_vao);
    glGenBuffers(1, &g->marker_vbo);
    glBindBuffer(GL_ARRAY_BUFFER, g->marker_vbo);
    glBufferData(GL_ARRAY_BUFFER, VIEW_MAX_LIGHTS * 3 * sizeof(float), NULL, GL_DYNAMIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, NULL);
    glGenFramebuffers(1, &g->fbo);
    glGenRenderbuffers(1, &g->color_rb);
    glGenRenderbuffers(1, &g->depth_rb);
    return resize_fbo(g, w, h);
}

void view_gl_upload(view_gl *g, const float *rgb, size_t count)
{
    glBindBuffer(GL_TEXTURE_BUFFER, g->bbuf);
    glBufferSubData(GL_TEXTURE_BUFFER, 0,
                    (GLsizeiptr)((count < g->texels ? count : g->texels) * 3 * sizeof(float)), rgb);
}

static void draw_markers(view_gl *g, const float mvp[16], const float *markers, size_t count,
                         long selected)
{
    if (!count)
        return;
    glDisable(GL_DEPTH_TEST); /* a light behind a wall stays findable */
    glUseProgram(g->marker_prog);
    glUniformMatrix4fv(g->u_marker_mvp, 1, GL_FALSE, mvp);
    GLint colour = glGetUniformLocation(g->marker_prog, "colour");
    glBindVertexArray(g->marker_vao);
    glBindBuffer(GL_ARRAY_BUFFER, g->marker_vbo);
    glBufferSubData(GL_ARRAY_BUFFER, 0, (GLsizeiptr)(count * 3 * sizeof(float)), markers);
    glUniform3f(colour, 1.0f, 1.0f, 1.0f);
    glDrawArrays(GL_POINTS, 0, (GLsizei)count);
    if (selected >= 0 && (size_t)selected < count) {
        glUniform3f(colour, 1.0f, 0.85f, 0.0f);
        glDrawArrays(GL_POINTS, (GLint)selected, 1);
    }
}

void view_gl_draw(view_gl *g, const float mvp[16], double exposure, int smooth,
                  const float *markers, size_t count, long selected)
{
    glBindFramebuffer(GL_FRAMEBUFFER, g->fbo);
    glViewport(0, 0, g->fb_w, g->fb_h);
    glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glEnable(GL_CULL_FACE); /* the back of a wall is not drawn: rooms seen from outside */
    glEnable(GL_PROGRAM_POINT_SIZE);
    glUseProgram(g->prog);
    glUniformMatrix4fv(g->u_mvp, 1, GL_FALSE, mvp);
    glUniform1f(g->u_exposure, (float)exposure);
    glUniform1i(g->u_smooth, smooth);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_BUFFER, g->btex);
    glUniform1i(g->u_bsamp, 0);
    glBindVertexArray(g->vao);
    glDrawArrays(GL_TRIANGLES, 0, (GLsizei)(3 * g->n));
    draw_markers(g, mvp, markers, count, selected);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void view_gl_present(view_gl *g, int win_w, int win_h)
{
    if ((win_w != g->fb_w || win_h != g->fb_h) && win_w > 0 && win_h > 0)
        resize_fbo(g, win_w, win_h); /* takes effect from the next frame */
    glBindFramebuffer(GL_READ_FRAMEBUFFER, g->fbo);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
    glBlitFramebuffer(0, 0, g->fb_w, g->fb_h, 0, 0, win_w, win_h, GL_COLOR_BUFFER_BIT,
                      GL_NEAREST);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

/* Mean luma (Rec. 709 weights on the 8-bit sRGB values) of the picture's left and right
 * halves: what the headless test compares (the middle column, if any, counts in neither). */
static void halves(const unsigned char *px, int w, int h, double out[2])
{
    double sum[2] = {0, 0};
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            if (2 * x + 1 == w)
                continue;
            const unsigned char *p = px + 3 * ((size_t)y * w + x);
            sum[2 * x >= w] += 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        }
    for (int k = 0; k < 2; k++)
        out[k] = sum[k] / ((double)(w / 2) * h);
}

static void write_to_file(void *ctx, void *data, int size)
{
    cli_outfile *o = ctx;
    if (fwrite(data, 1, (size_t)size, o->f) != (size_t)size)
        errno = errno ? errno : EIO;
}

int view_gl_screenshot(view_gl *g, const char *path, double half_luma[2])
{
    size_t row = (size_t)g->fb_w * 3;
    unsigned char *px = malloc(row * g->fb_h), *tmp = malloc(row);
    if (!px || !tmp) {
        free(px);
        free(tmp);
        fprintf(stderr, "lrr view: out of memory for the screenshot\n");
        return CLI_EXIT_FAIL;
    }
    glBindFramebuffer(GL_READ_FRAMEBUFFER, g->fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, g->fb_w, g->fb_h, GL_RGB, GL_UNSIGNED_BYTE, px);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    for (int y = 0; y < g->fb_h / 2; y++) { /* GL's rows go bottom up, PNG's top down */
        memcpy(tmp, px + y * row, row);
        memcpy(px + y * row, px + (g->fb_h - 1 - y) * row, row);
        memcpy(px + (g->fb_h - 1 - y) * row, tmp, row);
    }
    free(tmp);
    halves(px, g->fb_w, g->fb_h, half_luma);
    cli_outfile o;
    int rc = CLI_EXIT_FAIL;
    if (cli_outfile_open(&o, path) != 0) {
        fprintf(stderr, "lrr view: cannot write '%s': %s\n", path, strerror(errno));
    } else if (!stbi_write_png_to_func(write_to_file, &o, g->fb_w, g->fb_h, 3, px, (int)row) ||
               ferror(o.f)) {
        cli_outfile_abort(&o);
        fprintf(stderr, "lrr view: cannot write '%s'\n", path);
    } else if (cli_outfile_commit(&o) != 0) {
        fprintf(stderr, "lrr view: cannot write '%s': %s\n", path, strerror(errno));
    } else {
        rc = CLI_EXIT_OK;
    }
    free(px);
    return rc;
}

void view_gl_free(view_gl *g)
{
    glDeleteProgram(g->prog);
    glDeleteProgram(g->marker_prog);
    glDeleteBuffers(1, &g->vbo);
    glDeleteBuffers(1, &g->corner_vbo);
    glDeleteBuffers(1, &g->bbuf);
    glDeleteBuffers(1, &g->marker_vbo);
    glDeleteTextures(1, &g->btex);
    glDeleteVertexArrays(1, &g->vao);
    glDeleteVertexArrays(1, &g->marker_vao);
    glDeleteFramebuffers(1, &g->fbo);
    glDeleteRenderbuffers(1, &g->color_rb);
    glDeleteRenderbuffers(1, &g->depth_rb);
}
