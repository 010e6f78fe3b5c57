//! The SH triple-product tensor Γ (SHEXP §3, eq. 4) and the SH product built on it.
//!
//! `Γ_ijk = ∫ y_i y_j y_k ds`. Γ is stored sparse: an entry is kept when it is allowed by
//! the selection rules of real SH *and* its value exceeds [`ACCIDENTAL_ZERO_TOL`] — the
//! selection rules are necessary but not sufficient, because a Gaunt coefficient can
//! vanish "accidentally" (Wigner 3j symbols have non-trivial zeros, and for real SH two
//! complex Gaunt terms can cancel). The tolerance is explicit and documented; no test on
//! floats compares against exactly zero.
//!
//! # Nonzero counts and SHEXP §3
//! SHEXP §3 prints the number of nonzero entries of Γ for orders 1..8:
//! `1, 10, 83, 369, 1164, 2961, 6586, 13018`. We count ordered triples `(i, j, k)`:
//!
//! | n | allowed by the selection rules ([`TripleProduct::structural_count`]) | truly nonzero ([`TripleProduct::nonzeros`]) | SHEXP |
//! |---|---|---|---|
//! | 1 | 1 | 1 | 1 |
//! | 2 | 10 | 10 | 10 |
//! | 3 | 83 | 83 | 83 |
//! | 4 | 359 | 353 | 369 |
//! | 5 | 1164 | 1158 | 1164 |
//! | 6 | 2961 | 2907 | 2961 |
//! | 7 | 6586 | 6460 | 6586 |
//! | 8 | 13018 | 12868 | 13018 |
//!
//! For orders 5–8 the paper's numbers equal *exactly* the count of triples allowed by the
//! selection rules, so the paper counts structural entries and includes the Gaunt
//! "accidental zeros": triples that pass every selection rule but integrate to zero. The
//! first of these appear at order 4, `Γ[(2,0),(3,±2),(3,±2)]` — the Wigner 3j symbol
//! `(2 3 3; 0 2 −2)` vanishes — 2 unique / 6 ordered entries. We store only the truly
//! nonzero entries (fewer multiply-adds per product, same result). At order 4 the rule
//! count is 359, not the printed 369; since the rule count reproduces every other order
//! of the table exactly, we read 369 as a typo for 359. `penumbra tables --json` reports
//! both `gamma_nonzeros` (stored, truly nonzero) and `gamma_structural` (the paper's count).

use penumbra_math::quadrature::SphereQuadrature;
use penumbra_math::sh::{ShEval, lm_of};

/// Values below this magnitude are treated as accidental zeros of Γ. The smallest
/// genuine nonzero |Γ| for order ≤ 8 is ~3e-4 and quadrature rounding is ~1e-16, so
/// the threshold separates the two by many orders of magnitude on either side.
pub const ACCIDENTAL_ZERO_TOL: f64 = 1e-11;

/// Whether `Γ_ijk` can be nonzero by the selection rules of *real* SH:
/// `l₁+l₂+l₃` even, triangle inequality, the largest `|m|` equals the sum of the other
/// two, and an even number of sine-type (`m < 0`) functions.
pub fn allowed(i: usize, j: usize, k: usize) -> bool {
    let (l1, m1) = lm_of(i);
    let (l2, m2) = lm_of(j);
    let (l3, m3) = lm_of(k);
    if (l1 + l2 + l3) % 2 == 1 {
        return false;
    }
    if l3 > l1 + l2 || l3 < l1.abs_diff(l2) {
        return false;
    }
    let negs = [m1, m2, m3].iter().filter(|&&m| m < 0).count();
    if negs % 2 == 1 {
        return false;
    }
    let mut a = [m1.unsigned_abs(), m2.unsigned_abs(), m3.unsigned_abs()];
    a.sort_unstable();
    a[2] == a[0] + a[1]
}

fn distinct_permutations(i: usize, j: usize, k: usize) -> usize {
    if i == j && j == k {
        1
    } else if i == j || j == k || i == k {
        3
    } else {
        6
    }
}

/// One nonzero entry of Γ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    /// Output index `i`.
    pub i: u16,
    /// Input index `j`.
    pub j: u16,
    /// Input index `k`.
    pub k: u16,
    /// `Γ_ijk`.
    pub value: f64,
}

/// Sparse triple-product tensor of one order, with the products it enables.
#[derive(Debug, Clone)]
pub struct TripleProduct {
    order: usize,
    /// Unique entries with `i ≤ j ≤ k`, sorted lexicographically.
    unique: Vec<Entry>,
    /// All ordered entries, grouped by `i` (CSR offsets in `row_start`).
    ordered: Vec<Entry>,
    row_start: Vec<usize>,
    /// Ordered triples allowed by the selection rules but numerically zero (accidental zeros).
    accidental_zeros: usize,
}

