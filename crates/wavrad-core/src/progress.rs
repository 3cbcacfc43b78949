//! Progress of the long phases (refinement, solve, render), reported to
//! whoever drives them: the CLI draws bars, Python calls back, tests stay
//! silent.

/// Receives progress of the long phases (the CLI draws bars; default: none).
pub trait Progress: Sync {
    /// A phase with `total` steps starts.
    fn start(&self, _phase: &str, _total: u64) {}
    /// `steps` more steps are done.
    fn advance(&self, _steps: u64) {}
    /// The phase is over.
    fn finish(&self) {}
}

/// Progress that reports nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;
impl Progress for Silent {}
