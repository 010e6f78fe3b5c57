//! The DRT ray loops' walk through the level and their clutter pre-filter, with everything
//! that does not depend on the ray precomputed per block.
//!
//! [`Walk::trace`] is [`LevelGeometry::trace_segments`] with each block's world bounds,
//! face map and neighbours looked up instead of rebuilt per ray (the quarter turn of the
//! scale, the `OnceLock` of the face table, the shape's missing-face mask and the links),
//! and the direction's reciprocals passed in. It computes the same expressions in the same
//! order, so it gives the same faces, points and segments bit for bit (tested against
//! `trace_segments` on every texel ray of a maze).
//!
//! [`Walk::prefilter`] tests the padded boxes of a block's clutter instances against a
//! segment in one branch-free loop over structure-of-arrays bounds. It is a filter only:
//! the survivors go to [`ClutterScene::closest_among_except_inv`] in their original order,
//! which repeats the same padded test with its shrinking upper bound, so the closest hit is
//! the one the unfiltered search returns (a box the filter drops fails that search's first
//! test, whose interval is a sub-interval of the filter's).
//!
//! [`LevelGeometry::trace_segments`]: crate::level_reference::LevelGeometry::trace_segments
//! [`ClutterScene::closest_among_except_inv`]: crate::clutter::ClutterScene::closest_among_except_inv

use crate::clutter::ClutterScene;
use crate::gather::DirectionSet;
use crate::level::{Level, Links, rotate_y, world_face};
use crate::shape::FACE_COUNT;

/// `next` of a local face that is a wall.
const WALL: u32 = u32::MAX - 1;
/// `next` of an opening with no neighbour: the ray leaves the level.
const LOST: u32 = u32::MAX;

/// One block's walk data.
#[derive(Debug, Clone)]
struct BlockWalk {
    /// World bounds (the expressions of `world_exit`).
    lo: [f64; 3],
    hi: [f64; 3],
    /// Local face on world face `w` (`2·axis`: low end, `2·axis + 1`: high end).
    local: [usize; FACE_COUNT],
    /// Per local face: [`WALL`], [`LOST`] or the neighbouring block.
    next: [u32; FACE_COUNT],
}

/// The padded boxes of one block's clutter instances, structure of arrays.
#[derive(Debug, Clone, Default)]
struct BlockBoxes {
    inst: Vec<usize>,
    lo: [Vec<f64>; 3],
    hi: [Vec<f64>; 3],
}

/// Instances per block the branch-free pre-filter handles (a `u64` mask); a block with
/// more goes straight to the closest-hit search.
const MASK_BITS: usize = 64;

/// The level walk and clutter pre-filter of a DRT scene.
#[derive(Debug, Clone)]
pub(crate) struct Walk {
    blocks: Vec<BlockWalk>,
    boxes: Vec<BlockBoxes>,
}

impl Walk {
    /// Precomputes the walk of `level` (missing-face masks per shape) and the padded boxes
    /// of `block_clutter`'s instances.
    pub(crate) fn new(
        level: &Level,
        links: &Links,
        missing: &[u8],
        clutter: &ClutterScene,
        block_clutter: &[Vec<usize>],
    ) -> Self {
        let blocks = level
            .blocks
            .iter()
            .enumerate()
            .map(|(b, blk)| {
                let ext = rotate_y(blk.scale, blk.rotation);
                let mut lo = [0.0; 3];
                let mut hi = [0.0; 3];
                for a in 0..3 {
                    let h = 0.5 * ext[a].abs();
                    (lo[a], hi[a]) = (blk.translation[a] - h, blk.translation[a] + h);
                }
                let mut local = [0; FACE_COUNT];
                for f in 0..FACE_COUNT {
                    local[world_face(f, blk.rotation % 4)] = f;
                }
                let next = core::array::from_fn(|f| {
                    if missing[blk.shape] & (1 << f) == 0 {
                        WALL
                    } else {
                        match links[b][f] {
                            Some((y, _)) => y as u32,
                            None => LOST,
                        }
                    }
                });
                BlockWalk { lo, hi, local, next }
            })
            .collect();
        let boxes = block_clutter
            .iter()
            .map(|insts| {
                let mut bb = BlockBoxes { inst: insts.clone(), ..BlockBoxes::default() };
                for &i in insts {
                    let [lo, hi] = clutter.padded_bounds(i);
                    for k in 0..3 {
                        bb.lo[k].push(lo[k]);
                        bb.hi[k].push(hi[k]);
                    }
                }
                bb
            })
            .collect();
        Self { blocks, boxes }
    }

