/* penumbra_asset.h — single-header C99 reader of penumbra asset containers, format v1.
 *
 * Written from schemas/asset-format.md alone (that page is the contract; this file is the
 * proof that it is complete). stb-style: in exactly one translation unit,
 *
 *     #define PENUMBRA_ASSET_IMPLEMENTATION
 *     #include "penumbra_asset.h"
 *
 * and include it without the define everywhere else. Depends on <stddef.h>, <stdint.h> and
 * <string.h> only; never allocates, never aborts, never reads outside [data, data + size).
 *
 * pn_asset_open() validates every rule of the spec's §10 (1–15): magic, version, header and
 * table CRC-32C, kind, header fields, exact file size, every table entry (name, dtype, rank,
 * flags, reserved fields, dims beyond the rank, dims × element size = length with checked
 * 64-bit arithmetic, canonical 64-byte aligned offsets, bounds, zero padding), the end of the
 * last section, unique names, the `meta` JSON section, every section CRC and the UTF-8 of
 * every JSON section. It accepts and refuses exactly the files the Rust loader
 * (penumbra-asset's Asset::parse) does; a differential test checks it
 * (crates/capi/tests/c_reader.rs). Unknown-critical-section checks (§7) are the caller's: it knows its kind's
 * section names (see pn_section.flags & PN_SECTION_CRITICAL).
 *
 * Limits taken from the spec, which set the field sizes below: section names are 1–32 bytes
 * (so `name` has 33 with the terminating NUL), rank ≤ 6, each dimension is a u32 in the file,
 * at most 4096 sections. pn_asset_find() is a linear scan over the table (no index is built,
 * to stay allocation-free): O(section_count) per call, so look sections up once at load.
 *
 * Thread safety: every function is reentrant; a pn_asset is read-only after pn_asset_open and
 * may be shared between threads. The caller owns the bytes and must keep them alive and
 * unchanged while the pn_asset and any pn_section.data pointer are used. For typed views
 * (e.g. (const float *)section.data) load the file at a 64-byte aligned address on a
 * little-endian machine: every section offset is a multiple of 64.
 *
 * License: MIT OR Apache-2.0, like the rest of penumbra.
 */
#ifndef PENUMBRA_ASSET_H
#define PENUMBRA_ASSET_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Element type codes (spec §4). */
enum {
    PN_DTYPE_U8 = 1,
    PN_DTYPE_U16 = 2,
    PN_DTYPE_U32 = 3,
    PN_DTYPE_I32 = 4,
    PN_DTYPE_F16 = 5,
    PN_DTYPE_F32 = 6,
    PN_DTYPE_F64 = 7,
    PN_DTYPE_JSON = 8
};

/* Section flag bit 0 (spec §7): a reader that does not know the section must refuse the asset. */
#define PN_SECTION_CRITICAL 0x0001u
#define PN_MAX_RANK 6
#define PN_MAX_SECTIONS 4096u
#define PN_NAME_LEN 32

/* Return codes of pn_asset_open / pn_asset_section / pn_asset_find. 0 is success. */
enum {
    PN_OK = 0,
    PN_ERR_ARGUMENT = 1,    /* a NULL pointer where one is not allowed, or index out of range */
    PN_ERR_TOO_SHORT = 2,   /* fewer than 64 bytes */
    PN_ERR_BAD_MAGIC = 3,
    PN_ERR_VERSION = 4,     /* format_major is not 1 */
    PN_ERR_HEADER_CRC = 5,
    PN_ERR_BAD_KIND = 6,
    PN_ERR_BAD_HEADER = 7,  /* section_count, flags, table_offset, reserved, file_size rules */
    PN_ERR_TRUNCATED = 8,   /* buffer shorter than file_size */
    PN_ERR_TRAILING = 9,    /* buffer longer than file_size */
    PN_ERR_TABLE_CRC = 10,
    PN_ERR_BAD_SECTION = 11, /* a table entry breaks a rule of spec §10.10 or names repeat */
    PN_ERR_PADDING = 12,    /* non-zero padding byte */
    PN_ERR_MISSING_META = 13,
    PN_ERR_META_NOT_JSON = 14,
    PN_ERR_SECTION_CRC = 15,
    PN_ERR_UTF8 = 16,       /* a JSON section is not valid UTF-8 */
    PN_ERR_NOT_FOUND = 17   /* pn_asset_find: no section of that name */
};

