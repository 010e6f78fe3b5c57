/* Shared by the C/C++ examples: read a whole file into 64-byte aligned memory (the format
 * aligns every section to 64 bytes, so typed views of the data are aligned too). */
#ifndef PENUMBRA_EXAMPLES_COMMON_H
#define PENUMBRA_EXAMPLES_COMMON_H
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

typedef struct example_file {
    void *block;       /* what to free() */
    unsigned char *data; /* 64-byte aligned */
    size_t size;
} example_file;

/* 0 on success; prints the reason and returns 1 otherwise. */
static int example_read(const char *path, example_file *f) {
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
    if (f->block == NULL) { fclose(fp); return 1; }
    f->data = (unsigned char *)f->block + (64 - (uintptr_t)f->block % 64) % 64;
    if (fread(f->data, 1, f->size, fp) != f->size) {
        fprintf(stderr, "%s: short read\n", path);
        fclose(fp);
        return 1;
    }
    fclose(fp);
    return 0;
}
#endif
