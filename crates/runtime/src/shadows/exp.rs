//! The SH exponential at run time (SHEXP §4), dispatched on [`RuntimeExp`]: HYB (OL with
//! scaling and squaring, §4.3), OL (eq. 23) or PS*-p (§4.3), per receiver or on every lane
//! of a receiver batch. The methods themselves live in `ShTables` (they read its OL table
//! and its triple-product tensor).

use super::batch::LANES;
use super::{RuntimeExp, ShadowEvaluator};

impl ShadowEvaluator<'_> {
    /// `g = exp*(f)` with the configured method.
    pub fn exponentiate(&self, f: &[f32], g: &mut [f32]) {
        match self.options.exp {
            RuntimeExp::Hyb => self.tables.exp_hyb(f, g),
            RuntimeExp::Ol => self.tables.exp_ol(f, g),
            RuntimeExp::PsStar(p) => self.tables.exp_ps_star(f, p, g),
        }
    }

    /// [`ShadowEvaluator::exponentiate`] on every lane: HYB batched (all lanes squared as
    /// often as the neediest; the others keep their value), OL and PS*-p lane by lane.
    #[inline(always)]
    pub(crate) fn exponentiate_lanes<const M: usize>(&self, f: &[[f32; LANES]; M], g: &mut [[f32; LANES]; M]) {
        if self.options.exp == RuntimeExp::Hyb {
            self.tables.exp_hyb_lanes::<M, LANES>(f, g);
            return;
        }
        for lane in 0..LANES {
            let fl: [f32; M] = core::array::from_fn(|i| f[i][lane]);
            let mut gl = [0.0f32; M];
            self.exponentiate(&fl, &mut gl);
            for i in 0..M {
                g[i][lane] = gl[i];
            }
        }
    }
}
