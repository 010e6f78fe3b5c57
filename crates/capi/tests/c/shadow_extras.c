/* shadow_extras: posing, local lights and indirect light from proxies through the C ABI
 * (include/penumbra.h; issue #14 §2), for tests/c_shadow_extras.rs.
 * Usage: shadow_extras TABLES.shtb SKINNED.sphr
 * Poses the set with two node matrices (node 0 moved by (1, 0, 0), node 1 turned 90° about z),
 * cuts the posed hierarchy for a cluster below it, shades a local spherical light blocked by the
 * posed leaves and the indirect light of the posed proxies with their stored albedos by each
 * operator, and checks the documented error codes. Prints one line per value:
 *   leaf I x y z r | cut N | cluster r g b | local r g b | local_unblocked r g b |
 *   direct OP r g b | indirect OP r g b | err NAME CODE
 * with %.9g, which round-trips an f32 exactly. Exit 0 on success, 2 on a failed call. */
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include "penumbra.h"

typedef struct file {
    void *block;
    unsigned char *data; /* 64-byte aligned, as the container's sections */
    size_t size;
} file;

static int read_file(const char *path, file *f) {
    FILE *fp = fopen(path, "rb");
    long n;
    f->block = NULL;
    if (fp == NULL || fseek(fp, 0, SEEK_END) != 0 || (n = ftell(fp)) < 0 || fseek(fp, 0, SEEK_SET) != 0) {
        fprintf(stderr, "%s: cannot read\n", path);
        if (fp) fclose(fp);
        return 1;
    }
    f->size = (size_t)n;
    f->block = malloc(f->size + 64);
    if (f->block == NULL) {
        fclose(fp);
        return 1;
    }
    f->data = (unsigned char *)f->block + (64 - (uintptr_t)f->block % 64) % 64;
    if (fread(f->data, 1, f->size, fp) != f->size) {
        fclose(fp);
        return 1;
    }
    fclose(fp);
    return 0;
}

