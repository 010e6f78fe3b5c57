//! The DRT vector and volume response at run time (MRT thesis §5.4.3), from the optional
//! sections of a `DRTO` kind-version-2 asset (`penumbra drt --vector`).
//!
//! Three groups of unreduced operators, each a list of records `(dst, src, rows, cols)` whose
//! columns multiply the `b` of block `src` (times the albedo scale `s`, as `ΔU_b`) or, when
//! `src = 0xFFFFFFFF`, the clutter coefficients `c` of the record's listed charts (albedo
//! already in `c`, as `ΔU_c`):
//! - `vec.scene` — per receiving-block texel the 4 OHLSH coefficients of `ΔU_b⃗ b + ΔU_c⃗ c`
//!   in the texel frame of the dictionary's `U_b⃗`, so a normal-mapped scene texel's radiance
//!   is `s·U_b⃗ (b − b_g) + vec.scene` ([`DrtVector::add_scene`],
//!   [`crate::mrt_vec::ohlsh_irradiance`]);
//! - `vec.clutter` — per clutter texel `[a₀, w]` with a **world** linear band: `E(m) = π y₀₀ a₀
//!   + (2π/3)·√(3/4π)·(w·m)` ([`DrtVector::clutter`], [`world_ohlsh_irradiance`]);
//! - `dyn` — `U_dyn`: per probe of each receiving block 9 world-frame SH radiance
//!   coefficients ([`DrtVector::probe_sh`]); probes sit at the block-local centres of a `g³`
//!   grid (x fastest), so [`DrtVector::probe_irradiance`] blends them trilinearly in
//!   block-local coordinates exactly as MRT's `U_bvol` probes are blended
//!   ([`crate::mrt::MrtRuntime::probe_irradiance`]), then applies [`crate::mrt_vec::sh9_irradiance`].
//!   In receiving blocks `U_dyn` replaces MRT's probes (it includes the clutter and the
//!   light arriving through openings); other blocks keep MRT's.

use crate::RuntimeError;
use crate::mrt::{MrtRuntime, dot};
use crate::mrt_vec::{grid_res, sh9_irradiance, trilinear};
use penumbra_asset::{Asset, DType};
use std::borrow::Cow;

const Y00: f32 = 0.282_094_8; // 1/(2√π)
const C1: f32 = 0.488_602_5; // √(3/4π)

fn bad(m: impl Into<String>) -> RuntimeError {
    RuntimeError::Invalid(m.into())
}

/// Irradiance for a world unit normal `m` from world OHLSH `[a₀, w]` (`vec.clutter`).
#[inline]
pub fn world_ohlsh_irradiance(a: &[f32; 4], m: [f32; 3]) -> f32 {
    core::f32::consts::PI * Y00 * a[0]
        + 2.0 * core::f32::consts::PI / 3.0 * C1 * (a[1] * m[0] + a[2] * m[1] + a[3] * m[2])
}

/// One record of a vector group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VecRecord {
    /// Receiving block (scene, probes) or clutter instance.
    pub dst: u32,
    /// Source block of the `b` columns, `u32::MAX` for chart columns.
    pub src: u32,
    /// Rows (items × 4 or × 9).
    pub rows: u32,
    /// Columns.
    pub cols: u32,
    /// Offset of the values.
    pub offset: u32,
    /// Offset of the chart list (chart records).
    pub charts: u32,
}

/// A validated group (`<p>.records`, `<p>.charts`, `<p>.values`).
#[derive(Debug, Clone)]
pub struct VecGroup<'a> {
    /// Records.
    pub records: Vec<VecRecord>,
    /// Chart columns.
    pub charts: &'a [u32],
    /// Values (f16 widened once).
    pub values: Cow<'a, [f32]>,
}

