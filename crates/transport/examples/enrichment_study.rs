//! App. A's five-red-faces case under variations of the enrichment (docs/mrt.md,
//! "Enrichment"): `cargo run --release -p penumbra-transport --example enrichment_study`.
//! Closed cube, thesis settings (16² per face, 16K rays, k_d 64), balanced F, seed 0.

use faer::{Mat, MatRef};
use penumbra_transport::balance::balance_transport;
use penumbra_transport::dict::{direct_matrix, predict, red_box_error, rel_error};
use penumbra_transport::gather::{DirectionSet, Gather, transport_matrix};
use penumbra_transport::operators::{Prior, fallback_basis, prior_from_samples, reduce};
use penumbra_transport::prior::{LightLayout, SphereLight, prior_lights, test_lights};
use penumbra_transport::shape::{CLOSED, Texels};
use penumbra_transport::svd::{frobenius, mul};

/// `[P S, C, U_b]` with block weights `w`, each block at Frobenius norm `w_i`; keep `k`.
fn enrich_w(prior: &Prior, c: MatRef<'_, f64>, ub: MatRef<'_, f64>, w: [f64; 3], k: usize) -> Prior {
    let ps = prior.scaled();
    let blocks = [ps.as_ref(), c, ub];
    let n = ps.nrows();
    let cols: usize = blocks.iter().map(|b| b.ncols()).sum();
    let mut cat = Mat::<f64>::zeros(n, cols);
    let mut at = 0;
    for (b, wi) in blocks.iter().zip(w) {
        let s = wi / frobenius(*b).max(1e-300);
        for j in 0..b.ncols() {
            for i in 0..n {
                cat[(i, at + j)] = b[(i, j)] * s;
            }
        }
        at += b.ncols();
    }
    prior_from_samples(cat.as_ref(), k).unwrap().0
}

#[allow(clippy::print_stdout)]
fn main() {
    let res = 16;
    let tex = Texels::new(CLOSED, res);
    let albedo = 1.0;
    let lights: Vec<SphereLight> = prior_lights(&CLOSED, LightLayout::Lattice)
        .into_iter()
        .map(|c| SphereLight { centre: c, radius: 0.05 })
        .collect();
    let l_d = direct_matrix(&tex, &lights);
    let (p0, _) = prior_from_samples(l_d.as_ref(), 64).unwrap();
    let mut f = transport_matrix(&tex, &DirectionSet::cosine(16384), albedo, Gather::Bilinear, 0, 0, &|_| {});
    balance_transport(&tex, &mut f, albedo);
    let tl = test_lights(&CLOSED, LightLayout::Lattice, 8, 0.05, 0, 0);
    let e = direct_matrix(&tex, &tl);
    let fe = mul(f.as_ref(), e.as_ref());
    let row = |name: &str, p: &Prior, kb: usize| {
        let r = reduce(f.as_ref(), p, kb).unwrap();
        let rb = red_box_error(&tex, f.as_ref(), e.as_ref(), &r, false);
        let rec = rel_error(predict(&r, e.as_ref()).as_ref(), fe.as_ref());
        println!("| {name} | {} | {kb} | {:.3} | {:.3} | {:.3} | {:.4} |", p.k(), rb.rgb, rb.non_red, rb.red, rec);
    };
    // same-face exclusion: face g's output uses b − T_g l_g (a plane cannot light itself)
    let excl = |name: &str, p: &Prior, kb: usize| {
        let r = reduce(f.as_ref(), p, kb).unwrap();
        let mut a = mul(r.u_b.as_ref(), r.t_d2b.as_ref());
        for &g in &tex.faces {
            for i in tex.face_range(g) {
                for j in tex.face_range(g) {
                    a[(i, j)] = 0.0;
                }
            }
        }
        let white = tex.face_range(2);
        let green = Mat::from_fn(e.nrows(), e.ncols(), |i, j| if white.contains(&i) { e[(i, j)] } else { 0.0 });
        let on_white = |m: &Mat<f64>| Mat::from_fn(white.len(), m.ncols(), |i, j| m[(white.start + i, j)]);
        let rr = on_white(&fe);
        let rg = on_white(&mul(f.as_ref(), green.as_ref()));
        let mr = on_white(&mul(a.as_ref(), e.as_ref()));
        let mg = on_white(&mul(a.as_ref(), green.as_ref()));
        let er2 = frobenius((&mr - &rr).as_ref()).powi(2);
        let eg2 = frobenius((&mg - &rg).as_ref()).powi(2);
        let ref2 = frobenius(rr.as_ref()).powi(2) + 2.0 * frobenius(rg.as_ref()).powi(2);
        let rec = rel_error(mul(a.as_ref(), e.as_ref()).as_ref(), fe.as_ref());
        println!(
            "| {name} + same-face exclusion | {} | {kb} | {:.3} | {:.3} | {:.3} | {:.4} |",
            p.k(),
            ((er2 + 2.0 * eg2) / ref2).sqrt(),
            frobenius(mg.as_ref()) / frobenius(rr.as_ref()),
            er2.sqrt() / frobenius(rr.as_ref()),
            rec
        );
    };
    println!("| variant | k (prior) | k_b | white-face RGB | non-red on white | red on white | reconstruction |");
    println!("|---|---|---|---|---|---|---|");
    let base = reduce(f.as_ref(), &p0, 32).unwrap();
    for kb in [8, 16, 32, 64] {
        row("none", &p0, kb);
        excl("none", &p0, kb);
        for modes in [0usize, 8] {
            let c = fallback_basis(&tex, &p0, modes);
            let p = enrich_w(&p0, c.as_ref(), base.u_b.as_ref(), [1.0; 3], 64);
            row(&format!("modes {modes}"), &p, kb);
            excl(&format!("modes {modes}"), &p, kb);
        }
    }
    if std::env::args().nth(1).as_deref() == Some("short") {
        return;
    }
    for modes in [0usize, 8, 16, 64] {
        let c = fallback_basis(&tex, &p0, modes);
        for k in [64usize, 96, 128, 192, 256] {
            let cap = 64 + c.ncols() + 32;
            if k > cap {
                continue;
            }
            for w in [[1.0, 1.0, 1.0], [1.0, 2.0, 1.0], [1.0, 0.5, 1.0]] {
                let p = enrich_w(&p0, c.as_ref(), base.u_b.as_ref(), w, k);
                row(&format!("modes {modes}, w {:?}", w), &p, 32);
            }
        }
    }
    // iterations at the default fallback, keeping 64 or full rank
    for k in [64usize, 150] {
        let c = fallback_basis(&tex, &p0, 8);
        let mut p = p0.clone();
        let mut r = base.clone();
        for it in 1..=3 {
            p = enrich_w(&p, c.as_ref(), r.u_b.as_ref(), [1.0; 3], k);
            r = reduce(f.as_ref(), &p, 32).unwrap();
            row(&format!("modes 8, iteration {it}"), &p, 32);
        }
    }
}
