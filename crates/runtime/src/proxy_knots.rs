//! The kinks of the proxy log table (SHTB kind_version 2, section `proxy_log_knots`; issue
//! #14 §1): where the SH log's eigenvalue clipping (SHEXP §5, eq. 32) engages inside a cell
//! of the uniform α grid, the row has a slope discontinuity. The bake stores the exact row at
//! each such α; [`ProxyKnots::interpolate`] splits the cell there and reads each side only
//! from nodes on its own side of the kink (asset spec §15.1, step 2).

use crate::error::RuntimeError;

/// Cell flags: a knot lies inside this cell / the cell to the left / the cell to the right.
pub(crate) const IN_CELL: u8 = 1;
const LEFT_CELL: u8 = 2;
const RIGHT_CELL: u8 = 4;

/// Where the knots fall on one uniform grid, by cell.
#[derive(Debug, Clone, Default)]
struct KnotGrid {
    /// Per cell `i` (between rows `i` and `i + 1`, `K − 1` cells; empty without knots):
    /// [`IN_CELL`] | `LEFT_CELL` | `RIGHT_CELL`.
    flags: Vec<u8>,
    /// Per cell: the index of the knot inside it (valid where `IN_CELL` is set).
    index: Vec<u16>,
    /// Per cell: the knot's position inside it, `x(K − 1) − i ∈ (0, 1)`.
    frac: Vec<f32>,
}

impl KnotGrid {
    fn new(k: usize) -> Self {
        Self { flags: vec![0; k - 1], index: vec![0; k - 1], frac: vec![0.0; k - 1] }
    }

    /// Places knot `q` at grid coordinate `t = x(K − 1)`; `false` if its cell already has one
    /// or it lies on (within `min_frac` of) a node.
    fn place(&mut self, q: usize, t: f64, min_frac: f64) -> bool {
        let k1 = self.flags.len();
        let cell = t.floor();
        if !(cell >= 0.0 && (cell as usize) < k1) {
            return false;
        }
        let c = cell as usize;
        let frac = t - cell;
        if !(frac > min_frac && frac < 1.0 - min_frac) || self.flags[c] & IN_CELL != 0 {
            return false;
        }
        self.flags[c] |= IN_CELL;
        self.index[c] = q as u16;
        self.frac[c] = frac as f32;
        if c > 0 {
            self.flags[c - 1] |= RIGHT_CELL;
        }
        if c + 1 < k1 {
            self.flags[c + 1] |= LEFT_CELL;
        }
        true
    }
}

/// The knots of one table, indexed by cell of the α grid (`proxy_log_occlusion`) and of the
/// θ grid (`cap_log`, read near contact at `θ = asin α`).
#[derive(Debug, Clone, Default)]
pub(crate) struct ProxyKnots {
    alpha: KnotGrid,
    theta: KnotGrid,
    /// Number of knots.
    count: usize,
    /// Per knot: the starred log row (`order` values each).
    rows: Vec<f32>,
}

/// Which grid [`ProxyKnots::interpolate`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Grid {
    /// `α_k = k/(K − 1)`, `proxy_log_occlusion`.
    Alpha,
    /// `θ_k = (π/2)k/(K − 1)`, `cap_log`.
    Theta,
}

/// One interpolation node: position in cell units relative to row `i`, and its row.
#[derive(Clone, Copy)]
struct Node<'r> {
    x: f32,
    row: &'r [f32],
}

impl ProxyKnots {
    /// Validates `section` (`[P, order + 1]` rows `(α, row)`, from `proxy_log_knots`) against
    /// a table of `k` rows: α finite, strictly increasing, strictly inside a grid cell, at
    /// most one knot per cell, rows finite.
    pub(crate) fn new(section: &[f32], order: usize, k: usize) -> Result<Self, RuntimeError> {
        let bad = |reason: String| RuntimeError::BadSection { name: "proxy_log_knots", reason };
        let p = section.len() / (order + 1);
        if p == 0 {
            return Ok(Self::default());
        }
        if p > u16::MAX as usize {
            return Err(bad(format!("{p} knots (at most {})", u16::MAX)));
        }
        let mut knots =
            Self { alpha: KnotGrid::new(k), theta: KnotGrid::new(k), count: p, rows: Vec::with_capacity(p * order) };
        let mut last = -1.0f64;
        for (q, r) in section.chunks_exact(order + 1).enumerate() {
            let alpha = r[0] as f64;
            if !(alpha > 0.0 && alpha < 1.0) || r[1..].iter().any(|v| !v.is_finite()) {
                return Err(bad(format!("knot {q}: alpha {alpha} not in (0, 1) or non-finite row")));
            }
            if alpha <= last {
                return Err(bad(format!("knot {q}: alpha {alpha} not increasing")));
            }
            last = alpha;
            if !knots.alpha.place(q, alpha * (k - 1) as f64, 0.0) {
                return Err(bad(format!("knot {q}: alpha {alpha} on a grid node or a second knot in one cell")));
            }
            // on the θ grid a knot that falls (nearly) on a node or shares a cell is not used
            let theta = alpha.asin() / core::f64::consts::FRAC_PI_2;
            knots.theta.place(q, theta * (k - 1) as f64, 1e-4);
            knots.rows.extend_from_slice(&r[1..]);
        }
        Ok(knots)
    }