impl<'a> VecGroup<'a> {
    fn from_asset(
        a: &Asset<'a>,
        p: &str,
        rows_of: &dyn Fn(u32) -> Option<u32>,
        kb_of: &dyn Fn(u32) -> Option<u32>,
        n_charts: u32,
    ) -> Result<Self, RuntimeError> {
        let sec =
            |n: &str| a.section(&format!("{p}.{n}")).ok_or_else(|| bad(format!("section \"{p}.{n}\" is missing")));
        let r = sec("records")?;
        if r.dtype() != DType::U32 || r.dims().len() != 2 || r.dims()[1] != 6 {
            return Err(bad(format!("section \"{p}.records\": expected u32 [_, 6]")));
        }
        let rec = r.as_u32().map_err(|e| bad(format!("{p}.records: {e}")))?;
        let ch = sec("charts")?;
        let charts = ch.as_u32().map_err(|e| bad(format!("{p}.charts: {e}")))?;
        let (values, _) = crate::drt::floats(a, &format!("{p}.values"))?;
        let mut records = Vec::with_capacity(rec.len() / 6);
        for q in rec.chunks_exact(6) {
            let x = VecRecord { dst: q[0], src: q[1], rows: q[2], cols: q[3], offset: q[4], charts: q[5] };
            let end = x.offset as u64 + x.rows as u64 * x.cols as u64;
            let ok_rows = rows_of(x.dst) == Some(x.rows);
            let ok_cols = if x.src == u32::MAX {
                x.charts as u64 + x.cols as u64 <= charts.len() as u64
                    && charts[x.charts as usize..(x.charts + x.cols) as usize].iter().all(|&j| j < n_charts)
            } else {
                kb_of(x.src) == Some(x.cols)
            };
            if !ok_rows || !ok_cols || end > values.len() as u64 {
                return Err(bad(format!("{p} record {x:?} does not match the level, the clutter or the values")));
            }
            records.push(x);
        }
        Ok(Self { records, charts, values })
    }

    /// `out[row_of(dst) + i] += Σ_records op·(s·b_src | c[charts])` for the record rows `i`.
    fn apply(
        &self,
        b: &[f32],
        kb_stride: usize,
        scale: f32,
        c: &[f32],
        tmp: &mut [f32],
        row_of: &dyn Fn(u32) -> usize,
        out: &mut [f32],
    ) {
        for r in &self.records {
            let (rows, cols) = (r.rows as usize, r.cols as usize);
            let op = &self.values[r.offset as usize..r.offset as usize + rows * cols];
            let (x, s) = if r.src == u32::MAX {
                let ch = &self.charts[r.charts as usize..r.charts as usize + cols];
                for (t, &j) in tmp[..cols].iter_mut().zip(ch) {
                    *t = c[j as usize];
                }
                (&tmp[..cols], 1.0)
            } else {
                (&b[r.src as usize * kb_stride..r.src as usize * kb_stride + cols], scale)
            };
            let o = &mut out[row_of(r.dst)..row_of(r.dst) + rows];
            for (i, oi) in o.iter_mut().enumerate() {
                *oi += s * dot(&op[i * cols..(i + 1) * cols], x);
            }
        }
    }
}

/// The vector and volume operators of a `DRTO`.
#[derive(Debug, Clone)]
pub struct DrtVector<'a> {
    /// `ΔU_b⃗`, `ΔU_c⃗`.
    pub scene: VecGroup<'a>,
    /// `C_b⃗`, `C_c⃗`.
    pub clutter: VecGroup<'a>,
    /// `U_dyn`.
    pub dyn_probes: VecGroup<'a>,
    /// Probe world positions `[P, 3]`.
    pub positions: &'a [f32],
    /// Probe inside clutter (1) or not (0).
    pub inside: &'a [u8],
    /// Probes per block edge.
    pub res: usize,
    /// Receiving blocks (ascending), with their first probe (`× g³`).
    pub blocks: Vec<u32>,
    /// First texel (level order) of each block of the level.
    offsets: Vec<usize>,
    /// First texel of each instance.
    first: Vec<usize>,
    tmp: Vec<f32>,
}

