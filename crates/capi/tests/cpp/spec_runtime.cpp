// The FIV lookup (schemas/asset-format.md §15.2) and the MRT one-bounce step (§15.3), written
// from the spec text alone, against the runtime behind the C ABI (crates/capi/tests/spec_runtime.rs).
// Usage: spec_runtime OCCLUDER.fivt DICTIONARY.mrtd LEVEL.mrtl
// Prints "<quantity> <max relative error> <values compared> <values non-zero>" lines.
#define PENUMBRA_ASSET_IMPLEMENTATION
#include "penumbra_asset.h"
#include "penumbra.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace {

using V3 = std::array<float, 3>;

struct File {
    std::vector<unsigned char> storage;
    const unsigned char *data = nullptr;
    size_t size = 0;
    pn_asset asset{};
};

bool load(const char *path, File &f) {
    std::ifstream in(path, std::ios::binary);
    std::vector<unsigned char> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    f.storage.assign(b.size() + 64, 0);
    size_t shift = (64 - reinterpret_cast<uintptr_t>(f.storage.data()) % 64) % 64;
    std::copy(b.begin(), b.end(), f.storage.begin() + static_cast<std::ptrdiff_t>(shift));
    f.data = f.storage.data() + shift;
    f.size = b.size();
    char err[256];
    if (pn_asset_open(f.data, f.size, &f.asset, err, sizeof err) != 0) {
        std::fprintf(stderr, "%s: %s\n", path, err);
        return false;
    }
    return true;
}

bool section(const File &f, const std::string &name, pn_section &s) { return pn_asset_find(&f.asset, name.c_str(), &s) == 0; }

const float *f32(const File &f, const std::string &name) {
    pn_section s;
    if (!section(f, name, s) || s.dtype != PN_DTYPE_F32) return nullptr;
    return static_cast<const float *>(s.data);
}

