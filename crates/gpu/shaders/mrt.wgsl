// MRT runtime, the WGSL twin of penumbra_runtime::mrt::MrtRuntime (MRT thesis §3.6.3, ch. 4).
// f32 only. One evaluation of one-bounce indirect light is four dispatches in this order:
//   project   b = T_d→b l_d per block, and b_g per face slot            (§4.4)
//   apply_ub  U_b b, or U_b (b − b_g) at the texels of face g           (§4.4.3, same-face rule)
//   respond   r = Σ_src T_b→r b_src per (receiving block, entering face) (§4.5.1)
//   apply_ur  += U_r r through the entering face's row index            (§4.5.2)
// Multi-bounce (§3.6.3) repeats them, `feedback` scaling each bounce by the albedo ratio and
// feeding it back as direct light; `pad_tiles` + `pad_border` write the padded atlas (§4.6).
// Buffer layouts: docs/engine-integration.md, "GPU shaders".

struct Params {
    n_blocks: u32,
    kb: u32,         // the level's k_b (stride of b, b_face and the T_b→r rows)
    k_r: u32,
    r2: u32,         // texels per face (R²)
    exclude: u32,    // 1: the same-face exclusion rule
    n_groups: u32,
    n_texels: u32,
    res: u32,        // R
    atlas_w: u32,
    n_tiles: u32,
    n_pad: u32,
    albedo_scale: f32,
}

// Per shape, SHAPE_STRIDE u32: n, k_b, face count, U_b offset, T_d→b offset (floats),
// U_r row-index offset per face 0..5 (u32s; NONE when the shape has no interface there),
// face of each texel slot 0..5 (NONE beyond the face count), padding.
const SHAPE_STRIDE: u32 = 20u;
const NONE: u32 = 0xffffffffu;

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> shapes: array<u32>;
// Per block: shape, first texel, first and one-past-last response group with this block as dst.
@group(0) @binding(2) var<storage, read> blocks: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> u_b: array<f32>;
@group(0) @binding(4) var<storage, read> t_d2b: array<f32>;
@group(0) @binding(5) var<storage, read_write> l_d: array<f32>;
@group(0) @binding(6) var<storage, read_write> b: array<f32>;
@group(0) @binding(7) var<storage, read_write> b_face: array<f32>;
@group(0) @binding(8) var<storage, read_write> out: array<f32>;
// Per response group: dst block, entering face, first and one-past-last record.
@group(0) @binding(9) var<storage, read> groups: array<vec4<u32>>;
@group(0) @binding(10) var<storage, read> rec_src: array<u32>;
@group(0) @binding(11) var<storage, read> t_b2r: array<f32>;
@group(0) @binding(12) var<storage, read_write> r: array<f32>;
@group(0) @binding(13) var<storage, read> u_r_idx: array<u32>;
@group(0) @binding(14) var<storage, read> u_r: array<f32>;
@group(0) @binding(15) var<storage, read_write> total: array<f32>;
// Atlas tiles (block, face, x0, y0) and border records (atlas pixel, block, texel).
@group(0) @binding(16) var<storage, read> tiles: array<vec4<u32>>;
@group(0) @binding(17) var<storage, read> pad: array<u32>;
@group(0) @binding(18) var<storage, read_write> atlas: array<f32>;

fn shape_of(x: u32) -> u32 {
    return blocks[x].x * SHAPE_STRIDE;
}

// Dispatch (⌈kb/64⌉, n_blocks): invocation (i, x) writes b_g[x][slot][i] for every slot and
// b[x][i] = Σ_g b_g (zero for i ≥ the shape's k_b and for absent slots).
@compute @workgroup_size(64)
fn project(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    let x = id.y;
    if (i >= p.kb || x >= p.n_blocks) {
        return;
    }
    let s = shape_of(x);
    let n = shapes[s];
    let kb_s = shapes[s + 1u];
    let faces = shapes[s + 2u];
    let td = shapes[s + 4u];
    let off = blocks[x].y;
    var sum = 0.0;
    for (var slot = 0u; slot < 6u; slot++) {
        var v = 0.0;
        if (i < kb_s && slot < faces) {
            let row = td + i * n + slot * p.r2;
            let l0 = off + slot * p.r2;
            for (var t = 0u; t < p.r2; t++) {
                v += t_d2b[row + t] * l_d[l0 + t];
            }
        }
        b_face[(x * 6u + slot) * p.kb + i] = v;
        sum += v;
    }
    b[x * p.kb + i] = sum;
}