    /// [`LevelGeometry::trace_segments`](crate::level_reference::LevelGeometry::trace_segments)
    /// from `p` in block `b` along `d` (`inv = 1/d` per component): the wall hit
    /// `(block, local face, world point)` and the blocks crossed in `segs`.
    #[inline]
    pub(crate) fn trace(
        &self,
        mut b: usize,
        mut p: [f64; 3],
        d: [f64; 3],
        inv: [f64; 3],
        segs: &mut Vec<(usize, f64, f64)>,
    ) -> Option<(usize, usize, [f64; 3])> {
        segs.clear();
        let mut travelled = 0.0;
        for _ in 0..4 * self.blocks.len() + 4 {
            let w = &self.blocks[b];
            let mut best = (usize::MAX, f64::INFINITY);
            for a in 0..3 {
                let pa = p[a].clamp(w.lo[a], w.hi[a]);
                let (t, wf) = if d[a] > 0.0 {
                    ((w.hi[a] - pa) * inv[a], 2 * a + 1)
                } else if d[a] < 0.0 {
                    ((w.lo[a] - pa) * inv[a], 2 * a)
                } else {
                    continue;
                };
                let f = w.local[wf];
                if t < best.1 || (t == best.1 && f < best.0) {
                    best = (f, t);
                }
            }
            let (f, t) = best;
            if f == usize::MAX {
                return None;
            }
            segs.push((b, travelled, travelled + t));
            let q = [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]];
            match w.next[f] {
                WALL => return Some((b, f, q)),
                LOST => return None,
                y => {
                    b = y as usize;
                    p = q;
                    travelled += t;
                }
            }
        }
        None
    }

    /// Bit `j` set when the padded box of block `y`'s `j`-th instance meets the ray
    /// `o + t·d` for some `t ∈ [t0, t1]`; `None` when the block has more than
    /// [`MASK_BITS`] instances (then every instance is a candidate).
    #[inline]
    pub(crate) fn prefilter(&self, y: usize, o: [f64; 3], inv: [f64; 3], (t0, t1): (f64, f64)) -> Option<u64> {
        let bb = &self.boxes[y];
        let n = bb.inst.len();
        if n > MASK_BITS {
            return None;
        }
        let lo: [&[f64]; 3] = core::array::from_fn(|k| &bb.lo[k][..n]);
        let hi: [&[f64]; 3] = core::array::from_fn(|k| &bb.hi[k][..n]);
        let mut mask = 0u64;
        for j in 0..n {
            // `slab_inv`'s expressions; its early return is the last comparison here, since
            // the entry only grows and the exit only shrinks
            let (mut a0, mut a1) = (t0, t1);
            for k in 0..3 {
                let (a, b) = ((lo[k][j] - o[k]) * inv[k], (hi[k][j] - o[k]) * inv[k]);
                let (a, b) = if a > b { (b, a) } else { (a, b) };
                a0 = if a > a0 { a } else { a0 };
                a1 = if b < a1 { b } else { a1 };
            }
            mask |= u64::from(a0 <= a1) << j;
        }
        Some(mask)
    }

    /// Instances of block `y`.
    #[inline]
    pub(crate) fn instances(&self, y: usize) -> &[usize] {
        &self.boxes[y].inst
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drt::cluttered_blocks;
    use crate::level_reference::LevelGeometry;
    use crate::shape::CUBE2D;
    use penumbra_math::rng::{hash4, unit_f64};

    /// The coherent order is a permutation of the cosine set, and consecutive rays change
    /// the sign of a component far less often than in Hammersley order.
    #[test]
    fn the_coherent_order_permutes_the_cosine_set_and_keeps_signs_steady() {
        let key = |v: &Vec<[f64; 3]>| {
            let mut k: Vec<[u64; 3]> = v.iter().map(|d| d.map(f64::to_bits)).collect();
            k.sort_unstable();
            k
        };
        let flips = |v: &[[f64; 3]]| {
            v.windows(2).map(|w| (0..2).filter(|&k| (w[0][k] > 0.0) != (w[1][k] > 0.0)).count()).sum::<usize>()
        };
        let (a, b) = (DirectionSet::cosine(1024).dirs, coherent_cosine(1024).dirs);
        assert_eq!(key(&a), key(&b));
        // Hammersley: about one flip per ray; sectors: a few per sector boundary and turn
        assert!(flips(&a) > 800 && flips(&b) < 64, "{} {}", flips(&a), flips(&b));
    }

    /// Every ray of a random maze with boxes: the same wall, segments and closest clutter
    /// hit as the unfiltered walk and search, bit for bit, including rays along the axes
    /// and from points on block faces.
    #[test]
    fn the_walk_and_pre_filter_give_the_unfiltered_answers_bit_for_bit() {
        let names: Vec<String> = CUBE2D.iter().map(|s| s.name.to_string()).collect();
        let missing: Vec<u8> = CUBE2D.iter().map(|s| s.missing).collect();
        let ex = crate::drt_examples::example("maze-boxes", &names, &missing, 12, 3, 30).unwrap();
        let links = ex.level.validate(&names, &missing).unwrap();
        let clutter = ClutterScene::new(&ex.clutter, 4).unwrap();
        let mut block_clutter = vec![Vec::new(); ex.level.blocks.len()];
        for i in 0..clutter.len() {
            for b in cluttered_blocks(&ex.level, &clutter, i) {
                block_clutter[b].push(i);
            }
        }
        let walk = Walk::new(&ex.level, &links, &missing, &clutter, &block_clutter);
        let geo = LevelGeometry { level: &ex.level, links: &links, missing: &missing };
        let (mut s0, mut s1) = (Vec::new(), Vec::new());
        let (mut walls, mut hits) = (0, 0);
        for r in 0..40_000u64 {
            let u = |j: u64| unit_f64(hash4(5, 0x5741, r, j));
            let b = ((u(0) * ex.level.blocks.len() as f64) as usize).min(ex.level.blocks.len() - 1);
            // every 4th origin on a face of the block, every 8th direction along an axis
            let mut l = [u(1), u(2), u(3)];
            if r % 4 == 0 {
                l[(r / 4 % 3) as usize] = (r / 12 % 2) as f64;
            }
            let p = ex.level.blocks[b].to_world(l);
            let mut d = penumbra_math::warp::uniform_sphere(u(4), u(5));
            if r % 8 == 1 {
                d = [0.0; 3];
                d[(r / 8 % 3) as usize] = if r % 16 == 1 { 1.0 } else { -1.0 };
            }
            let inv = d.map(|c| 1.0 / c);
            let a = geo.trace_segments(b, p, d, &mut s0).map(|h| (h.block, h.face, h.point));
            let w = walk.trace(b, p, d, inv, &mut s1);
            assert_eq!(a.map(|h| (h.0, h.1, h.2.map(f64::to_bits))), w.map(|h| (h.0, h.1, h.2.map(f64::to_bits))));
            assert_eq!(s0, s1);
            walls += usize::from(a.is_some());
            for &(y, t0, t1) in &s0 {
                let tmin = t0.max(1e-9);
                let all = clutter.closest_among_except_inv(&block_clutter[y], usize::MAX, p, d, inv, tmin, t1);
                let mask = walk.prefilter(y, p, inv, (tmin, t1)).unwrap();
                let cand = Bits(mask).map(|j| block_clutter[y][j]);
                let some = clutter.closest_among_except_iter(cand, usize::MAX, p, d, inv, tmin, t1);
                assert_eq!(
                    all.map(|h| (h.t.to_bits(), h.chart, h.front)),
                    some.map(|h| (h.t.to_bits(), h.chart, h.front))
                );
                hits += usize::from(all.is_some());
            }
        }
        // the test saw both outcomes in numbers
        assert!(walls > 30_000 && hits > 1_000, "{walls} walls, {hits} clutter hits");
    }
}