float dot(const V3 &a, const V3 &b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V3 sub(const V3 &a, const V3 &b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

// Relative error with a floor: values far below the largest compared one are judged against it.
struct Err {
    double max_rel = 0, scale = 0;
    size_t n = 0, nonzero = 0;
    std::vector<std::pair<double, double>> pairs;
    void add(double spec, double runtime) {
        pairs.emplace_back(spec, runtime);
        scale = std::max(scale, std::fabs(runtime));
    }
    void finish(const char *what) {
        for (auto [a, b] : pairs) {
            double den = std::max(std::fabs(b), 1e-3 * scale);
            if (den > 0) max_rel = std::max(max_rel, std::fabs(a - b) / den);
            n++;
            nonzero += b != 0.0;
        }
        std::printf("%s %.3e %zu %zu\n", what, max_rel, n, nonzero);
    }
};

// ---- §15.2 FIV lookup, from the spec ----
struct Fiv {
    size_t A, P, K, S;
    const float *fiv, *irr, *env;
    const uint8_t *inside;
    V3 c, e1, e2, e3;
    float R, rmin, rmax;
};

bool read_fiv(const File &f, Fiv &t) {
    pn_section s, ins, irr;
    if (!section(f, "fiv", s) || s.dtype != PN_DTYPE_F32 || !section(f, "inside", ins) || !section(f, "irradiance", irr))
        return false;
    t.A = s.dims[0], t.P = s.dims[1], t.K = s.dims[2], t.S = irr.dims[1];
    t.fiv = static_cast<const float *>(s.data);
    t.inside = static_cast<const uint8_t *>(ins.data);
    t.irr = static_cast<const float *>(irr.data);
    t.env = f32(f, "env_fiv");
    const float *fr = f32(f, "frame"), *radii = f32(f, "radii");
    if (!fr || !radii || !t.env) return false;
    t.c = {fr[0], fr[1], fr[2]}, t.e1 = {fr[3], fr[4], fr[5]}, t.e2 = {fr[6], fr[7], fr[8]}, t.e3 = {fr[9], fr[10], fr[11]};
    t.R = radii[0], t.rmin = radii[1], t.rmax = radii[2];
    return true;
}

// Steps 1–4: the occluded FIV [rgb][xyz]; false when every corner is inside.
bool occluded_fiv(const Fiv &t, const V3 &q, float out[3][3]) {
    const float PI = 3.14159265358979f, TAU = 6.28318530717959f;
    float x1 = dot(q, t.e1), x2 = dot(q, t.e2), x3 = dot(q, t.e3);
    float rho = std::sqrt(x1 * x1 + x2 * x2 + x3 * x3), theta = 0, phi = 0;
    if (rho > 0) {
        theta = std::atan2(x1, x3);
        if (theta < 0) theta += TAU;
        phi = std::acos(std::clamp(x2 / rho, -1.0f, 1.0f));
    }
    float u = theta / TAU * static_cast<float>(t.A);
    float v = std::clamp(phi / PI * static_cast<float>(t.P - 1), 0.0f, static_cast<float>(t.P - 1));
    float rt = rho / t.R;
    float w = (rt - t.rmin) / (t.rmax - t.rmin) * static_cast<float>(t.K - 1);
    w = std::isfinite(w) ? std::clamp(w, 0.0f, static_cast<float>(t.K - 1)) : 0.0f;
    long long ui = static_cast<long long>(std::floor(u));
    size_t i0 = static_cast<size_t>(((ui % static_cast<long long>(t.A)) + static_cast<long long>(t.A)) % static_cast<long long>(t.A));
    size_t i1 = (i0 + 1) % t.A;
    float fu = std::clamp(u - std::floor(u), 0.0f, 1.0f);
    size_t j0 = std::min(static_cast<size_t>(std::floor(v)), t.P - 2);
    float fv = std::clamp(v - static_cast<float>(j0), 0.0f, 1.0f);
    size_t k0 = std::min(static_cast<size_t>(std::floor(w)), t.K - 2);
    float fw = std::clamp(w - static_cast<float>(k0), 0.0f, 1.0f);
    float delta = t.rmin > 0 ? t.rmin : t.rmin + (t.rmax - t.rmin) * 1.0f / static_cast<float>(t.K - 1);
    float s = std::fmax(rt, delta);
    float acc[3][3] = {}, plain[3][3] = {}, wsum = 0;
    int valid = 0;
    for (int a = 0; a < 2; a++)
        for (int b = 0; b < 2; b++)
            for (int c = 0; c < 2; c++) {
                size_t i = a ? i1 : i0, j = j0 + static_cast<size_t>(b), k = k0 + static_cast<size_t>(c);
                if (t.inside[(i * t.P + j) * t.K + k]) continue;
                float sk = t.rmin + (t.rmax - t.rmin) * static_cast<float>(k) / static_cast<float>(t.K - 1);
                sk = std::max(sk, delta);
                float sc = (sk / s) * (sk / s);
                float wt = (a ? fu : 1 - fu) * (b ? fv : 1 - fv) * (c ? fw : 1 - fw);
                const float *x = t.fiv + ((i * t.P + j) * t.K + k) * 9;
                for (int ch = 0; ch < 3; ch++)
                    for (int d = 0; d < 3; d++) {
                        acc[ch][d] += wt * (sc * x[ch * 3 + d]);
                        plain[ch][d] += sc * x[ch * 3 + d];
                    }
                wsum += wt;
                valid++;
            }
    if (valid == 0) return false;
    for (int ch = 0; ch < 3; ch++)
        for (int d = 0; d < 3; d++) out[ch][d] = wsum > 0 ? acc[ch][d] / wsum : plain[ch][d] / static_cast<float>(valid);
    return true;
}

// Step 5 (partial = none).
V3 occluded(const Fiv &t, const V3 &center, const V3 &p, const V3 &n) {
    if (dot(sub(center, p), n) <= -t.R) return {0, 0, 0};
    float f[3][3];
    if (!occluded_fiv(t, sub(p, center), f)) return {0, 0, 0};
    V3 o;
    for (int c = 0; c < 3; c++) o[c] = std::max(0.0f, f[c][0] * n[0] + f[c][1] * n[1] + f[c][2] * n[2]);
    return o;
}

// Step 6: the unoccluded irradiance.
V3 face_dir(int f, float s, float t) {
    float a = 2 * s - 1, b = 2 * t - 1;
    switch (f) {
    case 0: return {1, -b, -a};
    case 1: return {-1, -b, a};
    case 2: return {a, 1, b};
    case 3: return {a, -1, -b};
    case 4: return {a, -b, 1};
    default: return {-a, -b, -1};
    }
}
void face_of(const V3 &d, int &f, float &s, float &t) {
    float ax = std::fabs(d[0]), ay = std::fabs(d[1]), az = std::fabs(d[2]), sc, tc, ma;
    if (ax >= ay && ax >= az) {
        f = d[0] > 0 ? 0 : 1, sc = d[0] > 0 ? -d[2] : d[2], tc = -d[1], ma = ax;
    } else if (ay >= az) {
        f = d[1] > 0 ? 2 : 3, sc = d[0], tc = d[1] > 0 ? d[2] : -d[2], ma = ay;
    } else {
        f = d[2] > 0 ? 4 : 5, sc = d[2] > 0 ? d[0] : -d[0], tc = -d[1], ma = az;
    }
    if (!(ma > 0)) { f = 0, s = 0.5f, t = 0.5f; return; }
    s = std::clamp(0.5f * (sc / ma + 1), 0.0f, 1.0f);
    t = std::clamp(0.5f * (tc / ma + 1), 0.0f, 1.0f);
}
V3 total(const Fiv &t, const V3 &n) {
    int f;
    float s, tt;
    face_of(n, f, s, tt);
    float S = static_cast<float>(t.S), x = s * S - 0.5f, y = tt * S - 0.5f, x0 = std::floor(x), y0 = std::floor(y);
    float fx = x - x0, fy = y - y0;
    V3 out{0, 0, 0};
    for (int dj = 0; dj < 2; dj++)
        for (int di = 0; di < 2; di++) {
            long long i = static_cast<long long>(x0) + di, j = static_cast<long long>(y0) + dj, N = static_cast<long long>(t.S);
            int g = f;
            size_t ii, jj;
            if (i >= 0 && i < N && j >= 0 && j < N) {
                ii = static_cast<size_t>(i), jj = static_cast<size_t>(j);
            } else {
                float gs, gt;
                face_of(face_dir(f, (static_cast<float>(i) + 0.5f) / S, (static_cast<float>(j) + 0.5f) / S), g, gs, gt);
                ii = std::min(static_cast<size_t>(gs * S), t.S - 1), jj = std::min(static_cast<size_t>(gt * S), t.S - 1);
            }
            const float *v = t.irr + ((static_cast<size_t>(g) * t.S + jj) * t.S + ii) * 3;
            float wgt = (di ? fx : 1 - fx) * (dj ? fy : 1 - fy);
            for (int c = 0; c < 3; c++) out[c] += wgt * v[c];
        }
    return out;
}

// Step 7: two occluders with the overlap correction.
float lens(float r1, float r2, float d) {
    const double PI = 3.14159265358979323846;
    if (d >= r1 + r2) return 0;
    if (d <= std::fabs(r1 - r2)) { float r = std::min(r1, r2); return static_cast<float>(PI) * r * r; }
    double a = r1, b = r2, e = d;
    double a1 = std::acos(std::clamp((e * e + a * a - b * b) / (2 * e * a), -1.0, 1.0));
    double a2 = std::acos(std::clamp((e * e + b * b - a * a) / (2 * e * b), -1.0, 1.0));
    double k = std::sqrt(std::max(0.0, (-e + a + b) * (e + a - b) * (e - a + b) * (e + a + b)));
    return static_cast<float>(a * a * a1 + b * b * a2 - 0.5 * k);
}
V3 combined(const Fiv &t, const V3 c[2], const V3 &p, const V3 &n) {
    const float PI = 3.14159265358979f;
    float sg = std::copysign(1.0f, n[2]), a = -1 / (sg + n[2]), b = n[0] * n[1] * a;
    V3 t1{1 + sg * n[0] * n[0] * a, sg * b, -sg * n[0]}, t2{b, sg + n[1] * n[1] * a, -n[1]};
    V3 O[2], S{0, 0, 0}, M{0, 0, 0};
    bool has[2];
    float dc[2][2], dr[2];
    for (int o = 0; o < 2; o++) {
        O[o] = occluded(t, c[o], p, n);
        V3 v = sub(c[o], p);
        float h = dot(v, n);
        has[o] = h > 0;
        h = std::max(h, 1e-3f * t.R);
        if (has[o]) dc[o][0] = dot(v, t1) / h, dc[o][1] = dot(v, t2) / h, dr[o] = t.R / h;
        for (int ch = 0; ch < 3; ch++) S[ch] += O[o][ch], M[ch] = std::max(M[ch], O[o][ch]);
    }
    V3 tot = S;
    if (has[0] && has[1]) {
        float dist = std::sqrt((dc[0][0] - dc[1][0]) * (dc[0][0] - dc[1][0]) + (dc[0][1] - dc[1][1]) * (dc[0][1] - dc[1][1]));
        float l = lens(dr[0], dr[1], dist);
        if (l > 0) {
            float share = l / (PI * (dr[0] * dr[0] + dr[1] * dr[1]));
            for (int ch = 0; ch < 3; ch++) tot[ch] -= share * (O[0][ch] + O[1][ch]);
        }
    }
    for (int ch = 0; ch < 3; ch++) tot[ch] = std::clamp(tot[ch], M[ch], S[ch]);
    return tot;
}

// A small deterministic generator.
struct Rng {
    uint64_t s = 0x9E3779B97F4A7C15ull;
    float next() {
        s ^= s >> 12, s ^= s << 25, s ^= s >> 27;
        return static_cast<float>((s * 0x2545F4914F6CDD1Dull) >> 40) / 16777216.0f;
    }
    V3 unit() {
        for (;;) {
            V3 v{2 * next() - 1, 2 * next() - 1, 2 * next() - 1};
            float l = std::sqrt(dot(v, v));
            if (l > 0.1f && l <= 1) return {v[0] / l, v[1] / l, v[2] / l};
        }
    }
};

int fiv_checks(const File &ff) {
    Fiv t;
    if (!read_fiv(ff, t)) return 2;
    char err[256];
    pn_fiv_table *table = nullptr;
    if (pn_fiv_table_open(ff.data, ff.size, &table, err, sizeof err) != PN_OK) { std::fprintf(stderr, "%s\n", err); return 2; }
    V3 c2{t.c[0] + 1.1f * t.R, t.c[1], t.c[2] + 0.4f * t.R};
    pn_fiv_placed one[1] = {{table, {t.c[0], t.c[1], t.c[2]}}};
    pn_fiv_placed two[2] = {one[0], {table, {c2[0], c2[1], c2[2]}}};
    pn_fiv_scene *s1 = nullptr, *s2 = nullptr;
    if (pn_fiv_scene_new(one, 1, PN_FIV_PARTIAL_NONE, true, &s1, err, sizeof err) != PN_OK ||
        pn_fiv_scene_new(two, 2, PN_FIV_PARTIAL_NONE, true, &s2, err, sizeof err) != PN_OK) {
        std::fprintf(stderr, "%s\n", err);
        return 2;
    }
    Err lookup, irr, overlap;
    Rng rng;
    const V3 cs[2] = {t.c, c2};
    for (int k = 0; k < 4000; k++) {
        // receivers from inside the ball to beyond r_max, any normal
        V3 d = rng.unit(), n = rng.unit();
        float rr = 0.2f + 10.0f * rng.next();
        V3 p{t.c[0] + d[0] * rr * t.R, t.c[1] + d[1] * rr * t.R, t.c[2] + d[2] * rr * t.R};
        V3 spec = occluded(t, t.c, p, n), rt, spec2 = combined(t, cs, p, n), rt2, et = total(t, n), rte;
        pn_fiv_scene_occluded(s1, p.data(), n.data(), rt.data());
        pn_fiv_scene_occluded(s2, p.data(), n.data(), rt2.data());
        pn_fiv_table_irradiance(table, n.data(), rte.data());
        for (int ch = 0; ch < 3; ch++) {
            lookup.add(spec[ch], rt[ch]);
            overlap.add(spec2[ch], rt2[ch]);
            irr.add(et[ch], rte[ch]);
        }
    }
    lookup.finish("fiv_occluded");
    overlap.finish("fiv_overlap");
    irr.finish("fiv_irradiance");
    pn_fiv_scene_free(s1);
    pn_fiv_scene_free(s2);
    pn_fiv_table_free(table);
    return 0;
}

// ---- §15.3 MRT one bounce, from the spec ----
int mrt_checks(const File &df, const File &lf) {
    static const char *names[] = {"closed", "dead_end", "straight", "corner", "tee", "cross"};
    static const char *tokens[6] = {"nx", "px", nullptr, nullptr, "nz", "pz"};
    struct Shape {
        std::string name;
        size_t n, kb, F;
        const uint8_t *faces;
        const float *u_b, *t_d2b;
        const uint32_t *u_r_idx[6];
    };
    std::vector<Shape> shapes;
    for (const char *nm : names) {
        pn_section ub, td, fc;
        std::string b = nm;
        if (!section(df, b + ".u_b", ub) || !section(df, b + ".t_d2b", td) || !section(df, b + ".faces", fc)) continue;
        Shape s{b, ub.dims[0], ub.dims[1], fc.dims[0], static_cast<const uint8_t *>(fc.data), static_cast<const float *>(ub.data),
                static_cast<const float *>(td.data), {}};
        for (int g = 0; g < 6; g++) {
            pn_section ix;
            if (tokens[g] && section(df, b + ".u_r_idx." + tokens[g], ix)) s.u_r_idx[g] = static_cast<const uint32_t *>(ix.data);
        }
        shapes.push_back(s);
    }
    bool exclude = false;
    pn_section fl;
    if (section(df, "iface.flags", fl)) exclude = (static_cast<const uint32_t *>(fl.data)[0] & 1u) != 0;
    pn_section ur, blocks, recs, tb;
    if (!section(df, "iface.u_r", ur) || !section(lf, "blocks", blocks) || !section(lf, "records", recs) || !section(lf, "t_b2r", tb)) return 2;
    const float *u_r = static_cast<const float *>(ur.data), *t_b2r = static_cast<const float *>(tb.data);
    size_t k_r = ur.dims[1], KB = tb.dims[2], B = blocks.dims[0], P = recs.dims[0];
    const uint32_t *bl = static_cast<const uint32_t *>(blocks.data), *rc = static_cast<const uint32_t *>(recs.data);
    std::vector<size_t> off(B + 1, 0);
    for (size_t x = 0; x < B; x++) off[x + 1] = off[x] + shapes[bl[2 * x]].n;
    size_t N = off[B];
    std::vector<float> l(N), out(N, 0.0f), bsum(B * KB, 0.0f);
    Rng rng;
    for (auto &v : l) v = rng.next();
    for (size_t x = 0; x < B; x++) {
        const Shape &s = shapes[bl[2 * x]];
        size_t R2 = s.n / s.F;
        std::vector<float> bg(s.F * s.kb, 0.0f);
        for (size_t g = 0; g < s.F; g++)
            for (size_t i = 0; i < s.kb; i++) {
                float acc = 0;
                for (size_t t = g * R2; t < (g + 1) * R2; t++) acc += s.t_d2b[i * s.n + t] * l[off[x] + t];
                bg[g * s.kb + i] = acc;
                bsum[x * KB + i] += acc;
            }
        for (size_t g = 0; g < s.F; g++)
            for (size_t t = g * R2; t < (g + 1) * R2; t++) {
                float acc = 0;
                for (size_t i = 0; i < s.kb; i++) acc += s.u_b[t * s.kb + i] * (bsum[x * KB + i] - (exclude ? bg[g * s.kb + i] : 0.0f));
                out[off[x] + t] = acc;
            }
    }
    for (size_t p = 0; p < P;) {
        uint32_t dst = rc[3 * p], face = rc[3 * p + 1];
        std::vector<float> r(k_r, 0.0f);
        for (; p < P && rc[3 * p] == dst && rc[3 * p + 1] == face; p++) {
            const float *op = t_b2r + p * k_r * KB;
            for (size_t j = 0; j < k_r; j++)
                for (size_t i = 0; i < KB; i++) r[j] += op[j * KB + i] * bsum[rc[3 * p + 2] * KB + i];
        }
        const Shape &s = shapes[bl[2 * dst]];
        const uint32_t *idx = face < 6 ? s.u_r_idx[face] : nullptr;
        if (!idx) continue;
        for (size_t t = 0; t < s.n; t++) {
            float acc = 0;
            for (size_t j = 0; j < k_r; j++) acc += u_r[idx[t] * k_r + j] * r[j];
            out[off[dst] + t] += acc;
        }
    }
    char err[256];
    pn_mrt *m = nullptr;
    if (pn_mrt_open(df.data, df.size, lf.data, lf.size, &m, err, sizeof err) != PN_OK) { std::fprintf(stderr, "%s\n", err); return 2; }
    std::vector<float> rt(N);
    if (pn_mrt_texel_count(m) != N || pn_mrt_indirect(m, l.data(), rt.data(), N, true) != PN_OK) return 2;
    Err e;
    for (size_t t = 0; t < N; t++) e.add(out[t], rt[t]);
    e.finish("mrt_one_bounce");
    pn_mrt_free(m);
    return 0;
}

}  // namespace

int main(int argc, char **argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: %s OCCLUDER.fivt DICTIONARY.mrtd LEVEL.mrtl\n", argv[0]);
        return 2;
    }
    File ff, df, lf;
    if (!load(argv[1], ff) || !load(argv[2], df) || !load(argv[3], lf)) return 2;
    int st = fiv_checks(ff);
    return st ? st : mrt_checks(df, lf);
}