impl TripleProduct {
    /// Builds Γ for SH order `order` (1..=16) by exact product quadrature (total degree
    /// `3(n−1)`), keeping the entries allowed by the selection rules whose value exceeds
    /// [`ACCIDENTAL_ZERO_TOL`].
    pub fn new(order: usize) -> Self {
        assert!((1..=16).contains(&order), "triple product order out of range");
        let nc = order * order;
        let mut triples = Vec::new();
        for i in 0..nc {
            for j in i..nc {
                for k in j..nc {
                    if allowed(i, j, k) {
                        triples.push((i, j, k));
                    }
                }
            }
        }
        let q = SphereQuadrature::exact_for_degree(3 * (order - 1));
        let eval = ShEval::new(order);
        let mut y = vec![0.0; nc];
        let mut acc = vec![0.0; triples.len()];
        for (d, w) in q.iter() {
            eval.eval_into(d, &mut y);
            for (a, &(i, j, k)) in acc.iter_mut().zip(&triples) {
                *a += w * y[i] * y[j] * y[k];
            }
        }
        let mut unique = Vec::new();
        let mut accidental_zeros = 0;
        for (&(i, j, k), &v) in triples.iter().zip(&acc) {
            if v.abs() > ACCIDENTAL_ZERO_TOL {
                unique.push(Entry { i: i as u16, j: j as u16, k: k as u16, value: v });
            } else {
                accidental_zeros += distinct_permutations(i, j, k);
            }
        }
        let mut ordered = Vec::new();
        for e in &unique {
            let (i, j, k) = (e.i, e.j, e.k);
            let mut perms = [(i, j, k), (i, k, j), (j, i, k), (j, k, i), (k, i, j), (k, j, i)];
            perms.sort_unstable();
            let mut last = None;
            for p in perms {
                if Some(p) != last {
                    ordered.push(Entry { i: p.0, j: p.1, k: p.2, value: e.value });
                    last = Some(p);
                }
            }
        }
        ordered.sort_by_key(|e| (e.i, e.j, e.k));
        let mut row_start = vec![0usize; nc + 1];
        for e in &ordered {
            row_start[e.i as usize + 1] += 1;
        }
        for i in 0..nc {
            row_start[i + 1] += row_start[i];
        }
        Self { order, unique, ordered, row_start, accidental_zeros }
    }

    /// SH order.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Number of coefficients `n²`.
    pub fn len(&self) -> usize {
        self.order * self.order
    }

    /// Whether the tensor is empty (never).
    pub fn is_empty(&self) -> bool {
        self.ordered.is_empty()
    }

    /// Number of nonzero entries over ordered triples (the count SHEXP §3 tabulates).
    pub fn nonzeros(&self) -> usize {
        self.ordered.len()
    }

    /// Number of nonzero entries with `i ≤ j ≤ k`.
    pub fn unique_nonzeros(&self) -> usize {
        self.unique.len()
    }

    /// Ordered triples the selection rules allow but that vanish (Gaunt accidental zeros).
    pub fn accidental_zeros(&self) -> usize {
        self.accidental_zeros
    }

    /// Ordered triples allowed by the selection rules (the count SHEXP §3 tabulates).
    pub fn structural_count(&self) -> usize {
        self.ordered.len() + self.accidental_zeros
    }

    /// Unique entries `i ≤ j ≤ k`.
    pub fn unique_entries(&self) -> &[Entry] {
        &self.unique
    }

    /// All ordered entries, grouped by `i`.
    pub fn entries(&self) -> &[Entry] {
        &self.ordered
    }

    /// `Γ_ijk` (zero when not stored).
    pub fn get(&self, i: usize, j: usize, k: usize) -> f64 {
        let row = &self.ordered[self.row_start[i]..self.row_start[i + 1]];
        row.binary_search_by_key(&(j as u16, k as u16), |e| (e.j, e.k)).map(|p| row[p].value).unwrap_or(0.0)
    }

    /// SH product `(f * g)_i = Σ_jk Γ_ijk f_j g_k` (SHEXP eq. 3), truncated to this order.
    pub fn product(&self, f: &[f64], g: &[f64], out: &mut [f64]) {
        let n = self.len();
        for i in 0..n {
            let mut s = 0.0;
            for e in &self.ordered[self.row_start[i]..self.row_start[i + 1]] {
                s += e.value * f[e.j as usize] * g[e.k as usize];
            }
            out[i] = s;
        }
    }