typedef struct pn_section {
    char name[PN_NAME_LEN + 1]; /* NUL-terminated */
    uint8_t dtype;              /* PN_DTYPE_* */
    uint8_t rank;               /* 1..6 */
    uint16_t flags;             /* PN_SECTION_CRITICAL or 0 */
    uint32_t dims[PN_MAX_RANK]; /* dims[0..rank]; the rest 0 (u32 in the file, spec §3) */
    uint64_t elements;          /* product of dims[0..rank] */
    uint64_t offset;            /* byte offset in the file (multiple of 64) */
    uint64_t byte_len;
    uint32_t crc;               /* CRC-32C of the data, as stored (verified by pn_asset_open) */
    const void *data;           /* = file bytes + offset */
} pn_section;

/* Defined here so the caller owns its storage (stack, struct member, ...); treat as opaque. */
typedef struct pn_asset {
    const uint8_t *bytes;
    uint64_t size;
    uint32_t section_count;
    uint16_t major, minor;
    char kind[5];
} pn_asset;

/* Validates the `size` bytes at `data` as a complete v1 asset. On success fills *out and
 * returns 0. On failure returns a PN_ERR_* code, leaves *out zeroed, and writes a
 * NUL-terminated message into err (truncated to err_len bytes) unless err is NULL or err_len 0. */
int pn_asset_open(const void *data, size_t size, pn_asset *out, char *err, size_t err_len);
/* The 4-character kind ("SHTB", ...), NUL-terminated. */
void pn_asset_kind(const pn_asset *a, char out[5]);
void pn_asset_version(const pn_asset *a, uint16_t *major, uint16_t *minor);
uint32_t pn_asset_section_count(const pn_asset *a);
/* Section `index` in file order. 0 = ok, PN_ERR_ARGUMENT when out of range. */
int pn_asset_section(const pn_asset *a, uint32_t index, pn_section *out);
/* The section called `name` (case-sensitive). 0 = ok, PN_ERR_NOT_FOUND when absent. */
int pn_asset_find(const pn_asset *a, const char *name, pn_section *out);
/* CRC-32C (Castagnoli) of n bytes, spec §9. */
uint32_t pn_crc32c(const void *data, size_t n);
/* IEEE binary16 bits to float, exact (spec §4). */
float pn_f16_to_f32(uint16_t h);
/* Element size in bytes of a dtype code, 0 for an unknown code. */
uint32_t pn_dtype_size(uint8_t dtype);

#ifdef __cplusplus
}
#endif
#endif /* PENUMBRA_ASSET_H */

#ifdef PENUMBRA_ASSET_IMPLEMENTATION
#ifndef PENUMBRA_ASSET_IMPLEMENTED
#define PENUMBRA_ASSET_IMPLEMENTED
#include <string.h>

/* Reflected CRC-32C table (polynomial 0x82F63B78), precomputed so that no function writes
 * shared state (the spec's portable reference fills a static table lazily, which is a data
 * race when two threads open their first asset at once). */
