use super::*;
use crate::mrt::{MrtDictionary, MrtLevel, MrtShape};
use crate::sh::ShBasis;

fn hash(i: u32) -> f32 {
    let mut h = i.wrapping_mul(0x9E37_79B9) ^ 0x85EB_CA6B;
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h as f32 / u32::MAX as f32) * 2.0 - 1.0
}

/// Lat-long quadrature of `f` over the sphere (midpoint in θ and φ), f64 accumulation.
fn integrate(mut f: impl FnMut([f32; 3]) -> f64) -> f64 {
    let (nt, np) = (400, 800);
    let mut s = 0.0;
    for i in 0..nt {
        let th = (i as f64 + 0.5) * core::f64::consts::PI / nt as f64;
        for j in 0..np {
            let ph = (j as f64 + 0.5) * 2.0 * core::f64::consts::PI / np as f64;
            let d = [(th.sin() * ph.cos()) as f32, (th.sin() * ph.sin()) as f32, th.cos() as f32];
            s += f(d) * th.sin();
        }
    }
    s * core::f64::consts::PI / nt as f64 * 2.0 * core::f64::consts::PI / np as f64
}

fn eval9(basis: &ShBasis, c: &[f32; 9], d: [f32; 3]) -> f64 {
    let mut y = [0.0f32; 9];
    basis.eval(d, &mut y);
    c.iter().zip(&y).map(|(a, b)| f64::from(a * b)).sum()
}

#[test]
fn sh_rotation_about_y_matches_brute_force_projection() {
    let basis = ShBasis::new(3);
    let c: [f32; 9] = core::array::from_fn(|i| hash(i as u32 + 7));
    for angle in [core::f32::consts::FRAC_PI_2, core::f32::consts::PI, 3.0 * core::f32::consts::FRAC_PI_2, 0.7] {
        let rot = rotate_sh9_y(&c, angle);
        let (s, co) = angle.sin_cos();
        // g(ω) = f(R⁻¹ω), R⁻¹ = rotation by −angle
        let inv = |w: [f32; 3]| [w[0] * co - w[2] * s, w[1], w[0] * s + w[2] * co];
        for j in 0..9 {
            let proj = integrate(|d| {
                let mut y = [0.0f32; 9];
                basis.eval(d, &mut y);
                eval9(&basis, &c, inv(d)) * f64::from(y[j])
            });
            assert!((proj - f64::from(rot[j])).abs() < 2e-3, "angle {angle} coeff {j}: {proj} vs {}", rot[j]);
        }
    }
    // one quarter turn takes radiance along shape +z to world +x ((x, y, z) → (z, y, −x))
    let mut zc = [0.0f32; 9];
    zc[2] = 1.0;
    let r = rotate_sh9_y(&zc, core::f32::consts::FRAC_PI_2);
    assert!((r[3] + 1.0).abs() < 1e-6 && r.iter().enumerate().all(|(i, v)| i == 3 || v.abs() < 1e-6), "{r:?}");
}

#[test]
fn sh9_and_ohlsh_irradiance_match_the_clamped_cosine_integral() {
    let basis = ShBasis::new(3);
    let c: [f32; 9] = core::array::from_fn(|i| hash(i as u32 + 100) + if i == 0 { 4.0 } else { 0.0 });
    for k in 0..4 {
        let m = [hash(200 + k), hash(300 + k), hash(400 + k)];
        let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        let m = [m[0] / l, m[1] / l, m[2] / l];
        let brute = integrate(|d| eval9(&basis, &c, d) * f64::from((d[0] * m[0] + d[1] * m[1] + d[2] * m[2]).max(0.0)));
        let e = f64::from(sh9_irradiance(&c, m));
        assert!((brute - e).abs() < 2e-3 * brute.abs().max(1.0), "{brute} vs {e}");
        // OHLSH is linear SH: for radiance with no band 2 its irradiance is exact too
        let a = [c[0], c[1], c[2], c[3]];
        let lin = integrate(|d| {
            let mut y = [0.0f32; 9];
            basis.eval(d, &mut y);
            f64::from(a[0] * y[0] + a[1] * y[1] + a[2] * y[2] + a[3] * y[3])
                * f64::from((d[0] * m[0] + d[1] * m[1] + d[2] * m[2]).max(0.0))
        });
        let eo = f64::from(ohlsh_irradiance(&a, m));
        assert!((lin - eo).abs() < 2e-3 * lin.abs().max(1.0), "{lin} vs {eo}");
    }
    // constant radiance 1: E = π for every normal
    let mut one = [0.0f32; 9];
    one[0] = (4.0 * PI).sqrt();
    assert!((sh9_irradiance(&one, [0.0, 1.0, 0.0]) - PI).abs() < 1e-5);
}

/// One closed block, R = 1 (6 texels, one per face), k_b = 2.
struct Fixture {
    faces: Vec<u8>,
    u_b: Vec<f32>,
    t_d2b: Vec<f32>,
    u_bvec: Vec<f32>,
    u_bvol: Vec<f32>,
    probes: Vec<f32>,
}

