/* The on-screen line of the viewer: a built-in 5×7 bitmap font (digits, letters shown as
 * capitals, a little punctuation), each lit pixel a small square, on a dark band. No font
 * library, no texture: a few thousand vertices a frame. */
#include "view_internal.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_CHARS 200
#define QUAD_FLOATS 12 /* two triangles, x y each */

static const char charset[] = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ.:-|/+";
/* rows top to bottom, bit 4 the leftmost pixel */
static const unsigned char glyphs[][7] = {
    {14, 17, 19, 21, 25, 17, 14}, {4, 12, 4, 4, 4, 4, 14},     {14, 17, 1, 2, 4, 8, 31},
    {31, 2, 4, 2, 1, 17, 14},     {2, 6, 10, 18, 31, 2, 2},    {31, 16, 30, 1, 1, 17, 14},
    {6, 8, 16, 30, 17, 17, 14},   {31, 1, 2, 4, 8, 8, 8},      {14, 17, 17, 14, 17, 17, 14},
    {14, 17, 17, 15, 1, 2, 12},   {14, 17, 17, 31, 17, 17, 17}, {30, 17, 17, 30, 17, 17, 30},
    {14, 17, 16, 16, 16, 17, 14}, {28, 18, 17, 17, 17, 18, 28}, {31, 16, 16, 30, 16, 16, 31},
    {31, 16, 16, 30, 16, 16, 16}, {14, 17, 16, 23, 17, 17, 15}, {17, 17, 17, 31, 17, 17, 17},
    {14, 4, 4, 4, 4, 4, 14},      {7, 2, 2, 2, 2, 18, 12},     {17, 18, 20, 24, 20, 18, 17},
    {16, 16, 16, 16, 16, 16, 31}, {17, 27, 21, 21, 17, 17, 17}, {17, 17, 25, 21, 19, 17, 17},
    {14, 17, 17, 17, 17, 17, 14}, {30, 17, 17, 30, 16, 16, 16}, {14, 17, 17, 17, 21, 18, 13},
    {30, 17, 17, 30, 20, 18, 17}, {15, 16, 16, 14, 1, 1, 30},  {31, 4, 4, 4, 4, 4, 4},
    {17, 17, 17, 17, 17, 17, 14}, {17, 17, 17, 17, 17, 10, 4}, {17, 17, 17, 21, 21, 21, 10},
    {17, 17, 10, 4, 10, 17, 17},  {17, 17, 17, 10, 4, 4, 4},   {31, 1, 2, 4, 8, 16, 31},
    {0, 0, 0, 0, 0, 12, 12},      {0, 12, 12, 0, 12, 12, 0},   {0, 0, 0, 31, 0, 0, 0},
    {4, 4, 4, 4, 4, 4, 4},        {0, 1, 2, 4, 8, 16, 0},      {0, 4, 4, 31, 4, 4, 0}};

static const char font_vs[] =
    "#version 330 core\n"
    "layout(location = 0) in vec2 px;\n"
    "uniform vec2 size;\n"
    "void main() { gl_Position = vec4(2.0 * px.x / size.x - 1.0, 1.0 - 2.0 * px.y / size.y,"
    " 0.0, 1.0); }\n";
static const char font_fs[] =
    "#version 330 core\n"
    "uniform vec4 colour;\n"
    "out vec4 frag;\n"
    "void main() { frag = colour; }\n";

static struct {
    GLuint prog, vao, vbo;
    GLint u_size, u_colour;
    float *v;
} font;

static GLuint shader(GLenum kind, const char *src)
{
    GLuint s = glCreateShader(kind);
    glShaderSource(s, 1, &src, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    return ok ? s : 0;
}

int view_font_init(void)
{
    GLuint vs = shader(GL_VERTEX_SHADER, font_vs), fs = shader(GL_FRAGMENT_SHADER, font_fs);
    GLint ok = 0;
    if (vs && fs) {
        font.prog = glCreateProgram();
        glAttachShader(font.prog, vs);
        glAttachShader(font.prog, fs);
        glLinkProgram(font.prog);
        glGetProgramiv(font.prog, GL_LINK_STATUS, &ok);
    }
    glDeleteShader(vs);
    glDeleteShader(fs);
    font.v = malloc((size_t)(MAX_CHARS * 35 + 1) * QUAD_FLOATS * sizeof *font.v);
    if (!ok || !font.v) {
        fprintf(stderr, "lrr view: no on-screen text (the split goes to the window title)\n");
        view_font_free();
        return -1;
    }
    font.u_size = glGetUniformLocation(font.prog, "size");
    font.u_colour = glGetUniformLocation(font.prog, "colour");
    glGenVertexArrays(1, &font.vao);
    glBindVertexArray(font.vao);
    glGenBuffers(1, &font.vbo);
    glBindBuffer(GL_ARRAY_BUFFER, font.vbo);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, NULL);
    return 0;
}

static float *quad(float *v, float x0, float y0, float x1, float y1)
{
    const float q[QUAD_FLOATS] = {x0, y0, x1, y0, x1, y1, x0, y0, x1, y1, x0, y1};
    memcpy(v, q, sizeof q);
    return v + QUAD_FLOATS;
}

/* The band and the text's pixels as quads; returns the number of quads. */
static size_t layout(const char *text, int scale)
{
    size_t len = strlen(text) < MAX_CHARS ? strlen(text) : MAX_CHARS;
    float s = (float)scale, *v = quad(font.v, 0, 0, (6 * len + 6) * s, 11 * s);
    for (size_t i = 0; i < len; i++) {
        const char *at = strchr(charset, toupper((unsigned char)text[i]));
        if (!at || !*at)
            continue;
        const unsigned char *g = glyphs[at - charset];
        for (int r = 0; r < 7; r++)
            for (int c = 0; c < 5; c++)
                if (g[r] & (16 >> c)) {
                    float x = (4 + 6 * i + c) * s, y = (2 + r) * s;
                    v = quad(v, x, y, x + s, y + s);
                }
    }
    return (size_t)(v - font.v) / QUAD_FLOATS;
}

void view_font_draw(const char *text, GLuint fbo, int win_w, int win_h, int scale)
{
    if (!font.prog || !text[0])
        return;
    size_t quads = layout(text, scale);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glViewport(0, 0, win_w, win_h);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE); /* the quads turn clockwise on screen: y grows downwards */
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(font.prog);
    glUniform2f(font.u_size, (float)win_w, (float)win_h);
    glBindVertexArray(font.vao);
    glBindBuffer(GL_ARRAY_BUFFER, font.vbo);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(quads * QUAD_FLOATS * sizeof(float)), font.v,
                 GL_STREAM_DRAW);
    glUniform4f(font.u_colour, 0.0f, 0.0f, 0.0f, 0.6f);
    glDrawArrays(GL_TRIANGLES, 0, 6);
    glUniform4f(font.u_colour, 1.0f, 1.0f, 1.0f, 1.0f);
    glDrawArrays(GL_TRIANGLES, 6, (GLsizei)(6 * (quads - 1)));
    glDisable(GL_BLEND);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void view_font_free(void)
{
    if (font.prog)
        glDeleteProgram(font.prog);
    if (font.vbo)
        glDeleteBuffers(1, &font.vbo);
    if (font.vao)
        glDeleteVertexArrays(1, &font.vao);
    free(font.v);
    memset(&font, 0, sizeof font);
}
