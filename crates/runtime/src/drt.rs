//! The DRT runtime (MRT thesis §5.4, §5.4.1): clutter's indirect shadows and interreflections
//! on top of the MRT runtime, from a `DRTO` asset baked for an `MRTD` dictionary and an `MRTL`
//! level.
//!
//! Per evaluation ([`DrtRuntime::one_bounce`]), after the MRT runtime has computed `b` per
//! block:
//! 1. `c = T_d→c l_d,c`, each chart's coefficient times its albedo in the chosen channel
//!    (`c_j = ρ_j Σ_{t∈j} w_t l_t`, `w_t = 1/√m_j`);
//! 2. scene indirect `= s·(U_b b + U_r r + Σ ΔU_b^{X←Y} b_Y) + ΔU_c c` (`s` = walls' albedo over
//!    the dictionary's baked albedo; `ΔU_c` carries the clutter's albedo through `c`);
//! 3. clutter indirect `l_c = s·C_b b + C_c c = s·A (W b_stack) + A_c (W_c c)` per instance
//!    (`C_c`, light from clutter onto clutter, is this project's addition: docs/drt.md).
//!
//! **Multi-bounce through the clutter** ([`DrtRuntime::multi_bounce`]; the thesis is silent):
//! each bounce feeds the scene's indirect irradiance back as the scene's direct light (as
//! [`crate::mrt::MrtRuntime::multi_bounce`] does) *and* the clutter's `l_c` back as the
//! clutter's direct light, so wall → clutter → wall paths of every length are kept; only
//! clutter → clutter light is missing (no DRT operator carries it).
//!
//! Everything is f32 and allocation-free after construction (f16 operator sections, written by
//! `penumbra drt --half`, are widened to f32 once at construction).

use crate::RuntimeError;
use crate::mrt::{MrtDictionary, MrtLevel, MrtRuntime, dot};
use penumbra_asset::{Asset, DType, f16_bits_to_f32};
use std::borrow::Cow;

fn bad(m: impl Into<String>) -> RuntimeError {
    RuntimeError::Invalid(m.into())
}

fn f32s<'a>(a: &Asset<'a>, name: &str) -> Result<(&'a [f32], Vec<usize>), RuntimeError> {
    let s = a.section(name).ok_or_else(|| bad(format!("section {name:?} is missing")))?;
    if s.dtype() != DType::F32 {
        return Err(bad(format!("section {name:?}: expected f32")));
    }
    Ok((s.as_f32().map_err(|e| bad(format!("section {name:?}: {e}")))?, s.dims().to_vec()))
}

/// An f32 or f16 section as f32: borrowed (zero copy) when stored as f32, widened once at
/// setup when stored as f16 (`penumbra drt --half`).
pub(crate) fn floats<'a>(a: &Asset<'a>, name: &str) -> Result<(Cow<'a, [f32]>, Vec<usize>), RuntimeError> {
    let s = a.section(name).ok_or_else(|| bad(format!("section {name:?} is missing")))?;
    let e = |x: penumbra_asset::ViewError| bad(format!("section {name:?}: {x}"));
    let v = match s.dtype() {
        DType::F32 => Cow::Borrowed(s.as_f32().map_err(e)?),
        DType::F16 => Cow::Owned(s.as_f16_bits().map_err(e)?.iter().map(|&h| f16_bits_to_f32(h)).collect()),
        other => return Err(bad(format!("section {name:?}: expected f32 or f16, found {}", other.name()))),
    };
    Ok((v, s.dims().to_vec()))
}

fn u32s<'a>(a: &Asset<'a>, name: &str, cols: usize) -> Result<&'a [u32], RuntimeError> {
    let s = a.section(name).ok_or_else(|| bad(format!("section {name:?} is missing")))?;
    if s.dtype() != DType::U32 || (cols > 0 && (s.dims().len() != 2 || s.dims()[1] != cols)) {
        return Err(bad(format!("section {name:?}: expected u32 [_, {cols}], found {:?} {:?}", s.dtype(), s.dims())));
    }
    s.as_u32().map_err(|e| bad(format!("section {name:?}: {e}")))
}

/// One `ΔU_b` record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeltaRecord {
    /// Receiving block.
    pub dst: u32,
    /// Source block.
    pub src: u32,
    /// Offset into `du_b` (elements).
    pub offset: u32,
    /// Rows (texels of `dst`).
    pub rows: u32,
    /// Columns (`k_b` of `src`).
    pub cols: u32,
}

