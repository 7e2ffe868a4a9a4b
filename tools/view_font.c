/* placeholder */
#include "view_internal.h"
int view_font_init(void) { return -1; }
void view_font_draw(const char *text, int win_w, int win_h, int scale) {}
void view_font_free(void) {}
