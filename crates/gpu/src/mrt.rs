//! The MRT runtime on the GPU: `shaders/mrt.wgsl` over an [`MrtRuntime`]'s dictionary and
//! level, flattened into the buffers the shader's header describes.

use crate::GpuError;
use crate::device::{Gpu, groups64};
use penumbra_runtime::mrt::MrtRuntime;

/// The shader's source.
pub const SOURCE: &str = include_str!("../shaders/mrt.wgsl");
/// Its entry points, in dispatch order.
pub const ENTRY_POINTS: &[&str] =
    &["project", "apply_ub", "respond", "apply_ur", "feedback", "pad_tiles", "pad_border"];

const SHAPE_STRIDE: usize = 20;
const NONE: u32 = u32::MAX;

#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    n_blocks: u32,
    kb: u32,
    k_r: u32,
    r2: u32,
    exclude: u32,
    n_groups: u32,
    n_texels: u32,
    res: u32,
    atlas_w: u32,
    n_tiles: u32,
    n_pad: u32,
    albedo_scale: f32,
}

/// The buffers and pipelines of one level.
#[derive(Debug)]
pub struct GpuMrt<'g> {
    gpu: &'g Gpu,
    params: Params,
    max_n: usize,
    n_atlas: usize,
    uniform: wgpu::Buffer,
    bufs: Vec<wgpu::Buffer>,
    pipes: Vec<wgpu::ComputePipeline>,
    bind_groups: Vec<wgpu::BindGroup>,
}

// binding indices of the shader
const B_SHAPES: usize = 1;
const B_LD: usize = 5;
const B_OUT: usize = 8;
const B_TOTAL: usize = 15;
const B_ATLAS: usize = 18;

/// The bindings each entry point uses (auto layouts hold exactly these).
const USES: [&[u32]; 7] = [
    &[0, 1, 2, 4, 5, 6, 7],
    &[0, 1, 2, 3, 6, 7, 8],
    &[0, 6, 9, 10, 11, 12],
    &[0, 1, 2, 8, 9, 12, 13, 14],
    &[0, 5, 8, 15],
    &[0, 1, 2, 8, 16, 18],
    &[0, 2, 8, 17, 18],
];

