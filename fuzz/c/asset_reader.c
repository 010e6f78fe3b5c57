/* libFuzzer target of include/penumbra_asset.h (`make fuzz-c`; fuzz/run-c.sh). Any input: no
 * sanitizer report, and for an accepted one the invariants a caller relies on: every section's
 * data lies inside the buffer at a 64-aligned offset, its CRC matches, dims × size = length,
 * and pn_asset_find returns the same section. The decision itself is compared with the Rust
 * loader by crates/capi/tests/c_reader.rs. */
#define PENUMBRA_ASSET_IMPLEMENTATION
#include "penumbra_asset.h"

#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    pn_asset a;
    char err[64];
    uint32_t i, n;
    if (pn_asset_open(data, size, &a, err, sizeof err) != 0) {
        if (err[0] == '\0') abort();
        return 0;
    }
    n = pn_asset_section_count(&a);
    if (n == 0 || n > PN_MAX_SECTIONS) abort();
    for (i = 0; i < n; i++) {
        pn_section s, f;
        if (pn_asset_section(&a, i, &s) != 0) abort();
        if (s.offset % 64 != 0 || s.offset > size || s.byte_len > size - s.offset) abort();
        if ((const uint8_t *)s.data != data + s.offset) abort();
        if (s.elements * pn_dtype_size(s.dtype) != s.byte_len) abort();
        if (pn_crc32c(s.data, (size_t)s.byte_len) != s.crc) abort();
        if (pn_asset_find(&a, s.name, &f) != 0 || f.offset != s.offset) abort();
    }
    return 0;
}