fn fixture() -> Fixture {
    let (n, kb) = (6, 2);
    let u_b: Vec<f32> = (0..n * kb).map(|i| 0.5 + 0.25 * hash(i as u32)).collect();
    let t_d2b: Vec<f32> = (0..kb * n).map(|i| 0.3 + 0.2 * hash(50 + i as u32)).collect();
    // U_b⃗ whose irradiance at the unperturbed normal is U_b, plus tangential terms
    let mut u_bvec = vec![0.0f32; n * kb * 4];
    for t in 0..n {
        for k in 0..kb {
            let a = &mut u_bvec[(t * kb + k) * 4..(t * kb + k) * 4 + 4];
            a[0] = u_b[t * kb + k] / (PI * Y00);
            a[1] = hash(900 + (t * kb + k) as u32);
            a[3] = hash(950 + (t * kb + k) as u32);
        }
    }
    // probes: res 2; mode 0 constant radiance v_p = p + 1, mode 1 radiance along shape +z
    let mut u_bvol = vec![0.0f32; 8 * kb * 9];
    let mut probes = Vec::new();
    for p in 0..8 {
        u_bvol[p * kb * 9] = (4.0 * PI).sqrt() * (p as f32 + 1.0);
        u_bvol[(p * kb + 1) * 9 + 2] = 1.0 / C1;
        probes.extend([0.25 + 0.5 * (p & 1) as f32, 0.25 + 0.5 * ((p >> 1) & 1) as f32, 0.25 + 0.5 * (p >> 2) as f32]);
    }
    Fixture { faces: (0..6).collect(), u_b, t_d2b, u_bvec, u_bvol, probes }
}

fn runtime<'a>(f: &'a Fixture, q: u32, exclude: bool) -> MrtRuntime<'a> {
    let shape = MrtShape {
        name: "closed".into(),
        n: 6,
        k_b: 2,
        faces: &f.faces,
        u_b: &f.u_b,
        t_d2b: &f.t_d2b,
        u_r_idx: [None; 6],
        u_bvec: Some(&f.u_bvec),
        u_bvol: Some((&f.u_bvol, &f.probes)),
        positions: None,
    };
    let dict = MrtDictionary {
        shapes: vec![shape],
        u_r: &[],
        k_r: 1,
        face_texels: 1,
        exclude_same_face: exclude,
        vectors: None,
        face_frames: None,
    };
    let level = MrtLevel {
        warps: Vec::new(),
        block_warp: vec![None],
        shapes: vec![0],
        rotations: vec![q],
        xform: None,
        records: vec![],
        t_b2r: &[],
        k_b: 2,
        atlas: (3, 18),
        tiles: &[],
        pad: &[],
    };
    MrtRuntime::new(dict, level)
}

#[test]
fn vector_irradiance_at_the_normal_equals_the_scalar_indirect_light() {
    let f = fixture();
    let l_d: Vec<f32> = (0..6).map(|i| 1.0 + hash(70 + i)).collect();
    for exclude in [false, true] {
        let mut rt = runtime(&f, 0, exclude);
        let mut scalar = vec![0.0; 6];
        rt.indirect(&l_d, &mut scalar, false);
        let mut vec4 = vec![[0.0; 4]; 6];
        rt.vector_coefficients(&mut vec4);
        for t in 0..6 {
            let e = ohlsh_irradiance(&vec4[t], [0.0, 0.0, 1.0]);
            assert!(
                (e - scalar[t]).abs() <= 1e-5 * scalar[t].abs().max(1.0),
                "texel {t} exclude {exclude}: {e} vs {}",
                scalar[t]
            );
        }
        // a 60° tilt toward u changes it by the a₁₁ term, known in closed form
        let (s, c) = (60f32.to_radians().sin(), 60f32.to_radians().cos());
        let e = ohlsh_irradiance(&vec4[2], [s, 0.0, c]);
        let want = PI * Y00 * vec4[2][0] + 2.0 * PI / 3.0 * C1 * (vec4[2][2] * c - vec4[2][3] * s);
        assert!((e - want).abs() < 1e-5);
    }
    // the same-face rule matters: with it off, texel 0's vector differs
    let mut a = runtime(&f, 0, true);
    let mut b = runtime(&f, 0, false);
    let mut o = vec![0.0; 6];
    a.indirect(&l_d, &mut o, false);
    b.indirect(&l_d, &mut o, false);
    let (mut va, mut vb) = (vec![[0.0; 4]; 6], vec![[0.0; 4]; 6]);
    a.vector_coefficients(&mut va);
    b.vector_coefficients(&mut vb);
    assert!((va[0][0] - vb[0][0]).abs() > 1e-3);
}