/// One factored reflection record (`ΔU_c` of a block, `C_c` of an instance): the irradiance
/// of its `rows` texels is `A (W c[charts])`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReflectRecord {
    /// Receiving block (`du_c`) or instance (`c_c`).
    pub dst: u32,
    /// Rows.
    pub rows: u32,
    /// Rank.
    pub rank: u32,
    /// Columns (charts).
    pub cols: u32,
    /// Offset into `<p>.a` (`rows × rank`).
    pub a: u32,
    /// Offset into `<p>.w` (`rank × cols`).
    pub w: u32,
    /// Offset of its chart list in `<p>.charts`.
    pub charts: u32,
}

/// A list of factored reflection records and their data.
#[derive(Debug, Clone)]
pub struct ReflectOps<'a> {
    /// Records.
    pub records: Vec<ReflectRecord>,
    /// Chart lists.
    pub charts: &'a [u32],
    /// `A` factors.
    pub a: Cow<'a, [f32]>,
    /// `W` factors.
    pub w: Cow<'a, [f32]>,
}

impl<'a> ReflectOps<'a> {
    /// Reads `<p>.records`, `<p>.charts`, `<p>.a`, `<p>.w`; `rows_of(dst)` is the expected row
    /// count (None: `dst` out of range).
    fn read(a: &Asset<'a>, p: &str, nc: usize, rows_of: &dyn Fn(u32) -> Option<u64>) -> Result<Self, RuntimeError> {
        let rec = u32s(a, &format!("{p}.records"), 7)?;
        let charts = u32s(a, &format!("{p}.charts"), 0)?;
        let (av, _) = floats(a, &format!("{p}.a"))?;
        let (wv, _) = floats(a, &format!("{p}.w"))?;
        let mut records = Vec::new();
        for r in rec.chunks_exact(7) {
            let x = ReflectRecord { dst: r[0], rows: r[1], rank: r[2], cols: r[3], a: r[4], w: r[5], charts: r[6] };
            if rows_of(x.dst) != Some(u64::from(x.rows)) || x.rank > 4096 {
                return Err(bad(format!("{p} record {x:?}: receiver or rows out of range")));
            }
            let aend = u64::from(x.a) + u64::from(x.rows) * u64::from(x.rank);
            let wend = u64::from(x.w) + u64::from(x.rank) * u64::from(x.cols);
            let cend = u64::from(x.charts) + u64::from(x.cols);
            if aend > av.len() as u64 || wend > wv.len() as u64 || cend > charts.len() as u64 {
                return Err(bad(format!("{p} record {x:?}: offsets out of range")));
            }
            if charts[x.charts as usize..cend as usize].iter().any(|&c| c as usize >= nc) {
                return Err(bad(format!("{p} record {x:?}: chart out of range")));
            }
            records.push(x);
        }
        Ok(Self { records, charts, a: av, w: wv })
    }

    /// Adds `A (W c[charts])` of every record to `out` at `first(dst)`; `tmp` holds ≥ the
    /// largest rank.
    fn apply(&self, c: &[f32], tmp: &mut [f32], first: &dyn Fn(u32) -> usize, out: &mut [f32]) {
        for r in &self.records {
            let (rows, rank, cols) = (r.rows as usize, r.rank as usize, r.cols as usize);
            let charts = &self.charts[r.charts as usize..r.charts as usize + cols];
            let w = &self.w[r.w as usize..r.w as usize + rank * cols];
            let t = &mut tmp[..rank];
            for (i, ti) in t.iter_mut().enumerate() {
                *ti = w[i * cols..(i + 1) * cols].iter().zip(charts).map(|(wv, &ch)| wv * c[ch as usize]).sum();
            }
            let a = &self.a[r.a as usize..r.a as usize + rows * rank];
            let o0 = first(r.dst);
            for (k, ot) in out[o0..o0 + rows].iter_mut().enumerate() {
                *ot += dot(&a[k * rank..(k + 1) * rank], t);
            }
        }
    }

    fn max_rank(&self) -> usize {
        self.records.iter().map(|r| r.rank as usize).max().unwrap_or(0)
    }
}