// Dispatch (⌈max n/64⌉, n_blocks): out[t] = U_b[t] · b (minus b_g of the texel's face slot).
@compute @workgroup_size(64)
fn apply_ub(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = id.x;
    let x = id.y;
    if (x >= p.n_blocks) {
        return;
    }
    let s = shape_of(x);
    let n = shapes[s];
    if (t >= n) {
        return;
    }
    let kb_s = shapes[s + 1u];
    let ub = shapes[s + 3u] + t * kb_s;
    let slot = t / p.r2;
    var v = 0.0;
    for (var i = 0u; i < kb_s; i++) {
        var e = b[x * p.kb + i];
        if (p.exclude == 1u) {
            e = e - b_face[(x * 6u + slot) * p.kb + i];
        }
        v += u_b[ub + i] * e;
    }
    out[blocks[x].y + t] = v;
}

// Dispatch (⌈k_r/64⌉, n_groups): r[g][j] = Σ over the group's records of T_b→r[rec][j] · b[src].
@compute @workgroup_size(64)
fn respond(@builtin(global_invocation_id) id: vec3<u32>) {
    let j = id.x;
    let g = id.y;
    if (j >= p.k_r || g >= p.n_groups) {
        return;
    }
    var v = 0.0;
    for (var rec = groups[g].z; rec < groups[g].w; rec++) {
        let src = rec_src[rec];
        let op = (rec * p.k_r + j) * p.kb;
        var d = 0.0;
        for (var i = 0u; i < p.kb; i++) {
            d += t_b2r[op + i] * b[src * p.kb + i];
        }
        v += d;
    }
    r[g * p.k_r + j] = v;
}

// Dispatch (⌈max n/64⌉, n_blocks): out[t] += Σ over the block's groups of U_r[row(t)] · r[g].
@compute @workgroup_size(64)
fn apply_ur(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = id.x;
    let x = id.y;
    if (x >= p.n_blocks) {
        return;
    }
    let s = shape_of(x);
    if (t >= shapes[s]) {
        return;
    }
    let o = blocks[x].y + t;
    var v = out[o];
    for (var g = blocks[x].z; g < blocks[x].w; g++) {
        let idx = shapes[s + 5u + groups[g].y];
        if (idx == NONE) {
            continue;
        }
        let row = u_r_idx[idx + t] * p.k_r;
        var d = 0.0;
        for (var j = 0u; j < p.k_r; j++) {
            d += u_r[row + j] * r[g * p.k_r + j];
        }
        v += d;
    }
    out[o] = v;
}

// Dispatch ⌈n_texels/64⌉: one bounce of multi_bounce. The bounce's indirect light times the
// albedo ratio is added to the total and becomes the next bounce's direct light.
@compute @workgroup_size(64)
fn feedback(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = id.x;
    if (t >= p.n_texels) {
        return;
    }
    let s = out[t] * p.albedo_scale;
    total[t] += s;
    l_d[t] = s;
}

// Dispatch (⌈R²/64⌉, n_tiles): tile interiors of the padded atlas from the texels in `out`.
@compute @workgroup_size(64)
fn pad_tiles(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    let ti = id.y;
    if (k >= p.r2 || ti >= p.n_tiles) {
        return;
    }
    let tile = tiles[ti];
    let s = shape_of(tile.x);
    var slot = NONE;
    for (var q = 0u; q < shapes[s + 2u]; q++) {
        if (shapes[s + 11u + q] == tile.y) {
            slot = q;
        }
    }
    if (slot == NONE) {
        return;
    }
    let i = k % p.res;
    let j = k / p.res;
    atlas[(tile.w + 1u + j) * p.atlas_w + tile.z + 1u + i] = out[blocks[tile.x].y + slot * p.r2 + k];
}

// Dispatch ⌈n_pad/64⌉ after pad_tiles: each border pixel copies its texel.
@compute @workgroup_size(64)
fn pad_border(@builtin(global_invocation_id) id: vec3<u32>) {
    let q = id.x;
    if (q >= p.n_pad) {
        return;
    }
    atlas[pad[q * 3u]] = out[blocks[pad[q * 3u + 1u]].y + pad[q * 3u + 2u]];
}
