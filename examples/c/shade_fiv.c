/* shade_fiv: FIV soft shadows through the C ABI (include/penumbra.h). Usage: shade_fiv OCCLUDER.fivt
 * Places two copies of the occluder — one where it was baked, one moved by 1.2 R along +x, so
 * their shadows overlap — and shades an 8 × 8 grid of upward-facing receivers on the plane
 * through the bottom of the baked ball (x, z in [-2R, 2R] around its centre). Prints one line
 * per receiver: "p x y z n x y z E r g b" (irradiance, shadowed by both, overlap-corrected),
 * then the unshadowed irradiance "U r g b". Exit 0 on success, 2 on a bad asset. */
#include "penumbra.h"
#include "common.h"

int main(int argc, char **argv) {
    example_file f;
    pn_fiv_table *table = NULL;
    pn_fiv_scene *scene = NULL;
    pn_fiv_placed placed[2];
    char err[256];
    float c[3], r, up[3] = {0.0f, 1.0f, 0.0f}, e[3];
    int i, j;
    if (argc != 2) {
        fprintf(stderr, "usage: %s OCCLUDER.fivt\n", argv[0]);
        return 2;
    }
    if (pn_abi_version() != PN_ABI_VERSION) {
        fprintf(stderr, "library ABI %u, header %u\n", pn_abi_version(), PN_ABI_VERSION);
        return 2;
    }
    if (example_read(argv[1], &f) != 0) return 2;
    if (pn_fiv_table_open(f.data, f.size, &table, err, sizeof err) != PN_OK) {
        fprintf(stderr, "%s: %s\n", argv[1], err);
        return 2;
    }
    pn_fiv_table_ball(table, c, &r);
    placed[0].table = table;
    placed[1].table = table;
    for (i = 0; i < 3; i++) placed[0].center[i] = placed[1].center[i] = c[i];
    placed[1].center[0] += 1.2f * r;
    if (pn_fiv_scene_new(placed, 2, PN_FIV_PARTIAL_NONE, true, &scene, err, sizeof err) != PN_OK) {
        fprintf(stderr, "scene: %s\n", err);
        return 2;
    }
    for (j = 0; j < 8; j++) {
        for (i = 0; i < 8; i++) {
            float p[3];
            p[0] = c[0] + r * (-2.0f + 4.0f * (float)i / 7.0f);
            p[1] = c[1] - r;
            p[2] = c[2] + r * (-2.0f + 4.0f * (float)j / 7.0f);
            if (pn_fiv_scene_irradiance(scene, p, up, e) != PN_OK) return 2;
            printf("p %.9g %.9g %.9g n %.9g %.9g %.9g E %.9g %.9g %.9g\n", p[0], p[1], p[2], up[0], up[1], up[2], e[0],
                   e[1], e[2]);
        }
    }
    pn_fiv_table_irradiance(table, up, e);
    printf("U %.9g %.9g %.9g\n", e[0], e[1], e[2]);
    pn_fiv_scene_free(scene);
    pn_fiv_table_free(table);
    free(f.block);
    return 0;
}