/// Azimuth sectors of [`coherent_cosine`].
const SECTORS: usize = 16;

/// The cosine-weighted direction set [`DirectionSet::cosine`] in an order that keeps
/// consecutive rays close: by azimuth sector, and within a sector by elevation, up and down
/// in turn. Hammersley's order steps the azimuth by a radical inverse, so the signs of a
/// ray's components, which pick the walk's exit faces and the slab tests' branches, are a
/// coin toss from one ray to the next; in this order they change a few dozen times per
/// texel. A texel's sums are integers (`crate::drt_state`), so the order of its rays
/// changes nothing in the result.
pub(crate) fn coherent_cosine(n: usize) -> DirectionSet {
    let mut dirs = DirectionSet::cosine(n).dirs;
    let key = |d: &[f64; 3]| {
        let phi = d[1].atan2(d[0]).rem_euclid(2.0 * core::f64::consts::PI);
        let s = ((phi / (2.0 * core::f64::consts::PI) * SECTORS as f64) as usize).min(SECTORS - 1);
        (s, if s % 2 == 0 { d[2] } else { -d[2] })
    };
    dirs.sort_by(|a, b| {
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    DirectionSet { dirs }
}

/// The set bits of a mask, lowest first.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Bits(pub u64);

impl Iterator for Bits {
    type Item = usize;
    #[inline]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let j = self.0.trailing_zeros() as usize;
        self.0 &= self.0 - 1;
        Some(j)
    }
}
