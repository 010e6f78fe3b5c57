/* Reads a VOSS asset (volumetric-obscurance sample sets, MRT thesis §6.3.5) with
 * include/penumbra_asset.h alone, as schemas/asset-format.md ("VOSS") describes it, and checks
 * every set's sections (crates/capi/tests/c_reader.rs runs it):
 *   - the counts N from the section names `disk.c0.n<N>.points`;
 *   - for each family {disk|ball}.{c0|c1} and N: `<set>.points` f32 [N, 2|3], `<set>.weights`
 *     f32 [N], `<set>.log2area` f32 [N], and for the disk `<set>.zs` f32 [N];
 *   - points inside the unit disk/ball, the c1 sample 0 at the origin, weights ≥ 0 summing to 1,
 *     the unweighted area fractions 2^log2area summing to 1, zs = sqrt(1 - x² - y²);
 *   - reflect2d f32 [S, S, 2] and reflect3d f32 [S, S, 3] of unit normals.
 * Prints "A <sections>" then "S <set> <N> <D> <sum of weights %.6f>" per set, "X <reason>" for
 * every violation, and "E". Exit 0 when it printed no X, 1 otherwise, 2 when it cannot run. */
#define PENUMBRA_ASSET_IMPLEMENTATION
#include "penumbra_asset.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

static void fail(const char *what, const char *name) {
    printf("X %s %s\n", what, name);
    failures++;
}

/* The f32 section `name` of the given rank and dims, little-endian (copied out: no alignment
 * assumption on the caller's buffer). Returns NULL (and reports) when absent or mismatched. */