#[test]
fn probe_irradiance_known_answer_with_rotation_and_trilinear_blend() {
    let f = fixture();
    // l_d such that b = (b0, b1) with b0 = Σ t_d2b[0] · l_d, etc.
    let l_d = vec![1.0f32; 6];
    let b0: f32 = f.t_d2b[..6].iter().sum();
    let b1: f32 = f.t_d2b[6..].iter().sum();
    for q in 0..4u32 {
        let mut rt = runtime(&f, q, true);
        let mut o = vec![0.0; 6];
        rt.indirect(&l_d, &mut o, false);
        let mut sh = Vec::new();
        assert_eq!(rt.probe_sh(0, &mut sh), 8);
        // mode 1's radiance points along shape +z, i.e. world R_q(+z)
        let zw = rotate_vec_y([0.0, 0.0, 1.0], q);
        // at probe 0's centre, normal along it: π v₀ b0 + (2π/3) b1 (the constant and linear parts)
        let e = rt.probe_irradiance(0, &sh, [0.25, 0.25, 0.25], zw);
        let want = PI * b0 + 2.0 * PI / 3.0 * b1;
        assert!((e - want).abs() < 1e-4 * want, "q {q}: {e} vs {want}");
        // opposite normal: π b0 − (2π/3) b1
        let e = rt.probe_irradiance(0, &sh, [0.25, 0.25, 0.25], [-zw[0], -zw[1], -zw[2]]);
        assert!((e - (PI * b0 - 2.0 * PI / 3.0 * b1)).abs() < 1e-4 * want);
        // the block centre: the mean of the 8 probes (v = 4.5), normal ⟂ the linear part
        let e = rt.probe_irradiance(0, &sh, [0.5, 0.5, 0.5], [0.0, 1.0, 0.0]);
        assert!((e - PI * 4.5 * b0).abs() < 1e-4 * e, "{e}");
        // halfway between probes 0 and 1 along x, clamped outside the centres
        let e = rt.probe_irradiance(0, &sh, [0.5, 0.25, 0.0], [0.0, 1.0, 0.0]);
        assert!((e - PI * 1.5 * b0).abs() < 1e-4 * e, "{e}");
    }
}

/// The MRTD `face_frames` (origin, u, v, n per face; `schemas/asset-format.md`).
const FACE_FRAMES: [f32; 72] = [
    0., 0., 1., 0., 0., -1., 0., 1., 0., 1., 0., 0., //
    1., 0., 0., 0., 0., 1., 0., 1., 0., -1., 0., 0., //
    0., 0., 0., 0., 0., 1., 1., 0., 0., 0., 1., 0., //
    0., 1., 0., 1., 0., 0., 0., 0., 1., 0., -1., 0., //
    0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., //
    1., 0., 1., -1., 0., 0., 0., 1., 0., 0., 0., -1.,
];

#[test]
fn interface_tangent_maps_and_canonical_probes_follow_the_quarter_turns() {
    let t = crate::mrt::tangent_maps(&FACE_FRAMES).unwrap();
    for q in 0..4 {
        // side faces keep v = +Y and turn into side faces with the same (u, v): identity
        for g in [0, 1, 4, 5] {
            assert_eq!(t[q][g], [1.0, 0.0, 0.0, 1.0], "q {q} face {g}");
        }
        for g in [2, 3] {
            let m = t[q][g];
            // a rotation (floor and ceiling turn in their plane), q turns of a quarter turn
            assert!((m[0] * m[3] - m[1] * m[2] - 1.0).abs() < 1e-6, "q {q} face {g}: {m:?}");
            // the spec's closed form: floor [[c, −s], [s, c]], ceiling [[c, s], [−s, c]]
            let (c, sn) = ([1.0, 0.0, -1.0, 0.0][q], [0.0, 1.0, 0.0, -1.0][q]);
            let sg = if g == 2 { 1.0 } else { -1.0 };
            assert_eq!(m, [c, -sg * sn, sg * sn, c], "q {q} face {g}");
        }
    }
    // one turn, floor (u = +z, v = +x): R(x, y, z) = (−z, y, x) takes u to −x = −v_c and
    // v to +z = u_c, so the canonical tangent (u_c, v_c) components (a, b) are (b, −a) in the
    // texel's frame: Mᵀ = [[0, −1], [1, 0]]; the ceiling (u = +x, v = +z) turns the other way
    assert_eq!(t[1][2], [0.0, -1.0, 1.0, 0.0]);
    assert_eq!(t[1][3], [0.0, 1.0, -1.0, 0.0]);
    // the canonical probe of a probe is at its centre turned by (x, y, z) → (1 − z, y, x)
    for res in [1usize, 2, 3, 4] {
        for q in 0..4u32 {
            let mut seen = vec![false; res * res * res];
            for p in 0..res * res * res {
                let c = |i: usize| (i as f32 + 0.5) / res as f32;
                let mut pos = [c(p % res), c((p / res) % res), c(p / (res * res))];
                for _ in 0..q {
                    pos = [1.0 - pos[2], pos[1], pos[0]];
                }
                let pc = canonical_probe(p, res, q);
                let want = [c(pc % res), c((pc / res) % res), c(pc / (res * res))];
                assert!((0..3).all(|k| (pos[k] - want[k]).abs() < 1e-6), "res {res} q {q} probe {p}");
                seen[pc] = true;
            }
            assert!(seen.iter().all(|&s| s), "a permutation");
        }
    }
}