/// One `C_b` record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GatherRecord {
    /// Instance.
    pub instance: u32,
    /// Rank `r`.
    pub rank: u32,
    /// Stacked `b` length `K`.
    pub k: u32,
    /// Offset into `c_b.a` (`m × r`).
    pub a: u32,
    /// Offset into `c_b.w` (`r × K`).
    pub w: u32,
    /// Offset into `c_b.srcs`.
    pub srcs: u32,
    /// Source blocks.
    pub nsrc: u32,
}

/// A validated view of a `DRTO` asset.
#[derive(Debug, Clone)]
pub struct DrtOperators<'a> {
    /// `ΔU_b` records.
    pub du_b_records: Vec<DeltaRecord>,
    /// `ΔU_b` values.
    pub du_b: Cow<'a, [f32]>,
    /// `ΔU_c`, per receiving block.
    pub du_c: ReflectOps<'a>,
    /// `C_c`, per instance.
    pub c_c: ReflectOps<'a>,
    /// Per instance: first texel, texels, first chart, charts.
    pub instances: &'a [u32],
    /// Per chart: instance, first texel, texels.
    pub charts: &'a [u32],
    /// Per chart: albedo RGB.
    pub albedo: &'a [f32],
    /// Clutter texel positions (world), `[m, 3]`.
    pub positions: &'a [f32],
    /// Clutter texel normals (world), `[m, 3]`.
    pub normals: Cow<'a, [f32]>,
    /// Per clutter texel: `T_d→c` weight.
    pub t_d2c: &'a [f32],
    /// `C_b` records.
    pub c_b_records: Vec<GatherRecord>,
    /// Source blocks of the `C_b` records.
    pub c_b_srcs: &'a [u32],
    /// `C_b` factors.
    pub c_b_a: Cow<'a, [f32]>,
    /// `C_b` factors.
    pub c_b_w: Cow<'a, [f32]>,
    /// Receiving blocks: block, mask offset, texels.
    pub receivers: &'a [u32],
    /// Inpainting mask.
    pub inpaint_mask: &'a [u8],
}

