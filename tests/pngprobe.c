/* pngprobe.c - reads a PNG back with cairo for tests/cli_plot.sh, which checks where `plot` put
 * things, independently of the plotting code:
 *   pngprobe FILE size                 width and height in pixels
 *   pngprobe FILE pixel X Y            the colour of pixel (X, Y) (0-based, y down) as R G B
 *   pngprobe FILE hottest CX CY R      the lightest pixels (Rec. 709 luma) of those whose centres lie
 *                                      within R of (CX, CY): their centroid (pixel centres, so
 *                                      pixel (i, j) is at i + 0.5, j + 0.5), their luma and count */
#include <config.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cairo.h>

static void rgb_at(cairo_surface_t *s, int x, int y, int rgb[3])
{
    const unsigned char *row = cairo_image_surface_get_data(s) + (size_t)y * cairo_image_surface_get_stride(s);
    uint32_t p;
    memcpy(&p, row + 4 * (size_t)x, 4);
    rgb[0] = p >> 16 & 255, rgb[1] = p >> 8 & 255, rgb[2] = p & 255;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: pngprobe FILE size | pixel X Y | hottest CX CY R\n");
        return 2;
    }
    cairo_surface_t *s = cairo_image_surface_create_from_png(argv[1]);
    if (cairo_surface_status(s) != CAIRO_STATUS_SUCCESS) {
        fprintf(stderr, "pngprobe: %s: %s\n", argv[1], cairo_status_to_string(cairo_surface_status(s)));
        return 1;
    }
    cairo_format_t f = cairo_image_surface_get_format(s);
    if (f != CAIRO_FORMAT_RGB24 && f != CAIRO_FORMAT_ARGB32) {
        fprintf(stderr, "pngprobe: %s: not an RGB image\n", argv[1]);
        return 1;
    }
    int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s), rgb[3];
    cairo_surface_flush(s);
    if (strcmp(argv[2], "size") == 0) {
        printf("%d %d\n", w, h);
    } else if (strcmp(argv[2], "pixel") == 0 && argc == 5) {
        int x = atoi(argv[3]), y = atoi(argv[4]);
        if (x < 0 || y < 0 || x >= w || y >= h) {
            fprintf(stderr, "pngprobe: pixel (%d, %d) outside %d x %d\n", x, y, w, h);
            return 1;
        }
        rgb_at(s, x, y, rgb);
        printf("%d %d %d\n", rgb[0], rgb[1], rgb[2]);
    } else if (strcmp(argv[2], "hottest") == 0 && argc == 6) {
        double cx = atof(argv[3]), cy = atof(argv[4]), r = atof(argv[5]), best = -1, sx = 0, sy = 0;
        long n = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                if (hypot(x + 0.5 - cx, y + 0.5 - cy) > r)
                    continue;
                rgb_at(s, x, y, rgb);
                double luma = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
                if (luma > best + 1e-9)
                    best = luma, sx = sy = 0, n = 0;
                if (luma > best - 1e-9)
                    sx += x + 0.5, sy += y + 0.5, n++;
            }
        if (n == 0) {
            fprintf(stderr, "pngprobe: no pixel within %g of (%g, %g)\n", r, cx, cy);
            return 1;
        }
        printf("%.2f %.2f %.2f %ld\n", sx / n, sy / n, best, n);
    } else {
        fprintf(stderr, "pngprobe: unknown request '%s'\n", argv[2]);
        return 2;
    }
    cairo_surface_destroy(s);
    return 0;
}