impl<'g> GpuMrt<'g> {
    /// Uploads the runtime's dictionary and level.
    pub fn new(gpu: &'g Gpu, rt: &MrtRuntime<'_>) -> Result<Self, GpuError> {
        let d = rt.dictionary();
        let l = rt.level();
        if !l.warps.is_empty() {
            // MRTL kind version 2 re-baked warps (`T_d→b'`, `U_b'`, `b = X b'`) are not in
            // mrt.wgsl yet: refuse rather than evaluate the unit operators silently
            return Err(GpuError::Unsupported("re-baked warped blocks (MRTL warp sections)".into()));
        }
        let offsets = rt.offsets();
        let (mut shapes, mut u_b, mut t_d2b, mut u_r_idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for s in &d.shapes {
            let mut e = [0u32; SHAPE_STRIDE];
            e[0] = s.n as u32;
            e[1] = s.k_b as u32;
            e[2] = s.faces.len() as u32;
            e[3] = u_b.len() as u32;
            e[4] = t_d2b.len() as u32;
            u_b.extend_from_slice(s.u_b);
            t_d2b.extend_from_slice(s.t_d2b);
            for f in 0..6 {
                e[5 + f] = match s.u_r_idx[f] {
                    Some(idx) => {
                        let o = u_r_idx.len() as u32;
                        u_r_idx.extend_from_slice(idx);
                        o
                    }
                    None => NONE,
                };
                e[11 + f] = s.faces.get(f).map_or(NONE, |&g| u32::from(g));
            }
            shapes.extend_from_slice(&e);
        }
        let groups_dst = rt.response_groups();
        // response groups: (dst, face, first record, end record), records sorted by (dst, face, src)
        let mut groups = Vec::with_capacity(groups_dst.len() * 4);
        let mut i = 0;
        for &(dst, face) in groups_dst {
            let start = i;
            while i < l.records.len() && (l.records[i].dst, l.records[i].face) == (dst, face) {
                i += 1;
            }
            groups.extend_from_slice(&[dst, face, start as u32, i as u32]);
        }
        let nb = l.shapes.len();
        let mut blocks = Vec::with_capacity(nb * 4);
        for x in 0..nb {
            let first = groups_dst.iter().position(|g| g.0 as usize == x).unwrap_or(groups_dst.len());
            let end = groups_dst.iter().rposition(|g| g.0 as usize == x).map_or(first, |p| p + 1);
            blocks.extend_from_slice(&[l.shapes[x] as u32, offsets[x] as u32, first as u32, end as u32]);
        }
        let rec_src: Vec<u32> = l.records.iter().map(|r| r.src).collect();
        let n_texels = rt.texel_count();
        let max_n = d.shapes.iter().map(|s| s.n).max().unwrap_or(0);
        let res = (d.face_texels as f64).sqrt() as usize;
        let params = Params {
            n_blocks: nb as u32,
            kb: l.k_b as u32,
            k_r: d.k_r as u32,
            r2: d.face_texels as u32,
            exclude: u32::from(d.exclude_same_face),
            n_groups: groups_dst.len() as u32,
            n_texels: n_texels as u32,
            res: res as u32,
            atlas_w: l.atlas.0 as u32,
            n_tiles: (l.tiles.len() / 4) as u32,
            n_pad: (l.pad.len() / 3) as u32,
            albedo_scale: 1.0,
        };
        let n_atlas = l.atlas.0 * l.atlas.1;
        let bufs = vec![
            gpu.zeros("unused", 1),
            gpu.storage("shapes", &shapes),
            gpu.storage("blocks", &blocks),
            gpu.storage("u_b", &u_b),
            gpu.storage("t_d2b", &t_d2b),
            gpu.zeros("l_d", n_texels),
            gpu.zeros("b", nb * l.k_b),
            gpu.zeros("b_face", nb * 6 * l.k_b),
            gpu.zeros("out", n_texels),
            gpu.storage("groups", &groups),
            gpu.storage("rec_src", &rec_src),
            gpu.storage("t_b2r", l.t_b2r),
            gpu.zeros("r", groups_dst.len() * d.k_r),
            gpu.storage("u_r_idx", &u_r_idx),
            gpu.storage("u_r", d.u_r),
            gpu.zeros("total", n_texels),
            gpu.storage("tiles", l.tiles),
            gpu.storage("pad", l.pad),
            gpu.zeros("atlas", n_atlas),
        ];
        debug_assert_eq!(bufs[B_SHAPES].size() as usize, (shapes.len() * 4).max(4));
        let uniform = gpu.uniform("params", &params);
        let pipes = gpu.pipelines("mrt.wgsl", SOURCE, ENTRY_POINTS);
        let bind_groups = (0..ENTRY_POINTS.len())
            .map(|k| {
                let entries: Vec<(u32, &wgpu::Buffer)> =
                    USES[k].iter().map(|&b| (b, if b == 0 { &uniform } else { &bufs[b as usize] })).collect();
                gpu.bind(&pipes[k], &entries)
            })
            .collect();
        Ok(Self { gpu, params, max_n, n_atlas, uniform, bufs, pipes, bind_groups })
    }

    fn dispatch(&self, enc: &mut wgpu::CommandEncoder, k: usize, x: u32, y: u32) {
        let mut pass = enc
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(ENTRY_POINTS[k]), timestamp_writes: None });
        pass.set_pipeline(&self.pipes[k]);
        pass.set_bind_group(0, &self.bind_groups[k], &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Records one evaluation of `indirect` (the direct light already in `l_d`).
    fn record_indirect(&self, enc: &mut wgpu::CommandEncoder, interfaces: bool) {
        let p = &self.params;
        self.dispatch(enc, 0, groups64(p.kb as usize), p.n_blocks);
        self.dispatch(enc, 1, groups64(self.max_n), p.n_blocks);
        if interfaces && p.n_groups > 0 {
            self.dispatch(enc, 2, groups64(p.k_r as usize), p.n_groups);
            self.dispatch(enc, 3, groups64(self.max_n), p.n_blocks);
        }
    }

    fn set_scale(&mut self, albedo_scale: f32) {
        self.params.albedo_scale = albedo_scale;
        self.gpu.queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.params));
    }

    /// [`MrtRuntime::indirect`] on the GPU: one-bounce indirect light at every texel.
    pub fn indirect(&mut self, l_d: &[f32], interfaces: bool) -> Result<Vec<f32>, GpuError> {
        let n = self.params.n_texels as usize;
        check_len("l_d", l_d.len(), n)?;
        self.gpu.queue.write_buffer(&self.bufs[B_LD], 0, bytemuck::cast_slice(l_d));
        let mut enc = self.gpu.encoder();
        self.record_indirect(&mut enc, interfaces);
        self.gpu.read(enc, &self.bufs[B_OUT], n)
    }

    /// [`MrtRuntime::multi_bounce`] on the GPU.
    pub fn multi_bounce(&mut self, l_d: &[f32], bounces: usize, albedo_scale: f32) -> Result<Vec<f32>, GpuError> {
        let n = self.params.n_texels as usize;
        check_len("l_d", l_d.len(), n)?;
        self.set_scale(albedo_scale);
        self.gpu.queue.write_buffer(&self.bufs[B_LD], 0, bytemuck::cast_slice(l_d));
        let mut enc = self.gpu.encoder();
        enc.clear_buffer(&self.bufs[B_TOTAL], 0, None);
        for _ in 0..bounces {
            self.record_indirect(&mut enc, true);
            self.dispatch(&mut enc, 4, groups64(n), 1);
        }
        self.gpu.read(enc, &self.bufs[B_TOTAL], n)
    }

    /// [`MrtRuntime::pad_atlas`] on the GPU, into a zeroed atlas.
    pub fn pad_atlas(&mut self, texels: &[f32]) -> Result<Vec<f32>, GpuError> {
        check_len("texels", texels.len(), self.params.n_texels as usize)?;
        self.gpu.queue.write_buffer(&self.bufs[B_OUT], 0, bytemuck::cast_slice(texels));
        let mut enc = self.gpu.encoder();
        enc.clear_buffer(&self.bufs[B_ATLAS], 0, None);
        let p = self.params;
        self.dispatch(&mut enc, 5, groups64(p.r2 as usize), p.n_tiles);
        self.dispatch(&mut enc, 6, groups64(p.n_pad as usize), 1);
        self.gpu.read(enc, &self.bufs[B_ATLAS], self.n_atlas)
    }

    /// Milliseconds of one `indirect` evaluation (interfaces on), the median of `reps`, the
    /// direct light already uploaded by [`Self::indirect`]; submission and wait included.
    pub fn time_indirect(&self, reps: usize) -> Result<f64, GpuError> {
        let mut ms = Vec::with_capacity(reps);
        for _ in 0..reps.max(1) {
            let t = std::time::Instant::now();
            let mut enc = self.gpu.encoder();
            self.record_indirect(&mut enc, true);
            self.gpu.run(enc)?;
            ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        ms.sort_by(f64::total_cmp);
        Ok(ms[ms.len() / 2])
    }
}

fn check_len(what: &'static str, got: usize, want: usize) -> Result<(), GpuError> {
    if got == want { Ok(()) } else { Err(GpuError::Size { what, got, want }) }
}
