//! The canonical frame the fit runs in: the mesh translated to its bounding-box centre,
//! scaled to unit bounding-box diagonal, and quantised to a grid of 2⁻³² units.
//!
//! Why: every tolerance, grid spacing and optimiser step inside the fit is then relative,
//! so the fit of a mesh scaled by 10⁻⁴ or 10⁴ is the fit of the unscaled mesh, up to scale.
//! Rounding the normalised coordinates to 2⁻³² (≈ 2·10⁻¹⁰ of the diagonal, far below any
//! accuracy that matters) makes the normalised meshes of scaled copies bit-identical unless
//! a coordinate straddles a rounding boundary (probability ≈ 10⁻⁷ per coordinate), so the
//! optimiser takes the same path. Results are mapped back and made bounding against the
//! original coordinates, so the quantisation never costs coverage.

use penumbra_geometry::TriMesh;

/// Quantisation step of normalised coordinates.
const QUANTUM: f64 = 1.0 / 4_294_967_296.0;

/// Similarity between input and canonical coordinates: `q = (p − center) / scale`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Bounding-box centre of the input.
    pub center: [f64; 3],
    /// Bounding-box diagonal of the input (> 0).
    pub scale: f64,
}

impl Frame {
    /// The frame of a mesh; `None` when its bounding box is a single point or not finite.
    pub fn of(mesh: &TriMesh) -> Option<Self> {
        let b = mesh.bounds()?;
        let scale = b.diagonal();
        (scale > 0.0 && scale.is_finite()).then(|| Self { center: b.center(), scale })
    }

    /// Input → canonical, quantised.
    #[inline]
    pub fn to_canonical(&self, p: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| (((p[k] - self.center[k]) / self.scale) / QUANTUM).round() * QUANTUM)
    }

    /// Canonical → input.
    #[inline]
    pub fn to_input(&self, q: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| self.center[k] + q[k] * self.scale)
    }

    /// The mesh in canonical coordinates.
    pub fn canonical_mesh(&self, mesh: &TriMesh) -> TriMesh {
        TriMesh {
            positions: mesh.positions.iter().map(|&p| self.to_canonical(p)).collect(),
            indices: mesh.indices.clone(),
        }
    }
}