impl<'a> DrtOperators<'a> {
    /// Validates a `DRTO` asset against the dictionary and level it was baked for.
    pub fn from_asset(a: &Asset<'a>, d: &MrtDictionary<'_>, l: &MrtLevel<'_>) -> Result<Self, RuntimeError> {
        if a.kind().as_str() != "DRTO" {
            return Err(RuntimeError::WrongKind { expected: "DRTO", found: a.kind().as_str().to_string() });
        }
        // a shard (`penumbra drt --shard K/N`) holds some records only: refuse it (its `shard`
        // section is critical: a reader that does not know it must not use the asset)
        if a.sections().iter().any(|s| s.is_critical() && s.name() != "meta") {
            return Err(bad(
                "the asset has a critical section this runtime does not know (a shard of a bake? merge the shards with `penumbra drt merge`)",
            ));
        }
        let nb = l.shapes.len();
        let n_of = |b: u32| d.shapes[l.shapes[b as usize]].n as u64;
        let k_of = |b: u32| d.shapes[l.shapes[b as usize]].k_b as u64;
        let rec = u32s(a, "du_b.records", 5)?;
        let (du_b, _) = floats(a, "du_b")?;
        let mut du_b_records = Vec::with_capacity(rec.len() / 5);
        for r in rec.chunks_exact(5) {
            let x = DeltaRecord { dst: r[0], src: r[1], offset: r[2], rows: r[3], cols: r[4] };
            if x.dst as usize >= nb || x.src as usize >= nb {
                return Err(bad(format!("du_b record {x:?}: block out of range")));
            }
            let end = u64::from(x.offset) + u64::from(x.rows) * u64::from(x.cols);
            if u64::from(x.rows) != n_of(x.dst) || u64::from(x.cols) != k_of(x.src) || end > du_b.len() as u64 {
                return Err(bad(format!("du_b record {x:?}: dims or offset do not match the level and data")));
            }
            du_b_records.push(x);
        }
        let charts = u32s(a, "clutter.charts", 3)?;
        let nc = charts.len() / 3;
        let (albedo, ad) = f32s(a, "clutter.albedo")?;
        if ad != [nc, 3] {
            return Err(bad("clutter.albedo: dims"));
        }
        let (positions, pd) = f32s(a, "clutter.positions")?;
        let m = pd.first().copied().unwrap_or(0);
        let (normals, nd) = floats(a, "clutter.normals")?;
        let (t_d2c, wd) = f32s(a, "clutter.t_d2c")?;
        if pd != [m, 3] || nd != [m, 3] || wd != [m] {
            return Err(bad("clutter.positions / normals / t_d2c: dims"));
        }
        for c in charts.chunks_exact(3) {
            if u64::from(c[1]) + u64::from(c[2]) > m as u64 {
                return Err(bad(format!("clutter chart {c:?} out of range")));
            }
        }
        let instances = u32s(a, "clutter.instances", 4)?;
        for i in instances.chunks_exact(4) {
            if u64::from(i[0]) + u64::from(i[1]) > m as u64 || u64::from(i[2]) + u64::from(i[3]) > nc as u64 {
                return Err(bad(format!("clutter instance {i:?} out of range")));
            }
        }
        let du_c = ReflectOps::read(a, "du_c", nc, &|dst| ((dst as usize) < nb).then(|| n_of(dst)))?;
        let inst_rows = |i: u32| instances.get(i as usize * 4 + 1).map(|&m| u64::from(m));
        let c_c = ReflectOps::read(a, "c_c", nc, &inst_rows)?;
        let rec = u32s(a, "c_b.records", 7)?;
        let c_b_srcs = u32s(a, "c_b.srcs", 0)?;
        let (c_b_a, _) = floats(a, "c_b.a")?;
        let (c_b_w, _) = floats(a, "c_b.w")?;
        let ni = instances.len() / 4;
        let mut c_b_records = Vec::new();
        for r in rec.chunks_exact(7) {
            let x = GatherRecord { instance: r[0], rank: r[1], k: r[2], a: r[3], w: r[4], srcs: r[5], nsrc: r[6] };
            if x.instance as usize >= ni {
                return Err(bad(format!("c_b record {x:?}: instance out of range")));
            }
            let mi = u64::from(instances[x.instance as usize * 4 + 1]);
            let send = u64::from(x.srcs) + u64::from(x.nsrc);
            if send > c_b_srcs.len() as u64 {
                return Err(bad(format!("c_b record {x:?}: sources out of range")));
            }
            let srcs = &c_b_srcs[x.srcs as usize..send as usize];
            if srcs.iter().any(|&s| s as usize >= nb) || srcs.iter().map(|&s| k_of(s)).sum::<u64>() != u64::from(x.k) {
                return Err(bad(format!("c_b record {x:?}: sources do not match the level")));
            }
            let aend = u64::from(x.a) + mi * u64::from(x.rank);
            let wend = u64::from(x.w) + u64::from(x.rank) * u64::from(x.k);
            if aend > c_b_a.len() as u64 || wend > c_b_w.len() as u64 || x.rank > 4096 {
                return Err(bad(format!("c_b record {x:?}: factors out of range")));
            }
            c_b_records.push(x);
        }
        let receivers = u32s(a, "receivers", 3)?;
        let inpaint_mask = a
            .section("inpaint_mask")
            .ok_or_else(|| bad("section \"inpaint_mask\" is missing"))?
            .as_u8()
            .map_err(|e| bad(format!("inpaint_mask: {e}")))?;
        for r in receivers.chunks_exact(3) {
            if r[0] as usize >= nb || u64::from(r[1]) + u64::from(r[2]) > inpaint_mask.len() as u64 {
                return Err(bad(format!("receiver {r:?} out of range")));
            }
        }
        Ok(Self {
            du_b_records,
            du_b,
            du_c,
            c_c,
            instances,
            charts,
            albedo,
            positions,
            normals,
            t_d2c,
            c_b_records,
            c_b_srcs,
            c_b_a,
            c_b_w,
            receivers,
            inpaint_mask,
        })
    }

    /// Clutter texels (the length of `l_d,c` and `l_c`).
    pub fn clutter_texel_count(&self) -> usize {
        self.t_d2c.len()
    }

    /// Clutter charts (the length of `c`).
    pub fn chart_count(&self) -> usize {
        self.charts.len() / 3
    }
}

/// Which DRT paths to add (for measurements; the runtime normally adds all).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Paths {
    /// `ΔU_b b` (indirect shadows).
    pub occlusion: bool,
    /// `ΔU_c c` (light bounced off clutter onto the scene).
    pub reflection: bool,
}

