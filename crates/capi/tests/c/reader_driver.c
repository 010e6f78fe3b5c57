/* Differential-test driver of include/penumbra_asset.h (crates/capi/tests/c_reader.rs).
 * Reads records from stdin — a little-endian u64 length, then that many bytes — and for each
 * prints what pn_asset_open decides, in the text form the Rust test also produces:
 *   R                                         (refused)
 *   A <kind> <major> <minor> <count>          (accepted), then per section
 *   S <name> <dtype> <rank> <flags> <d0..d5> <elements> <offset> <byte_len> <crc>
 *   E
 * It also checks, per accepted asset, that pn_asset_find finds every section at the same
 * entry and that data == bytes + offset, printing "X <reason>" otherwise. */
#define PENUMBRA_ASSET_IMPLEMENTATION
#include "penumbra_asset.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int read_exact(void *p, size_t n) { return fread(p, 1, n, stdin) == n; }

int main(void) {
    unsigned char lenb[8];
    while (read_exact(lenb, 8)) {
        uint64_t len = 0;
        int k;
        unsigned char *buf;
        pn_asset a;
        char err[256];
        for (k = 7; k >= 0; k--) len = (len << 8) | lenb[k];
        buf = (unsigned char *)malloc(len ? (size_t)len : 1);
        if (buf == NULL || !read_exact(buf, (size_t)len)) {
            fprintf(stderr, "driver: bad input record\n");
            return 2;
        }
        if (pn_asset_open(buf, (size_t)len, &a, err, sizeof err) != 0) {
            /* The message must be non-empty and terminated within the buffer. */
            if (err[0] == '\0' || memchr(err, '\0', sizeof err) == NULL) printf("X empty error message\n");
            printf("R\n");
        } else {
            char kind[5];
            uint16_t major, minor;
            uint32_t i, n = pn_asset_section_count(&a);
            pn_section s, f;
            pn_asset_kind(&a, kind);
            pn_asset_version(&a, &major, &minor);
            printf("A %s %u %u %u\n", kind, (unsigned)major, (unsigned)minor, (unsigned)n);
            for (i = 0; i < n; i++) {
                if (pn_asset_section(&a, i, &s) != 0) { printf("X section %u\n", (unsigned)i); continue; }
                printf("S %s %u %u %u", s.name, (unsigned)s.dtype, (unsigned)s.rank, (unsigned)s.flags);
                for (k = 0; k < PN_MAX_RANK; k++) printf(" %" PRIu32, s.dims[k]);
                printf(" %" PRIu64 " %" PRIu64 " %" PRIu64 " %" PRIu32 "\n", s.elements, s.offset, s.byte_len, s.crc);
                if ((const unsigned char *)s.data != buf + s.offset) printf("X data pointer %u\n", (unsigned)i);
                if (pn_crc32c(s.data, (size_t)s.byte_len) != s.crc) printf("X crc %u\n", (unsigned)i);
                if (pn_asset_find(&a, s.name, &f) != 0 || f.offset != s.offset) printf("X find %s\n", s.name);
            }
            if (pn_asset_section(&a, n, &s) == 0) printf("X section past the end\n");
            if (pn_asset_find(&a, "no-such-section-name", &f) == 0) printf("X found a missing name\n");
            printf("E\n");
        }
        free(buf);
    }
    return 0;
}
