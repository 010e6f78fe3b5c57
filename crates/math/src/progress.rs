//! Progress reporting from libraries. Libraries never print: they call a [`Progress`]
//! sink owned by the CLI, which renders a bar, periodic log lines, or nothing.

/// Receives progress of a bake. Implementations must be cheap and thread-safe: bakers
/// call it from rayon workers, once per chunk of work (not per item).
pub trait Progress: Sync {
    /// `done` of `total` units of `stage` are finished.
    fn update(&self, stage: &str, done: u64, total: u64);
}

/// A sink that ignores everything.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn update(&self, _: &str, _: u64, _: u64) {}
}
