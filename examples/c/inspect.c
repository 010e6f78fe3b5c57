/* inspect: list any penumbra asset with the single-header reader (include/penumbra_asset.h),
 * no Rust involved. Usage: inspect ASSET...
 * Prints, per asset, "ASSET: KIND format M.m, N sections, S bytes" and one line per section:
 * name, element type, dims, byte length, CRC-32C (all verified on open), "critical" flag.
 * Exit 0 when every asset is valid, 2 otherwise (the reason on stderr). */
#define PENUMBRA_ASSET_IMPLEMENTATION
#include "penumbra_asset.h"
#include "common.h"

#include <inttypes.h>

static const char *dtype_name(uint8_t d) {
    static const char *names[] = {"?", "u8", "u16", "u32", "i32", "f16", "f32", "f64", "json"};
    return d <= PN_DTYPE_JSON ? names[d] : "?";
}

int main(int argc, char **argv) {
    int i, status = 0;
    if (argc < 2) {
        fprintf(stderr, "usage: %s ASSET...\n", argv[0]);
        return 2;
    }
    for (i = 1; i < argc; i++) {
        example_file f;
        pn_asset a;
        char err[256], kind[5];
        uint16_t major, minor;
        uint32_t s, n;
        if (example_read(argv[i], &f) != 0) { status = 2; free(f.block); continue; }
        if (pn_asset_open(f.data, f.size, &a, err, sizeof err) != 0) {
            fprintf(stderr, "%s: %s\n", argv[i], err);
            status = 2;
            free(f.block);
            continue;
        }
        pn_asset_kind(&a, kind);
        pn_asset_version(&a, &major, &minor);
        n = pn_asset_section_count(&a);
        printf("%s: %s format %u.%u, %u sections, %lu bytes\n", argv[i], kind, (unsigned)major, (unsigned)minor,
               (unsigned)n, (unsigned long)f.size);
        for (s = 0; s < n; s++) {
            pn_section sec;
            int k;
            if (pn_asset_section(&a, s, &sec) != 0) continue;
            printf("  %-32s %-4s [", sec.name, dtype_name(sec.dtype));
            for (k = 0; k < sec.rank; k++) printf(k ? ", %" PRIu32 : "%" PRIu32, sec.dims[k]);
            printf("] %" PRIu64 " bytes crc32c %08" PRIx32 "%s\n", sec.byte_len, sec.crc,
                   (sec.flags & PN_SECTION_CRITICAL) ? " critical" : "");
        }
        free(f.block);
    }
    return status;
}