impl<'a> DrtVector<'a> {
    /// The vector sections of `a` (`None` when the asset has none), validated against the
    /// MRT runtime of its level and the DRTO's receivers and clutter (`instances`: per
    /// instance `[first texel, texels, first chart, charts]`, `receivers`: per receiving
    /// block `[block, mask offset, texels]`).
    pub fn from_asset(
        a: &Asset<'a>,
        mrt: &MrtRuntime<'_>,
        instances: &[u32],
        receivers: &[u32],
        n_charts: u32,
    ) -> Result<Option<Self>, RuntimeError> {
        if a.section("vec.scene.records").is_none() {
            return Ok(None);
        }
        let lv = mrt.level();
        let dict = mrt.dictionary();
        let nb = lv.shapes.len();
        let blocks: Vec<u32> = receivers.chunks_exact(3).map(|r| r[0]).collect();
        let n_of = |x: u32| ((x as usize) < nb).then(|| dict.shapes[lv.shapes[x as usize]].n as u32);
        let kb_of = |x: u32| ((x as usize) < nb).then(|| dict.shapes[lv.shapes[x as usize]].k_b as u32);
        let recv_rank = |x: u32| blocks.binary_search(&x).ok();
        let pos = a.section("dyn.probes").ok_or_else(|| bad("section \"dyn.probes\" is missing"))?;
        let positions = pos.as_f32().map_err(|e| bad(format!("dyn.probes: {e}")))?;
        let inside = a
            .section("dyn.inside")
            .ok_or_else(|| bad("section \"dyn.inside\" is missing"))?
            .as_u8()
            .map_err(|e| bad(format!("dyn.inside: {e}")))?;
        let np = inside.len();
        // no receiving block (a level without clutter): no probes
        let g3 = np.checked_div(blocks.len()).unwrap_or(0);
        if positions.len() != 3 * np || g3 * blocks.len() != np || (np == 0) != blocks.is_empty() {
            return Err(bad("dyn.probes / dyn.inside do not hold g³ probes per receiving block"));
        }
        let res = if np == 0 {
            1
        } else {
            grid_res(g3).ok_or_else(|| bad(format!("{g3} probes per block is not a cube")))?
        };
        let scene = VecGroup::from_asset(
            a,
            "vec.scene",
            &|x| recv_rank(x).and_then(|_| n_of(x)).map(|n| 4 * n),
            &kb_of,
            n_charts,
        )?;
        let ni = instances.len() / 4;
        let clutter = VecGroup::from_asset(
            a,
            "vec.clutter",
            &|i| ((i as usize) < ni).then(|| 4 * instances[i as usize * 4 + 1]),
            &kb_of,
            n_charts,
        )?;
        let dyn_probes = VecGroup::from_asset(a, "dyn", &|x| recv_rank(x).map(|_| 9 * g3 as u32), &kb_of, n_charts)?;
        let cols = [&scene, &clutter, &dyn_probes].iter().flat_map(|g| g.records.iter().map(|r| r.cols)).max();
        Ok(Some(Self {
            scene,
            clutter,
            dyn_probes,
            positions,
            inside,
            res,
            first: instances.chunks_exact(4).map(|r| r[0] as usize).collect(),
            offsets: mrt.offsets().to_vec(),
            blocks,
            tmp: vec![0.0; cols.unwrap_or(0) as usize],
        }))
    }

    /// Adds `s·ΔU_b⃗ b + ΔU_c⃗ c` to `out` (4 per level texel, level texel order, the frame of
    /// [`MrtRuntime::vector_coefficients`]); `b` per block with stride `kb_stride`, `c` the
    /// DRT runtime's albedo-scaled clutter coefficients.
    pub fn add_scene(&mut self, b: &[f32], kb_stride: usize, scale: f32, c: &[f32], out: &mut [[f32; 4]]) {
        let offsets = &self.offsets;
        let flat = out.as_flattened_mut();
        let mut tmp = core::mem::take(&mut self.tmp);
        self.scene.apply(b, kb_stride, scale, c, &mut tmp, &|x| 4 * offsets[x as usize], flat);
        self.tmp = tmp;
    }

    /// World OHLSH `[a₀, w]` of every clutter texel: `s·C_b⃗ b + C_c⃗ c` ([`world_ohlsh_irradiance`]).
    pub fn clutter(&mut self, b: &[f32], kb_stride: usize, scale: f32, c: &[f32], out: &mut [[f32; 4]]) {
        out.iter_mut().for_each(|v| *v = [0.0; 4]);
        let first = &self.first;
        let flat = out.as_flattened_mut();
        let mut tmp = core::mem::take(&mut self.tmp);
        self.clutter.apply(b, kb_stride, scale, c, &mut tmp, &|i| 4 * first[i as usize], flat);
        self.tmp = tmp;
    }

    /// World SH of every probe of every receiving block (`blocks` order, `g³` each, 9 per
    /// probe): `U_dyn [s·b; c]`.
    pub fn probe_sh(&mut self, b: &[f32], kb_stride: usize, scale: f32, c: &[f32], out: &mut [[f32; 9]]) {
        out.iter_mut().for_each(|v| *v = [0.0; 9]);
        let g3 = self.res * self.res * self.res;
        let blocks = &self.blocks;
        let flat = out.as_flattened_mut();
        let mut tmp = core::mem::take(&mut self.tmp);
        let row = |x: u32| 9 * g3 * blocks.binary_search(&x).unwrap_or(0);
        self.dyn_probes.apply(b, kb_stride, scale, c, &mut tmp, &row, flat);
        self.tmp = tmp;
    }

    /// Irradiance at block-local `p ∈ [0,1]³` of receiving block `x` for a world unit normal
    /// `n`, from the output of [`DrtVector::probe_sh`]; `None` when `x` receives no `U_dyn`.
    pub fn probe_irradiance(&self, sh: &[[f32; 9]], x: usize, p: [f32; 3], n: [f32; 3]) -> Option<f32> {
        let k = self.blocks.binary_search(&(x as u32)).ok()?;
        let g3 = self.res * self.res * self.res;
        let c = trilinear(sh[k * g3..(k + 1) * g3].as_flattened(), self.res, p);
        Some(sh9_irradiance(&c, n))
    }
}