static float *f32_section(const pn_asset *a, const char *name, uint8_t rank, uint32_t d0, uint32_t d1,
                          uint32_t d2) {
    pn_section s;
    uint32_t want[3];
    uint64_t i;
    float *v;
    want[0] = d0;
    want[1] = d1;
    want[2] = d2;
    if (pn_asset_find(a, name, &s) != PN_OK) {
        fail("missing", name);
        return NULL;
    }
    if (s.dtype != PN_DTYPE_F32 || s.rank != rank) {
        fail("dtype/rank", name);
        return NULL;
    }
    for (i = 0; i < rank; i++)
        if (s.dims[i] != want[i]) {
            fail("dims", name);
            return NULL;
        }
    v = (float *)malloc(s.elements ? (size_t)s.elements * sizeof(float) : 1);
    if (v == NULL) {
        fail("out of memory", name);
        return NULL;
    }
    for (i = 0; i < s.elements; i++) {
        const uint8_t *p = (const uint8_t *)s.data + 4 * i;
        uint32_t u = (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
        memcpy(&v[i], &u, 4);
    }
    return v;
}

/* The counts N of the asset, found by name: every section `disk.c0.n<N>.points`, in table
 * order (the writer stores increasing N). Returns how many were read. */
static int read_counts(const pn_asset *a, long *out, int max) {
    uint32_t i, n = pn_asset_section_count(a);
    int k = 0;
    for (i = 0; i < n && k < max; i++) {
        pn_section s;
        const char *prefix = "disk.c0.n";
        char *end;
        long v;
        if (pn_asset_section(a, i, &s) != PN_OK || strncmp(s.name, prefix, strlen(prefix)) != 0) continue;
        v = strtol(s.name + strlen(prefix), &end, 10);
        if (end != s.name + strlen(prefix) && strcmp(end, ".points") == 0 && v >= 1 && v <= 256) out[k++] = v;
    }
    return k;
}

int main(int argc, char **argv) {
    FILE *f;
    long size, counts[256];
    unsigned char *buf;
    pn_asset a;
    char err[256], kind[5];
    int nc, fam, c;
    pn_section r;
    if (argc != 2) {
        fprintf(stderr, "usage: voss_reader FILE.voss\n");
        return 2;
    }
    f = fopen(argv[1], "rb");
    if (f == NULL || fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fprintf(stderr, "voss_reader: cannot read %s\n", argv[1]);
        return 2;
    }
    buf = (unsigned char *)malloc(size ? (size_t)size : 1);
    if (buf == NULL || fread(buf, 1, (size_t)size, f) != (size_t)size) {
        fprintf(stderr, "voss_reader: cannot read %s\n", argv[1]);
        return 2;
    }
    fclose(f);
    if (pn_asset_open(buf, (size_t)size, &a, err, sizeof err) != PN_OK) {
        printf("X refused %s\nE\n", err);
        free(buf);
        return 1;
    }
    pn_asset_kind(&a, kind);
    if (strcmp(kind, "VOSS") != 0) fail("kind", kind);
    printf("A %u\n", (unsigned)pn_asset_section_count(&a));
    nc = read_counts(&a, counts, 256);
    if (nc == 0) fail("no set named", "disk.c0.n<N>.points");
    /* reflection textures: S x S unit normals */
    if (pn_asset_find(&a, "reflect2d", &r) == PN_OK && r.rank == 3) {
        uint32_t s = r.dims[0], dim;
        for (dim = 2; dim <= 3; dim++) {
            const char *name = dim == 2 ? "reflect2d" : "reflect3d";
            float *v = f32_section(&a, name, 3, s, s, dim);
            uint32_t t;
            if (v == NULL) continue;
            for (t = 0; t < s * s; t++) {
                double l = 0.0;
                uint32_t k;
                for (k = 0; k < dim; k++) l += (double)v[t * dim + k] * v[t * dim + k];
                if (fabs(l - 1.0) > 1e-5) fail("not a unit normal in", name);
            }
            free(v);
        }
    } else {
        fail("missing or bad", "reflect2d");
    }
    for (fam = 0; fam < 4; fam++) {
        const char *domain = fam < 2 ? "disk" : "ball";
        int centre = fam % 2;
        uint32_t dim = fam < 2 ? 2 : 3;
        for (c = 0; c < nc; c++) {
            char key[24], name[PN_NAME_LEN + 1];
            uint32_t n = (uint32_t)counts[c], i, k;
            float *p, *w, *l, *zs = NULL;
            double sw = 0.0, sa = 0.0;
            sprintf(key, "%s.c%d.n%u", domain, centre, (unsigned)n);
            sprintf(name, "%s.points", key);
            p = f32_section(&a, name, 2, n, dim, 0);
            sprintf(name, "%s.weights", key);
            w = f32_section(&a, name, 1, n, 0, 0);
            sprintf(name, "%s.log2area", key);
            l = f32_section(&a, name, 1, n, 0, 0);
            if (dim == 2) {
                sprintf(name, "%s.zs", key);
                zs = f32_section(&a, name, 1, n, 0, 0);
            }
            if (p != NULL && w != NULL && l != NULL && (dim == 3 || zs != NULL)) {
                for (i = 0; i < n; i++) {
                    double r2 = 0.0;
                    for (k = 0; k < dim; k++) r2 += (double)p[i * dim + k] * p[i * dim + k];
                    if (!(r2 < 1.0)) fail("point outside the domain in", key);
                    if (centre && i == 0 && r2 != 0.0) fail("centre sample not at the origin in", key);
                    if (!(w[i] >= 0.0f)) fail("negative weight in", key);
                    sw += w[i];
                    sa += exp2((double)l[i]);
                    if (dim == 2 && fabs(zs[i] - sqrt(1.0 - r2)) > 1e-6 / (zs[i] > 0.01f ? zs[i] : 0.01f)) fail("zs != sqrt(1 - r^2) in", key);
                }
                if (fabs(sw - 1.0) > 1e-5) fail("weights do not sum to 1 in", key);
                if (fabs(sa - 1.0) > 1e-3) fail("area fractions do not sum to 1 in", key);
                printf("S %s %u %u %.6f\n", key, (unsigned)n, (unsigned)dim, sw);
            }
            free(p);
            free(w);
            free(l);
            free(zs);
        }
    }
    printf("E\n");
    free(buf);
    return failures ? 1 : 0;
}