static const uint32_t pn__crc_table[256] = {
    0x00000000u, 0xF26B8303u, 0xE13B70F7u, 0x1350F3F4u, 0xC79A971Fu, 0x35F1141Cu,
    0x26A1E7E8u, 0xD4CA64EBu, 0x8AD958CFu, 0x78B2DBCCu, 0x6BE22838u, 0x9989AB3Bu,
    0x4D43CFD0u, 0xBF284CD3u, 0xAC78BF27u, 0x5E133C24u, 0x105EC76Fu, 0xE235446Cu,
    0xF165B798u, 0x030E349Bu, 0xD7C45070u, 0x25AFD373u, 0x36FF2087u, 0xC494A384u,
    0x9A879FA0u, 0x68EC1CA3u, 0x7BBCEF57u, 0x89D76C54u, 0x5D1D08BFu, 0xAF768BBCu,
    0xBC267848u, 0x4E4DFB4Bu, 0x20BD8EDEu, 0xD2D60DDDu, 0xC186FE29u, 0x33ED7D2Au,
    0xE72719C1u, 0x154C9AC2u, 0x061C6936u, 0xF477EA35u, 0xAA64D611u, 0x580F5512u,
    0x4B5FA6E6u, 0xB93425E5u, 0x6DFE410Eu, 0x9F95C20Du, 0x8CC531F9u, 0x7EAEB2FAu,
    0x30E349B1u, 0xC288CAB2u, 0xD1D83946u, 0x23B3BA45u, 0xF779DEAEu, 0x05125DADu,
    0x1642AE59u, 0xE4292D5Au, 0xBA3A117Eu, 0x4851927Du, 0x5B016189u, 0xA96AE28Au,
    0x7DA08661u, 0x8FCB0562u, 0x9C9BF696u, 0x6EF07595u, 0x417B1DBCu, 0xB3109EBFu,
    0xA0406D4Bu, 0x522BEE48u, 0x86E18AA3u, 0x748A09A0u, 0x67DAFA54u, 0x95B17957u,
    0xCBA24573u, 0x39C9C670u, 0x2A993584u, 0xD8F2B687u, 0x0C38D26Cu, 0xFE53516Fu,
    0xED03A29Bu, 0x1F682198u, 0x5125DAD3u, 0xA34E59D0u, 0xB01EAA24u, 0x42752927u,
    0x96BF4DCCu, 0x64D4CECFu, 0x77843D3Bu, 0x85EFBE38u, 0xDBFC821Cu, 0x2997011Fu,
    0x3AC7F2EBu, 0xC8AC71E8u, 0x1C661503u, 0xEE0D9600u, 0xFD5D65F4u, 0x0F36E6F7u,
    0x61C69362u, 0x93AD1061u, 0x80FDE395u, 0x72966096u, 0xA65C047Du, 0x5437877Eu,
    0x4767748Au, 0xB50CF789u, 0xEB1FCBADu, 0x197448AEu, 0x0A24BB5Au, 0xF84F3859u,
    0x2C855CB2u, 0xDEEEDFB1u, 0xCDBE2C45u, 0x3FD5AF46u, 0x7198540Du, 0x83F3D70Eu,
    0x90A324FAu, 0x62C8A7F9u, 0xB602C312u, 0x44694011u, 0x5739B3E5u, 0xA55230E6u,
    0xFB410CC2u, 0x092A8FC1u, 0x1A7A7C35u, 0xE811FF36u, 0x3CDB9BDDu, 0xCEB018DEu,
    0xDDE0EB2Au, 0x2F8B6829u, 0x82F63B78u, 0x709DB87Bu, 0x63CD4B8Fu, 0x91A6C88Cu,
    0x456CAC67u, 0xB7072F64u, 0xA457DC90u, 0x563C5F93u, 0x082F63B7u, 0xFA44E0B4u,
    0xE9141340u, 0x1B7F9043u, 0xCFB5F4A8u, 0x3DDE77ABu, 0x2E8E845Fu, 0xDCE5075Cu,
    0x92A8FC17u, 0x60C37F14u, 0x73938CE0u, 0x81F80FE3u, 0x55326B08u, 0xA759E80Bu,
    0xB4091BFFu, 0x466298FCu, 0x1871A4D8u, 0xEA1A27DBu, 0xF94AD42Fu, 0x0B21572Cu,
    0xDFEB33C7u, 0x2D80B0C4u, 0x3ED04330u, 0xCCBBC033u, 0xA24BB5A6u, 0x502036A5u,
    0x4370C551u, 0xB11B4652u, 0x65D122B9u, 0x97BAA1BAu, 0x84EA524Eu, 0x7681D14Du,
    0x2892ED69u, 0xDAF96E6Au, 0xC9A99D9Eu, 0x3BC21E9Du, 0xEF087A76u, 0x1D63F975u,
    0x0E330A81u, 0xFC588982u, 0xB21572C9u, 0x407EF1CAu, 0x532E023Eu, 0xA145813Du,
    0x758FE5D6u, 0x87E466D5u, 0x94B49521u, 0x66DF1622u, 0x38CC2A06u, 0xCAA7A905u,
    0xD9F75AF1u, 0x2B9CD9F2u, 0xFF56BD19u, 0x0D3D3E1Au, 0x1E6DCDEEu, 0xEC064EEDu,
    0xC38D26C4u, 0x31E6A5C7u, 0x22B65633u, 0xD0DDD530u, 0x0417B1DBu, 0xF67C32D8u,
    0xE52CC12Cu, 0x1747422Fu, 0x49547E0Bu, 0xBB3FFD08u, 0xA86F0EFCu, 0x5A048DFFu,
    0x8ECEE914u, 0x7CA56A17u, 0x6FF599E3u, 0x9D9E1AE0u, 0xD3D3E1ABu, 0x21B862A8u,
    0x32E8915Cu, 0xC083125Fu, 0x144976B4u, 0xE622F5B7u, 0xF5720643u, 0x07198540u,
    0x590AB964u, 0xAB613A67u, 0xB831C993u, 0x4A5A4A90u, 0x9E902E7Bu, 0x6CFBAD78u,
    0x7FAB5E8Cu, 0x8DC0DD8Fu, 0xE330A81Au, 0x115B2B19u, 0x020BD8EDu, 0xF0605BEEu,
    0x24AA3F05u, 0xD6C1BC06u, 0xC5914FF2u, 0x37FACCF1u, 0x69E9F0D5u, 0x9B8273D6u,
    0x88D28022u, 0x7AB90321u, 0xAE7367CAu, 0x5C18E4C9u, 0x4F48173Du, 0xBD23943Eu,
    0xF36E6F75u, 0x0105EC76u, 0x12551F82u, 0xE03E9C81u, 0x34F4F86Au, 0xC69F7B69u,
    0xD5CF889Du, 0x27A40B9Eu, 0x79B737BAu, 0x8BDCB4B9u, 0x988C474Du, 0x6AE7C44Eu,
    0xBE2DA0A5u, 0x4C4623A6u, 0x5F16D052u, 0xAD7D5351u,
};