    /// The α-grid flags of cell `i` (0 without knots): nonzero when a knot lies in it or next
    /// to it.
    #[inline(always)]
    pub(crate) fn flags(&self, i: usize) -> u8 {
        self.alpha.flags.get(i).copied().unwrap_or(0)
    }

    /// The θ-grid flags of cell `i`.
    #[inline(always)]
    pub(crate) fn theta_flags(&self, i: usize) -> u8 {
        self.theta.flags.get(i).copied().unwrap_or(0)
    }

    /// Number of knots.
    pub(crate) fn len(&self) -> usize {
        self.count
    }

    /// The proxy log at `w ∈ [0, 1)` inside cell `i` of `table` (`[K, N]`, on `grid`), which
    /// has a knot in it or next to it (flags of cell `i` nonzero), by Lagrange interpolation over nodes of the
    /// kink-free segment that holds the query: the two nodes that bracket it (a grid row or a
    /// knot) and up to `reach − 1` more on each side, taken outwards, never past a knot and
    /// never below row `top_row` (the smooth clamp's ramp) or past row `K − 1`. With
    /// `reach = 2` that is a cubic through 4 nodes where the segment allows (3 on the short
    /// side of a split cell); `reach = 1` is linear between the bracketing nodes.
    pub(crate) fn interpolate<const N: usize>(
        &self,
        grid: Grid,
        table: &[f32],
        i: usize,
        w: f32,
        top_row: usize,
        reach: usize,
    ) -> [f32; N] {
        let k = table.len() / N;
        let row = |j: usize| &table[j * N..(j + 1) * N];
        let g = match grid {
            Grid::Alpha => &self.alpha,
            Grid::Theta => &self.theta,
        };
        let knot = |c: usize| {
            let q = g.index[c] as usize;
            (g.frac[c], &self.rows[q * N..(q + 1) * N])
        };
        let flags = g.flags[i];
        // left[0], right[0]: the bracketing nodes; further entries go outwards
        let mut left = [Node { x: 0.0, row: row(i) }; 2];
        let mut right = [Node { x: 1.0, row: row(i + 1) }; 2];
        let (mut nl, mut nr) = (1usize, 1usize);
        let mut left_open = true; // may extend further left
        let mut right_open = true;
        if flags & IN_CELL != 0 {
            let (f, kr) = knot(i);
            if w >= f {
                left[0] = Node { x: f, row: kr };
                left_open = false;
            } else {
                right[0] = Node { x: f, row: kr };
                right_open = false;
            }
        }
        // further left: row i − 1, or the knot in cell i − 1 when there is one
        if left_open && nl < reach {
            if flags & LEFT_CELL != 0 {
                let (f, kr) = knot(i - 1);
                left[nl] = Node { x: f - 1.0, row: kr };
                nl += 1;
            } else if i > top_row {
                left[nl] = Node { x: -1.0, row: row(i - 1) };
                nl += 1;
            }
        }
        if right_open && nr < reach {
            if flags & RIGHT_CELL != 0 {
                let (f, kr) = knot(i + 1);
                right[nr] = Node { x: 1.0 + f, row: kr };
                nr += 1;
            } else if i + 2 < k {
                right[nr] = Node { x: 2.0, row: row(i + 2) };
                nr += 1;
            }
        }
        let mut nodes = [Node { x: 0.0, row: row(i) }; 4];
        let mut m = 0;
        for node in left[..nl].iter().rev().chain(&right[..nr]) {
            nodes[m] = *node;
            m += 1;
        }
        let mut weight = [0.0f32; 4];
        for a in 0..m {
            let mut c = 1.0f32;
            for b in 0..m {
                if b != a {
                    c *= (w - nodes[b].x) / (nodes[a].x - nodes[b].x);
                }
            }
            weight[a] = c;
        }
        let mut out = [0.0f32; N];
        for a in 0..m {
            for l in 0..N {
                out[l] += weight[a] * nodes[a].row[l];
            }
        }
        out
    }
}
