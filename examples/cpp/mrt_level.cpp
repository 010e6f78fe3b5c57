// mrt_level: the MRT runtime of a level through the C ABI, from C++17.
// Usage: mrt_level DICTIONARY.mrtd LEVEL.mrtl
// Direct light: 1 + 0.25·(t mod 5) at every texel t of block 0, 0 elsewhere. Prints "T texels B blocks A w h", then per
// texel "t i l_d one_bounce one_bounce_no_interfaces three_bounces", then per non-zero atlas
// pixel "a index value" of the padded one-bounce atlas. Exit 0 on success, 2 on bad input.
#include "penumbra.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

namespace {

// Owns the file bytes in 64-byte aligned storage (the handle borrows them).
struct File {
    std::vector<unsigned char> storage;
    const unsigned char *data = nullptr;
    size_t size = 0;
};

bool read_file(const char *path, File &f) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    f.storage.assign(bytes.size() + 64, 0);
    size_t shift = (64 - reinterpret_cast<uintptr_t>(f.storage.data()) % 64) % 64;
    std::copy(bytes.begin(), bytes.end(), f.storage.begin() + static_cast<std::ptrdiff_t>(shift));
    f.data = f.storage.data() + shift;
    f.size = bytes.size();
    return true;
}

struct MrtDeleter {
    void operator()(pn_mrt *m) const { pn_mrt_free(m); }
};

}  // namespace

int main(int argc, char **argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s DICTIONARY.mrtd LEVEL.mrtl\n", argv[0]);
        return 2;
    }
    File dict, level;
    if (!read_file(argv[1], dict) || !read_file(argv[2], level)) {
        std::fprintf(stderr, "cannot read the inputs\n");
        return 2;
    }
    char err[256];
    pn_mrt *raw = nullptr;
    if (pn_mrt_open(dict.data, dict.size, level.data, level.size, &raw, err, sizeof err) != PN_OK) {
        std::fprintf(stderr, "%s\n", err);
        return 2;
    }
    std::unique_ptr<pn_mrt, MrtDeleter> mrt(raw);
    const size_t n = pn_mrt_texel_count(mrt.get());
    const size_t first_other = pn_mrt_block_offset(mrt.get(), 1);
    size_t w = 0, h = 0;
    pn_mrt_atlas_size(mrt.get(), &w, &h);
    std::vector<float> l_d(n, 0.0f), one(n), local(n), multi(n), atlas(w * h, 0.0f);
    for (size_t t = 0; t < first_other && t < n; ++t) l_d[t] = 1.0f + 0.25f * static_cast<float>(t % 5);
    if (pn_mrt_indirect(mrt.get(), l_d.data(), one.data(), n, true) != PN_OK ||
        pn_mrt_indirect(mrt.get(), l_d.data(), local.data(), n, false) != PN_OK ||
        pn_mrt_multi_bounce(mrt.get(), l_d.data(), multi.data(), n, 3, 0.5f) != PN_OK ||
        pn_mrt_pad_atlas(mrt.get(), one.data(), n, atlas.data(), atlas.size()) != PN_OK) {
        std::fprintf(stderr, "evaluation failed\n");
        return 2;
    }
    std::printf("T %zu B %zu A %zu %zu\n", n, pn_mrt_block_count(mrt.get()), w, h);
    for (size_t t = 0; t < n; ++t)
        std::printf("t %zu %.9g %.9g %.9g %.9g\n", t, l_d[t], one[t], local[t], multi[t]);
    for (size_t i = 0; i < atlas.size(); ++i)
        if (atlas[i] != 0.0f) std::printf("a %zu %.9g\n", i, atlas[i]);
    return 0;
}