impl Paths {
    /// Every path.
    pub const ALL: Self = Self { occlusion: true, reflection: true };
}

/// The DRT evaluator: buffers sized once.
#[derive(Debug, Clone)]
pub struct DrtRuntime<'a> {
    ops: DrtOperators<'a>,
    offsets: Vec<usize>,
    kb_of: Vec<usize>,
    c: Vec<f32>,
    tmp: Vec<f32>,
    scene_in: Vec<f32>,
    clutter_in: Vec<f32>,
    scene_out: Vec<f32>,
    clutter_out: Vec<f32>,
}

impl<'a> DrtRuntime<'a> {
    /// A runtime for the operators of the level `mrt` evaluates.
    pub fn new(ops: DrtOperators<'a>, mrt: &MrtRuntime<'_>) -> Self {
        let rank = ops
            .c_b_records
            .iter()
            .map(|r| r.rank as usize)
            .max()
            .unwrap_or(0)
            .max(ops.du_c.max_rank())
            .max(ops.c_c.max_rank());
        let m = ops.clutter_texel_count();
        let n = mrt.texel_count();
        Self {
            c: vec![0.0; ops.chart_count()],
            tmp: vec![0.0; rank],
            offsets: mrt.offsets().to_vec(),
            kb_of: mrt.level().shapes.iter().map(|&s| mrt.dictionary().shapes[s].k_b).collect(),
            scene_in: vec![0.0; n],
            clutter_in: vec![0.0; m],
            scene_out: vec![0.0; n],
            clutter_out: vec![0.0; m],
            ops,
        }
    }