    /// SH product returning a new vector.
    pub fn product_vec(&self, f: &[f64], g: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.len()];
        self.product(f, g, &mut out);
        out
    }

    /// Product matrix `(M_f)_ij = Σ_k Γ_ijk f_k` (SHEXP eq. 5), row-major `n² × n²`,
    /// symmetric, with `M_f g = f * g`.
    pub fn product_matrix(&self, f: &[f64]) -> Vec<f64> {
        let n = self.len();
        let mut m = vec![0.0; n * n];
        for e in &self.ordered {
            m[e.i as usize * n + e.j as usize] += e.value * f[e.k as usize];
        }
        m
    }

    /// Triple integral `(a, b, c) = Σ_ijk Γ_ijk a_i b_j c_k` of three reconstructions.
    pub fn triple(&self, a: &[f64], b: &[f64], c: &[f64]) -> f64 {
        self.ordered.iter().map(|e| e.value * a[e.i as usize] * b[e.j as usize] * c[e.k as usize]).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;
    use penumbra_math::rng::ItemRng;

    #[test]
    fn gamma_000_and_identity() {
        let t = TripleProduct::new(4);
        assert!((t.get(0, 0, 0) - 0.5 / PI.sqrt()).abs() < 1e-15);
        // 1 * f = f for the constant-one vector 1 = (√4π, 0, ...).
        let mut one = vec![0.0; 16];
        one[0] = (4.0 * PI).sqrt();
        let mut r = ItemRng::new(1, 0, 0);
        let f: Vec<f64> = (0..16).map(|_| r.next_f64() - 0.5).collect();
        let p = t.product_vec(&one, &f);
        for i in 0..16 {
            assert!((p[i] - f[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn symmetric_in_all_indices() {
        let t = TripleProduct::new(5);
        for e in t.entries() {
            let (i, j, k) = (e.i as usize, e.j as usize, e.k as usize);
            for (a, b, c) in [(i, k, j), (j, i, k), (j, k, i), (k, i, j), (k, j, i)] {
                assert_eq!(t.get(a, b, c), e.value);
            }
        }
        let m = t.product_matrix(&(0..25).map(|x| x as f64 * 0.1 - 1.0).collect::<Vec<_>>());
        for i in 0..25 {
            for j in 0..25 {
                assert!((m[i * 25 + j] - m[j * 25 + i]).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn counts_vs_shexp_table() {
        let shexp = [1usize, 10, 83, 369, 1164, 2961, 6586, 13018];
        let structural = [1usize, 10, 83, 359, 1164, 2961, 6586, 13018];
        let nonzero = [1usize, 10, 83, 353, 1158, 2907, 6460, 12868];
        for n in 1..=8 {
            let t = TripleProduct::new(n);
            assert_eq!(t.nonzeros(), nonzero[n - 1], "order {n}");
            assert_eq!(t.structural_count(), structural[n - 1], "order {n}");
            if n != 4 {
                assert_eq!(t.structural_count(), shexp[n - 1], "order {n}");
            }
            // Stored entries are far from the tolerance: nothing is near the cut.
            let min = t.entries().iter().map(|e| e.value.abs()).fold(f64::MAX, f64::min);
            assert!(min > 1e-3, "order {n}: min |Γ| = {min}");
        }
        // The first accidental zero: Γ[(2,0),(3,2),(3,2)] passes every rule but vanishes.
        let t = TripleProduct::new(4);
        let (a, b) = (penumbra_math::sh::index(2, 0), penumbra_math::sh::index(3, 2));
        assert!(allowed(a, b, b));
        assert_eq!(t.get(a, b, b), 0.0);
        assert_eq!(t.accidental_zeros(), 6);
    }

    #[test]
    fn selection_rules_are_complete() {
        // Every triple the rules forbid really integrates to zero (order 5, exact quadrature).
        let n = 5;
        let nc = n * n;
        let q = SphereQuadrature::exact_for_degree(3 * (n - 1));
        let e = ShEval::new(n);
        let mut full = vec![0.0; nc * nc * nc];
        let mut y = vec![0.0; nc];
        for (d, w) in q.iter() {
            e.eval_into(d, &mut y);
            for i in 0..nc {
                for j in 0..nc {
                    let wij = w * y[i] * y[j];
                    for k in 0..nc {
                        full[(i * nc + j) * nc + k] += wij * y[k];
                    }
                }
            }
        }
        let t = TripleProduct::new(n);
        for i in 0..nc {
            for j in 0..nc {
                for k in 0..nc {
                    let v = full[(i * nc + j) * nc + k];
                    if !allowed(i, j, k) {
                        assert!(v.abs() < 1e-13, "forbidden ({i},{j},{k}) = {v}");
                    }
                    assert!((t.get(i, j, k) - v).abs() < 1e-13);
                }
            }
        }
    }
}