#define CHECK(call)                                                        \
    do {                                                                   \
        int32_t st_ = (call);                                              \
        if (st_ != PN_OK) {                                                \
            fprintf(stderr, "%s:%d: %s = %d\n", __FILE__, __LINE__, #call, st_); \
            return 2;                                                      \
        }                                                                  \
    } while (0)

#define MAX_LEAVES 64

static void put3(const char *name, const float v[3]) { printf("%s %.9g %.9g %.9g\n", name, v[0], v[1], v[2]); }

int main(int argc, char **argv) {
    /* the light of tests/c_shadow_extras.rs: order-3 RGB coefficients (order-4 tables take the
     * first 9 and zeros) */
    static const float light3[9][3] = {{3.0f, 3.2f, 3.5f},   {0.1f, 0.0f, 0.0f},  {1.0f, 1.1f, 1.3f},
                                       {0.3f, 0.2f, 0.1f},   {0.05f, 0.02f, 0.0f}, {0.0f, 0.01f, 0.03f},
                                       {-0.2f, -0.1f, 0.0f}, {0.0f, 0.0f, 0.04f}, {0.02f, 0.02f, 0.02f}};
    /* column-major 4×4: node 0 translated by (1, 0, 0); node 1 a 90° turn about z */
    static const float mats[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1, 0, 0, 1,
                                   0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    static const char *op_names[3] = {"point", "averaged", "exact"};
    file tf, sf;
    pn_tables *t = NULL;
    pn_spheres *set = NULL;
    pn_shadow *ev = NULL;
    pn_posed_spheres *posed = NULL;
    pn_cluster *cl = NULL;
    pn_sphere leaves[MAX_LEAVES];
    float albedo[3 * MAX_LEAVES];
    float *light;
    char err[256];
    size_t order, n2, count, i, k;
    uint32_t op;
    int32_t st;
    float out[3], direct[3], indirect[3], nan_mats[32];
    const float p_r[3] = {0.0f, -3.0f, 0.0f}, n_up[3] = {0.0f, 1.0f, 0.0f};
    const float p_local[3] = {0.3f, -0.5f, 0.1f};
    pn_local_light ll = {{{0.0f, 4.0f, 0.0f}, 1.0f}, {1.0f, 2.0f, 0.5f}};
    pn_local_light bad = {{{0.0f, 4.0f, 0.0f}, -1.0f}, {1.0f, 1.0f, 1.0f}};

    if (argc != 3) {
        fprintf(stderr, "usage: %s TABLES.shtb SKINNED.sphr\n", argv[0]);
        return 2;
    }
    if (read_file(argv[1], &tf) != 0 || read_file(argv[2], &sf) != 0) return 2;
    if (pn_tables_open(tf.data, tf.size, &t, err, sizeof err) != PN_OK) {
        fprintf(stderr, "%s: %s\n", argv[1], err);
        return 2;
    }
    if (pn_spheres_open(sf.data, sf.size, &set, err, sizeof err) != PN_OK) {
        fprintf(stderr, "%s: %s\n", argv[2], err);
        return 2;
    }
    order = pn_tables_order(t);
    n2 = order * order;
    light = (float *)calloc(n2 * 3, sizeof(float));
    if (light == NULL) return 2;
    for (i = 0; i < n2 && i < 9; i++)
        for (k = 0; k < 3; k++) light[3 * i + k] = light3[i][k];
    if (pn_shadow_new(t, light, n2 * 3, NULL, &ev, err, sizeof err) != PN_OK) {
        fprintf(stderr, "shadow: %s\n", err);
        return 2;
    }
    count = pn_spheres_count(set);
    if (count == 0 || count > MAX_LEAVES) return 2;

    /* posing: the leaves, then the cut of the refitted tree and the cluster's irradiance */
    CHECK(pn_posed_spheres_new(set, &posed));
    CHECK(pn_posed_spheres_pose(posed, mats, 2));
    CHECK(pn_posed_spheres_leaves(posed, leaves, count));
    for (i = 0; i < count; i++)
        printf("leaf %u %.9g %.9g %.9g %.9g\n", (unsigned)i, leaves[i].center[0], leaves[i].center[1],
               leaves[i].center[2], leaves[i].radius);
    CHECK(pn_cluster_new(&cl));
    CHECK(pn_cluster_cut_posed(cl, ev, posed, p_r, 0.5f, 0.42261826f, p_r, n_up));
    printf("cut %u\n", (unsigned)pn_cluster_size(cl));
    CHECK(pn_cluster_irradiance(cl, ev, p_r, n_up, out));
    put3("cluster", out);

    /* a local spherical light above, blocked by the posed leaves */
    CHECK(pn_shadow_irradiance_local_light(ev, p_local, n_up, leaves, count, &ll, out));
    put3("local", out);
    CHECK(pn_shadow_irradiance_local_light(ev, p_local, n_up, NULL, 0, &ll, out));
    put3("local_unblocked", out);

    /* indirect light from the posed proxies with their stored albedos, each operator */
    for (i = 0; i < count; i++) CHECK(pn_spheres_albedo(set, i, albedo + 3 * i));
    for (op = PN_INDIRECT_POINT; op <= PN_INDIRECT_EXACT; op++) {
        CHECK(pn_shadow_shade_with_indirect_by(ev, p_local, n_up, leaves, count, albedo, count, op, direct,
                                               indirect));
        printf("direct %s %.9g %.9g %.9g\n", op_names[op], direct[0], direct[1], direct[2]);
        printf("indirect %s %.9g %.9g %.9g\n", op_names[op], indirect[0], indirect[1], indirect[2]);
    }

    /* error codes; a failed pose leaves the pose as it was */
    for (i = 0; i < 32; i++) nan_mats[i] = mats[i];
    nan_mats[5] = 0.0f / 0.0f;
    printf("err pose_nan %d\n", pn_posed_spheres_pose(posed, nan_mats, 2));
    printf("err pose_few_matrices %d\n", pn_posed_spheres_pose(posed, mats, 1));
    printf("err leaves_count %d\n", pn_posed_spheres_leaves(posed, leaves, count - 1));
    CHECK(pn_posed_spheres_leaves(posed, leaves, count));
    printf("leaf0_after_errors %.9g %.9g %.9g\n", leaves[0].center[0], leaves[0].center[1], leaves[0].center[2]);
    printf("err local_bad_light %d\n", pn_shadow_irradiance_local_light(ev, p_local, n_up, leaves, count, &bad, out));
    printf("err indirect_albedo_count %d\n",
           pn_shadow_shade_with_indirect_by(ev, p_local, n_up, leaves, count, albedo, 2, PN_INDIRECT_AVERAGED,
                                            direct, indirect));
    printf("err indirect_op %d\n",
           pn_shadow_shade_with_indirect_by(ev, p_local, n_up, leaves, count, albedo, count, 3, direct, indirect));
    st = pn_spheres_albedo(set, count, albedo);
    printf("err albedo_index %d\n", st);

    pn_cluster_free(cl);
    pn_posed_spheres_free(posed);
    pn_shadow_free(ev);
    pn_spheres_free(set);
    pn_tables_free(t);
    free(light);
    free(tf.block);
    free(sf.block);
    return 0;
}