uint32_t pn_crc32c(const void *data, size_t n) {
    const uint8_t *p = (const uint8_t *)data;
    uint32_t c = 0xFFFFFFFFu;
    while (n--) c = pn__crc_table[(c ^ *p++) & 0xFFu] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

float pn_f16_to_f32(uint16_t h) {
    uint32_t sign = (uint32_t)(h & 0x8000u) << 16, exp = (h >> 10) & 0x1Fu, man = h & 0x3FFu, bits;
    float out;
    if (exp == 0) {
        float f = (float)man * 5.9604644775390625e-8f;
        memcpy(&bits, &f, 4);
        bits |= sign;
    } else if (exp == 31) {
        bits = sign | 0x7F800000u | (man << 13);
    } else {
        bits = sign | ((exp + 112u) << 23) | (man << 13);
    }
    memcpy(&out, &bits, 4);
    return out;
}

uint32_t pn_dtype_size(uint8_t dtype) {
    switch (dtype) {
    case PN_DTYPE_U8: return 1;
    case PN_DTYPE_U16: return 2;
    case PN_DTYPE_U32: return 4;
    case PN_DTYPE_I32: return 4;
    case PN_DTYPE_F16: return 2;
    case PN_DTYPE_F32: return 4;
    case PN_DTYPE_F64: return 8;
    case PN_DTYPE_JSON: return 1;
    default: return 0;
    }
}

static uint16_t pn__u16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static uint32_t pn__u32(const uint8_t *p) {
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static uint64_t pn__u64(const uint8_t *p) { return (uint64_t)pn__u32(p) | ((uint64_t)pn__u32(p + 4) << 32); }

/* Checked 64-bit helpers: 0 on overflow, 1 otherwise. */
static int pn__add(uint64_t a, uint64_t b, uint64_t *r) {
    if (a > UINT64_MAX - b) return 0;
    *r = a + b;
    return 1;
}
static int pn__mul(uint64_t a, uint64_t b, uint64_t *r) {
    if (a != 0 && b > UINT64_MAX / a) return 0;
    *r = a * b;
    return 1;
}
static int pn__align64(uint64_t x, uint64_t *r) {
    if (!pn__add(x, 63u, r)) return 0;
    *r &= ~(uint64_t)63u;
    return 1;
}

static int pn__fail(int code, char *err, size_t err_len, const char *msg, uint64_t a, uint64_t b) {
    /* A tiny formatter (no snprintf: it is not guaranteed allocation-free): msg with the
     * first "%" replaced by a and the second by b, in decimal. */
    size_t o = 0;
    int arg = 0;
    if (err == NULL || err_len == 0) return code;
    for (; *msg && o + 1 < err_len; msg++) {
        if (*msg == '%' && arg < 2) {
            char digits[21];
            int nd = 0;
            uint64_t v = arg++ == 0 ? a : b;
            do { digits[nd++] = (char)('0' + (int)(v % 10u)); v /= 10u; } while (v && nd < 21);
            while (nd > 0 && o + 1 < err_len) err[o++] = digits[--nd];
        } else {
            err[o++] = *msg;
        }
    }
    err[o] = '\0';
    return code;
}

static int pn__name_byte(uint8_t b) {
    return (b >= 'A' && b <= 'Z') || (b >= 'a' && b <= 'z') || (b >= '0' && b <= '9') || b == '_' || b == '.' ||
           b == '-';
}

/* Strict UTF-8 (RFC 3629): no overlong forms, no surrogates, nothing above U+10FFFF. */
static int pn__utf8_ok(const uint8_t *p, uint64_t n) {
    uint64_t i = 0;
    while (i < n) {
        uint8_t c = p[i];
        uint64_t need;
        uint8_t lo = 0x80, hi = 0xBF;
        if (c < 0x80) { i++; continue; }
        if (c >= 0xC2 && c <= 0xDF) need = 1;
        else if (c == 0xE0) { need = 2; lo = 0xA0; }
        else if (c >= 0xE1 && c <= 0xEC) need = 2;
        else if (c == 0xED) { need = 2; hi = 0x9F; }
        else if (c >= 0xEE && c <= 0xEF) need = 2;
        else if (c == 0xF0) { need = 3; lo = 0x90; }
        else if (c >= 0xF1 && c <= 0xF3) need = 3;
        else if (c == 0xF4) { need = 3; hi = 0x8F; }
        else return 0;
        if (n - i - 1 < need) return 0;
        if (p[i + 1] < lo || p[i + 1] > hi) return 0;
        {
            uint64_t k;
            for (k = 2; k <= need; k++)
                if (p[i + k] < 0x80 || p[i + k] > 0xBF) return 0;
        }
        i += need + 1;
    }
    return 1;
}

static void pn__fill_section(const pn_asset *a, uint32_t index, pn_section *out) {
    const uint8_t *e = a->bytes + 64u + 96u * (uint64_t)index;
    int k;
    memset(out, 0, sizeof *out);
    memcpy(out->name, e, PN_NAME_LEN);
    out->name[PN_NAME_LEN] = '\0';
    out->dtype = e[32];
    out->rank = e[33];
    out->flags = pn__u16(e + 34);
    out->elements = 1;
    for (k = 0; k < PN_MAX_RANK; k++) {
        out->dims[k] = pn__u32(e + 40 + 4 * k);
        if (k < out->rank) out->elements *= out->dims[k]; /* checked at open: cannot overflow */
    }
    out->offset = pn__u64(e + 64);
    out->byte_len = pn__u64(e + 72);
    out->crc = pn__u32(e + 80);
    out->data = a->bytes + out->offset;
}

int pn_asset_open(const void *data, size_t size, pn_asset *out, char *err, size_t err_len) {
    static const uint8_t magic[8] = {'P', 'E', 'N', 'U', 'M', 'B', 'R', 'A'};
    const uint8_t *b = (const uint8_t *)data;
    uint64_t len = (uint64_t)size, file_size, table_end, first, expected, prev_end;
    uint32_t count, i, j;
    int k, meta = -1;

    if (out == NULL) return pn__fail(PN_ERR_ARGUMENT, err, err_len, "output pointer is NULL", 0, 0);
    memset(out, 0, sizeof *out);
    if (b == NULL && size != 0) return pn__fail(PN_ERR_ARGUMENT, err, err_len, "data is NULL", 0, 0);
    if (err != NULL && err_len > 0) err[0] = '\0';

    /* §10.1–3: identity. */
    if (len < 64) {
        size_t n = size < 8 ? size : 8;
        if (n > 0 && memcmp(b, magic, n) != 0)
            return pn__fail(PN_ERR_BAD_MAGIC, err, err_len, "not a penumbra asset (bad magic)", 0, 0);
        return pn__fail(PN_ERR_TOO_SHORT, err, err_len, "file too short: % bytes, the header alone is 64", len, 0);
    }
    if (memcmp(b, magic, 8) != 0)
        return pn__fail(PN_ERR_BAD_MAGIC, err, err_len, "not a penumbra asset (bad magic)", 0, 0);
    if (pn__u16(b + 8) != 1)
        return pn__fail(PN_ERR_VERSION, err, err_len,
                        "asset format version %.% is not supported (this reader reads 1.x)", pn__u16(b + 8),
                        pn__u16(b + 10));
    /* §10.4–6: header. */
    if (pn__u32(b + 60) != pn_crc32c(b, 60))
        return pn__fail(PN_ERR_HEADER_CRC, err, err_len, "header checksum mismatch", 0, 0);
    for (k = 0; k < 4; k++) {
        uint8_t c = b[12 + k];
        if (!((c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9')))
            return pn__fail(PN_ERR_BAD_KIND, err, err_len, "asset kind is not 4 bytes of [A-Z0-9]", 0, 0);
    }
    count = pn__u32(b + 16);
    if (count < 1 || count > PN_MAX_SECTIONS)
        return pn__fail(PN_ERR_BAD_HEADER, err, err_len, "section_count % not in 1..=4096", count, 0);
    if (pn__u32(b + 20) != 0) return pn__fail(PN_ERR_BAD_HEADER, err, err_len, "header flags are not 0", 0, 0);
    if (pn__u64(b + 24) != 64)
        return pn__fail(PN_ERR_BAD_HEADER, err, err_len, "table_offset % is not 64", pn__u64(b + 24), 0);
    for (k = 44; k < 60; k++)
        if (b[k] != 0) return pn__fail(PN_ERR_BAD_HEADER, err, err_len, "reserved header bytes are not 0", 0, 0);
    /* §10.7–9: size and table. count ≤ 4096, so these cannot overflow. */
    file_size = pn__u64(b + 32);
    if (len < file_size)
        return pn__fail(PN_ERR_TRUNCATED, err, err_len, "truncated: file_size is % but only % bytes", file_size, len);
    if (len > file_size)
        return pn__fail(PN_ERR_TRAILING, err, err_len, "trailing bytes: file_size is % but % bytes", file_size, len);
    table_end = 64u + 96u * (uint64_t)count;
    first = (table_end + 63u) & ~(uint64_t)63u;
    if (file_size < first)
        return pn__fail(PN_ERR_BAD_HEADER, err, err_len, "file_size % ends before the section table (%)", file_size,
                        first);
    if (pn__u32(b + 40) != pn_crc32c(b + 64, (size_t)(table_end - 64u)))
        return pn__fail(PN_ERR_TABLE_CRC, err, err_len, "section table checksum mismatch", 0, 0);

    /* §10.10: entries in order. */
    expected = first;
    prev_end = table_end;
    for (i = 0; i < count; i++) {
        const uint8_t *e = b + 64u + 96u * (uint64_t)i;
        uint64_t elements = 1, want, length, offset, end, p;
        uint8_t dtype = e[32], rank = e[33];
        int name_len = PN_NAME_LEN;
        for (k = 0; k < PN_NAME_LEN; k++)
            if (e[k] == 0) { name_len = k; break; }
        if (name_len == 0) return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: empty name", i, 0);
        for (k = 0; k < PN_NAME_LEN; k++) {
            if (k < name_len ? !pn__name_byte(e[k]) : e[k] != 0)
                return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: bad name byte at %", i, (uint64_t)k);
        }
        if (pn_dtype_size(dtype) == 0)
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: unknown element type %", i, dtype);
        if (rank < 1 || rank > PN_MAX_RANK || (dtype == PN_DTYPE_JSON && rank != 1))
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: bad rank %", i, rank);
        if ((pn__u16(e + 34) & ~PN_SECTION_CRITICAL) != 0)
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: unknown flags", i, 0);
        if (pn__u32(e + 36) != 0)
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: reserved field not 0", i, 0);
        for (k = 84; k < 96; k++)
            if (e[k] != 0) return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: reserved field not 0", i, 0);
        for (k = 0; k < PN_MAX_RANK; k++) {
            uint32_t d = pn__u32(e + 40 + 4 * k);
            if (k >= rank) {
                if (d != 0) return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: dim % beyond rank", i, k);
            } else if (!pn__mul(elements, d, &elements)) {
                return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: length overflows", i, 0);
            }
        }
        if (!pn__mul(elements, pn_dtype_size(dtype), &want))
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: length overflows", i, 0);
        length = pn__u64(e + 72);
        if (length != want)
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: length is not dims x size (%)", i, want);
        offset = pn__u64(e + 64);
        if (offset != expected)
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: offset is not the canonical %", i, expected);
        if (!pn__add(offset, length, &end) || end > file_size)
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: data ends beyond the file (size %)", i,
                            file_size);
        for (p = prev_end; p < offset; p++)
            if (b[p] != 0) return pn__fail(PN_ERR_PADDING, err, err_len, "non-zero padding at offset %", p, 0);
        prev_end = end;
        if (!pn__align64(prev_end, &expected))
            return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: length overflows", i, 0);
    }
    /* §10.11 */
    if (file_size != prev_end)
        return pn__fail(PN_ERR_BAD_HEADER, err, err_len, "file_size % is not the end of the last section (%)",
                        file_size, prev_end);
    /* §10.12: unique names, reported at the later entry. Quadratic (no allocation): at most
     * 4096·4095/2 comparisons of 32 bytes. */
    for (j = 1; j < count; j++)
        for (i = 0; i < j; i++)
            if (memcmp(b + 64u + 96u * (uint64_t)i, b + 64u + 96u * (uint64_t)j, PN_NAME_LEN) == 0)
                return pn__fail(PN_ERR_BAD_SECTION, err, err_len, "section %: duplicate name", j, 0);
    /* §10.13 */
    for (i = 0; i < count && meta < 0; i++)
        if (memcmp(b + 64u + 96u * (uint64_t)i, "meta\0\0\0\0", 8) == 0 && b[64u + 96u * (uint64_t)i + 8] == 0)
            meta = (int)i;
    if (meta < 0) return pn__fail(PN_ERR_MISSING_META, err, err_len, "no meta section", 0, 0);
    if (b[64u + 96u * (uint64_t)meta + 32] != PN_DTYPE_JSON)
        return pn__fail(PN_ERR_META_NOT_JSON, err, err_len, "meta section is not json", 0, 0);
    /* §10.14–15 (the entries were validated above, so offset + length is in bounds). */
    for (i = 0; i < count; i++) {
        const uint8_t *e = b + 64u + 96u * (uint64_t)i;
        if (pn_crc32c(b + pn__u64(e + 64), (size_t)pn__u64(e + 72)) != pn__u32(e + 80))
            return pn__fail(PN_ERR_SECTION_CRC, err, err_len, "section %: data checksum mismatch", i, 0);
    }
    for (i = 0; i < count; i++) {
        const uint8_t *e = b + 64u + 96u * (uint64_t)i;
        if (e[32] == PN_DTYPE_JSON && !pn__utf8_ok(b + pn__u64(e + 64), pn__u64(e + 72)))
            return pn__fail(PN_ERR_UTF8, err, err_len, "section %: json is not valid UTF-8", i, 0);
    }

    out->bytes = b;
    out->size = file_size;
    out->section_count = count;
    out->major = 1;
    out->minor = pn__u16(b + 10);
    memcpy(out->kind, b + 12, 4);
    out->kind[4] = '\0';
    return PN_OK;
}

void pn_asset_kind(const pn_asset *a, char out[5]) {
    if (out == NULL) return;
    if (a == NULL) { out[0] = '\0'; return; }
    memcpy(out, a->kind, 5);
}

void pn_asset_version(const pn_asset *a, uint16_t *major, uint16_t *minor) {
    if (major) *major = a ? a->major : 0;
    if (minor) *minor = a ? a->minor : 0;
}

uint32_t pn_asset_section_count(const pn_asset *a) { return a ? a->section_count : 0; }

int pn_asset_section(const pn_asset *a, uint32_t index, pn_section *out) {
    if (a == NULL || out == NULL || a->bytes == NULL || index >= a->section_count) return PN_ERR_ARGUMENT;
    pn__fill_section(a, index, out);
    return PN_OK;
}

int pn_asset_find(const pn_asset *a, const char *name, pn_section *out) {
    uint32_t i;
    size_t n;
    if (a == NULL || name == NULL || out == NULL || a->bytes == NULL) return PN_ERR_ARGUMENT;
    n = strlen(name);
    if (n == 0 || n > PN_NAME_LEN) return PN_ERR_NOT_FOUND;
    for (i = 0; i < a->section_count; i++) {
        const uint8_t *e = a->bytes + 64u + 96u * (uint64_t)i;
        if (memcmp(e, name, n) == 0 && (n == PN_NAME_LEN || e[n] == 0)) {
            pn__fill_section(a, i, out);
            return PN_OK;
        }
    }
    return PN_ERR_NOT_FOUND;
}

#endif /* PENUMBRA_ASSET_IMPLEMENTED */
#endif /* PENUMBRA_ASSET_IMPLEMENTATION */