    /// The operators.
    pub fn operators(&self) -> &DrtOperators<'a> {
        &self.ops
    }

    /// `c = T_d→c l_d,c` with each chart's albedo in `channel` (0..3) applied.
    pub fn project(&mut self, l_dc: &[f32], channel: usize) {
        assert!(l_dc.len() == self.ops.clutter_texel_count() && channel < 3, "l_dc length / channel");
        for (j, ch) in self.ops.charts.chunks_exact(3).enumerate() {
            let (f, m) = (ch[1] as usize, ch[2] as usize);
            let s: f32 = self.ops.t_d2c[f..f + m].iter().zip(&l_dc[f..f + m]).map(|(w, l)| w * l).sum();
            self.c[j] = self.ops.albedo[j * 3 + channel] * s;
        }
    }

    /// The clutter coefficients of the last [`DrtRuntime::project`].
    pub fn coefficients(&self) -> &[f32] {
        &self.c
    }

    /// Adds `s·Σ ΔU_b b` and `ΔU_c c` (the last projected `c`) to `out` (scene texels in block
    /// order). `b` is the MRT runtime's per-block `b` ([`MrtRuntime::coefficients`], stride
    /// `kb_stride`).
    pub fn add_scene(&mut self, b: &[f32], kb_stride: usize, scale: f32, paths: Paths, out: &mut [f32]) {
        if paths.occlusion {
            for r in &self.ops.du_b_records {
                let (rows, cols) = (r.rows as usize, r.cols as usize);
                let op = &self.ops.du_b[r.offset as usize..r.offset as usize + rows * cols];
                let bs = &b[r.src as usize * kb_stride..r.src as usize * kb_stride + cols];
                let o = &mut out[self.offsets[r.dst as usize]..self.offsets[r.dst as usize] + rows];
                for (t, ot) in o.iter_mut().enumerate() {
                    *ot += scale * dot(&op[t * cols..(t + 1) * cols], bs);
                }
            }
        }
        if paths.reflection {
            let offsets = &self.offsets;
            let mut tmp = core::mem::take(&mut self.tmp);
            self.ops.du_c.apply(&self.c, &mut tmp, &|dst| offsets[dst as usize], out);
            self.tmp = tmp;
        }
    }

    /// Clutter indirect irradiance `l_c = s·C_b b + C_c c` at every clutter texel (`c` from
    /// the last [`DrtRuntime::project`]).
    pub fn clutter_gather(&mut self, b: &[f32], kb_stride: usize, scale: f32, out: &mut [f32]) {
        assert!(out.len() == self.ops.clutter_texel_count(), "out must have clutter_texel_count() entries");
        out.iter_mut().for_each(|v| *v = 0.0);
        for r in &self.ops.c_b_records {
            let (rank, k) = (r.rank as usize, r.k as usize);
            let inst = &self.ops.instances[r.instance as usize * 4..r.instance as usize * 4 + 4];
            let (first, m) = (inst[0] as usize, inst[1] as usize);
            let w = &self.ops.c_b_w[r.w as usize..r.w as usize + rank * k];
            let srcs = &self.ops.c_b_srcs[r.srcs as usize..(r.srcs + r.nsrc) as usize];
            // tmp = W b_stack, with b_stack the sources' b read in place, block by block
            let tmp = &mut self.tmp[..rank];
            tmp.iter_mut().for_each(|v| *v = 0.0);
            let mut off = 0;
            for &s in srcs {
                let kb = self.kb_of[s as usize];
                let bs = &b[s as usize * kb_stride..s as usize * kb_stride + kb];
                for (i, ti) in tmp.iter_mut().enumerate() {
                    *ti += dot(&w[i * k + off..i * k + off + kb], bs);
                }
                off += kb;
            }
            let a = &self.ops.c_b_a[r.a as usize..r.a as usize + m * rank];
            for (t, ot) in out[first..first + m].iter_mut().enumerate() {
                *ot = scale * dot(&a[t * rank..(t + 1) * rank], tmp);
            }
        }
        // C_c c: light bounced off other clutter (and other faces of the same object)
        let inst = self.ops.instances;
        let mut tmp = core::mem::take(&mut self.tmp);
        self.ops.c_c.apply(&self.c, &mut tmp, &|i| inst[i as usize * 4] as usize, out);
        self.tmp = tmp;
    }

    /// One bounce with clutter: `mrt` evaluates the MRT part of `l_d` (scene direct
    /// irradiance), then the DRT paths are added; `l_dc` is the clutter's direct irradiance,
    /// `channel` selects the clutter albedo, `scale` is the walls' albedo over the
    /// dictionary's baked albedo. Writes the scene's indirect irradiance to `scene` and the
    /// clutter's to `clutter`.
    #[allow(clippy::too_many_arguments)]
    pub fn one_bounce(
        &mut self,
        mrt: &mut MrtRuntime<'_>,
        l_d: &[f32],
        l_dc: &[f32],
        channel: usize,
        scale: f32,
        paths: Paths,
        scene: &mut [f32],
        clutter: &mut [f32],
    ) {
        mrt.indirect(l_d, scene, true);
        scene.iter_mut().for_each(|v| *v *= scale);
        self.project(l_dc, channel);
        let kb = mrt.level().k_b;
        self.add_scene(mrt.coefficients(), kb, scale, paths, scene);
        self.clutter_gather(mrt.coefficients(), kb, scale, clutter);
    }

    /// `bounces` bounces through scene and clutter (module docs); the sums of the bounces go
    /// to `scene` and `clutter`.
    #[allow(clippy::too_many_arguments)]
    pub fn multi_bounce(
        &mut self,
        mrt: &mut MrtRuntime<'_>,
        l_d: &[f32],
        l_dc: &[f32],
        channel: usize,
        scale: f32,
        bounces: usize,
        scene: &mut [f32],
        clutter: &mut [f32],
    ) {
        scene.iter_mut().for_each(|v| *v = 0.0);
        clutter.iter_mut().for_each(|v| *v = 0.0);
        let mut si = core::mem::take(&mut self.scene_in);
        let mut ci = core::mem::take(&mut self.clutter_in);
        let mut so = core::mem::take(&mut self.scene_out);
        let mut co = core::mem::take(&mut self.clutter_out);
        si.copy_from_slice(l_d);
        ci.copy_from_slice(l_dc);
        for _ in 0..bounces {
            self.one_bounce(mrt, &si, &ci, channel, scale, Paths::ALL, &mut so, &mut co);
            for ((o, x), i) in scene.iter_mut().zip(&so).zip(si.iter_mut()) {
                *o += x;
                *i = *x;
            }
            for ((o, x), i) in clutter.iter_mut().zip(&co).zip(ci.iter_mut()) {
                *o += x;
                *i = *x;
            }
        }
        self.scene_in = si;
        self.clutter_in = ci;
        self.scene_out = so;
        self.clutter_out = co;
    }
}
