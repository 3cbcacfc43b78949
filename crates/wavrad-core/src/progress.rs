//! Progress of the long phases (refinement, solve, render), reported to
//! whoever drives them: the CLI draws bars, Python calls back, tests stay
//! silent. The driver may also ask the work to stop ([`Progress::interrupted`]);
//! with the time and memory limits that makes a solve's [`Budget`].

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Receives progress of the long phases (the CLI draws bars; default: none).
pub trait Progress: Sync {
    /// A phase with `total` steps starts.
    fn start(&self, _phase: &str, _total: u64) {}
    /// `steps` more steps are done.
    fn advance(&self, _steps: u64) {}
    /// The phase is over.
    fn finish(&self) {}
    /// Whether the driver asks the work to stop (Ctrl-C): refinement stops
    /// splitting and the solve stops sweeping, as when a [`Budget`] is
    /// spent. Default: never.
    fn interrupted(&self) -> bool {
        false
    }
    /// `items` (surface pairs or triples, links, pairs of clusters) were
    /// linked whole or left as they were, instead of refined, because the
    /// work was asked to stop.
    fn cut_short(&self, _items: u64) {}
    /// `items` (surface triples) were left out, without any links, because
    /// the work was asked to stop before they started: a three-point item
    /// linked whole still costs a quadrature, and a glossy mesh can plan
    /// hundreds of millions of them.
    fn left_out(&self, _items: u64) {}
    /// Links of `bytes` were made and are held until the solve's end.
    fn holding(&self, _bytes: u64) {}
    /// Something the user should know before the work goes on (the CLI
    /// prints it as a warning): a plan too large to project in full.
    fn warn(&self, _message: &str) {}
}

/// Progress that reports nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;
impl Progress for Silent {}

/// A driver's stop request without its reports: for work nested inside a
/// phase that already reports its own progress (the refinement inside one
/// shooting step), which must still stop when asked.
pub struct StopOnly<'a>(pub &'a dyn Progress);

impl Progress for StopOnly<'_> {
    fn interrupted(&self) -> bool {
        self.0.interrupted()
    }
    fn cut_short(&self, items: u64) {
        self.0.cut_short(items)
    }
    fn left_out(&self, items: u64) {
        self.0.left_out(items)
    }
    fn warn(&self, message: &str) {
        self.0.warn(message)
    }
    fn holding(&self, bytes: u64) {
        self.0.holding(bytes)
    }
}

/// What cut a solve short.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// Its wall-clock time limit passed.
    TimeLimit,
    /// The process's resident memory reached its limit.
    MemoryLimit,
    /// The driver interrupted it ([`Progress::interrupted`]).
    Interrupted,
}

impl std::fmt::Display for Stop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Stop::TimeLimit => "the time limit",
            Stop::MemoryLimit => "the memory limit",
            Stop::Interrupted => "an interrupt",
        })
    }
}

/// Copies of the links a projection made that the end of a solve holds
/// besides them (their concatenation, their arrangement for gathering, a
/// checkpoint's), so that the memory limit is reached when the process's
/// memory plus this many times the links held ([`Progress::holding`])
/// reaches it: the refinement stops where what follows it still fits.
/// What else a link costs the solve is held with a share per copy.
pub const LINK_COPIES: u64 = 2;

/// How often, at most, the resident memory is read.
const MEMORY_CHECK_INTERVAL: Duration = Duration::from_millis(50);

/// The limits a solve respects: a wall-clock time limit from its start, a
/// limit on the process's resident memory, and the driver's interrupt.
/// Once one is reached the budget stays spent: linking links the pairs of
/// clusters left at the coarsest ratio and refinement links the items left
/// without splitting them (both counted in [`Budget::coarse_items`]), the
/// three-point items not yet started are left out (counted in
/// [`Budget::left_out_items`]) and Gauss–Seidel stops after its current
/// sweep, so the solution is finished from what was done.
#[derive(Debug)]
pub struct Budget {
    started: Instant,
    time_limit: Option<Duration>,
    max_memory: Option<u64>,
    /// Nanoseconds from `started` at which memory is next read.
    next_memory_check: AtomicU64,
    spent: OnceLock<Stop>,
    coarse: AtomicUsize,
    left_out: AtomicUsize,
    held: AtomicU64,
}

impl Budget {
    /// A budget from now: at most `time_limit` of wall-clock time and
    /// `max_memory` bytes of resident memory (`None`: no limit).
    pub fn new(time_limit: Option<Duration>, max_memory: Option<u64>) -> Budget {
        Budget {
            started: Instant::now(),
            time_limit,
            max_memory,
            next_memory_check: AtomicU64::new(0),
            spent: OnceLock::new(),
            coarse: AtomicUsize::new(0),
            left_out: AtomicUsize::new(0),
            held: AtomicU64::new(0),
        }
    }

    /// No limits (an interrupt still stops the work).
    pub fn unlimited() -> Budget {
        Budget::new(None, None)
    }

    /// What spent the budget, checking the limits and `progress`'s
    /// interrupt now; `None` while work may go on.
    pub fn spent(&self, progress: &dyn Progress) -> Option<Stop> {
        if let Some(&stop) = self.spent.get() {
            return Some(stop);
        }
        let elapsed = self.started.elapsed();
        let stop = if progress.interrupted() {
            Some(Stop::Interrupted)
        } else if self.time_limit.is_some_and(|limit| elapsed >= limit) {
            Some(Stop::TimeLimit)
        } else if self.max_memory.is_some() && self.memory_due(elapsed) {
            let held = LINK_COPIES.saturating_mul(self.held.load(Ordering::Relaxed));
            let over = resident_memory_bytes()
                .zip(self.max_memory)
                .is_some_and(|(used, max)| used.saturating_add(held) >= max);
            over.then_some(Stop::MemoryLimit)
        } else {
            None
        };
        stop.map(|s| *self.spent.get_or_init(|| s))
    }

    /// What spent the budget, without checking again.
    pub fn stopped(&self) -> Option<Stop> {
        self.spent.get().copied()
    }

    /// Count `n` more items linked without refinement.
    pub fn add_coarse(&self, n: usize) {
        self.coarse.fetch_add(n, Ordering::Relaxed);
    }

    /// Items (surface pairs or triples, links, pairs of clusters) linked
    /// whole or left as they were, instead of refined, because the budget
    /// was spent.
    pub fn coarse_items(&self) -> usize {
        self.coarse.load(Ordering::Relaxed)
    }

    /// Count `bytes` more of links held until the solve's end.
    pub fn add_held(&self, bytes: u64) {
        self.held.fetch_add(bytes, Ordering::Relaxed);
    }

    /// Count `n` more items left out without links.
    pub fn add_left_out(&self, n: usize) {
        self.left_out.fetch_add(n, Ordering::Relaxed);
    }

    /// Items (surface triples) left out, without any links, because the
    /// budget was spent before they started ([`Progress::left_out`]).
    pub fn left_out_items(&self) -> usize {
        self.left_out.load(Ordering::Relaxed)
    }

    /// True at most once per [`MEMORY_CHECK_INTERVAL`] (reading the
    /// resident memory costs a system call).
    fn memory_due(&self, elapsed: Duration) -> bool {
        let now = elapsed.as_nanos() as u64;
        let due = self.next_memory_check.load(Ordering::Relaxed);
        now >= due
            && self
                .next_memory_check
                .compare_exchange(
                    due,
                    now + MEMORY_CHECK_INTERVAL.as_nanos() as u64,
                    Ordering::Relaxed,
                    Ordering::Relaxed,
                )
                .is_ok()
    }
}

/// A driver's progress with a [`Budget`]: it reports to `progress`, and
/// asks the work to stop once the budget is spent.
pub struct Budgeted<'a> {
    /// The driver's progress.
    pub progress: &'a dyn Progress,
    /// The limits.
    pub budget: &'a Budget,
}

impl Progress for Budgeted<'_> {
    fn start(&self, phase: &str, total: u64) {
        self.progress.start(phase, total)
    }
    fn advance(&self, steps: u64) {
        self.progress.advance(steps)
    }
    fn finish(&self) {
        self.progress.finish()
    }
    fn interrupted(&self) -> bool {
        self.budget.spent(self.progress).is_some()
    }
    fn cut_short(&self, items: u64) {
        self.budget.add_coarse(items as usize);
        self.progress.cut_short(items)
    }
    fn left_out(&self, items: u64) {
        self.budget.add_left_out(items as usize);
        self.progress.left_out(items)
    }
    fn warn(&self, message: &str) {
        self.progress.warn(message)
    }
    fn holding(&self, bytes: u64) {
        self.budget.add_held(bytes);
        self.progress.holding(bytes)
    }
}

/// The process's resident memory now (Linux; `None` elsewhere).
pub fn resident_memory_bytes() -> Option<u64> {
    proc_status_kib("VmRSS:").map(|kib| kib * 1024)
}

/// The machine's physical memory (Linux; `None` elsewhere).
pub fn physical_memory_bytes() -> Option<u64> {
    proc_kib("/proc/meminfo", "MemTotal:").map(|kib| kib * 1024)
}

/// A `kB` field of `/proc/self/status`.
pub(crate) fn proc_status_kib(field: &str) -> Option<u64> {
    proc_kib("/proc/self/status", field)
}

/// The `kB` field `field` of the `/proc` file `path`.
fn proc_kib(path: &str, field: &str) -> Option<u64> {
    let text = std::fs::read_to_string(path).ok()?;
    let line = text.lines().find(|l| l.starts_with(field))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Interrupt;
    impl Progress for Interrupt {
        fn interrupted(&self) -> bool {
            true
        }
    }

    #[test]
    fn a_budget_is_spent_by_its_first_limit_and_stays_spent() {
        let open = Budget::unlimited();
        assert_eq!(open.spent(&Silent), None);
        assert_eq!(open.spent(&Interrupt), Some(Stop::Interrupted));
        assert_eq!(open.spent(&Silent), Some(Stop::Interrupted));

        let timed = Budget::new(Some(Duration::ZERO), None);
        assert_eq!(timed.spent(&Silent), Some(Stop::TimeLimit));
        assert_eq!(timed.stopped(), Some(Stop::TimeLimit));

        let later = Budget::new(Some(Duration::from_secs(3600)), None);
        assert_eq!(later.spent(&Silent), None);
        assert_eq!(later.stopped(), None);
    }

    #[test]
    fn a_memory_limit_below_what_the_process_holds_is_spent() {
        if resident_memory_bytes().is_none() {
            return; // not Linux
        }
        let tight = Budget::new(None, Some(1));
        assert_eq!(tight.spent(&Silent), Some(Stop::MemoryLimit));
        let ample = Budget::new(None, Some(u64::MAX));
        assert_eq!(ample.spent(&Silent), None);
    }

    #[test]
    fn the_memory_limit_counts_the_copies_of_the_links_held() {
        let Some(now) = resident_memory_bytes() else {
            return; // not Linux
        };
        const GIB: u64 = 1 << 30;
        let budget = |held: u64| {
            let b = Budget::new(None, Some(now + GIB));
            b.add_held(held);
            b.spent(&Silent)
        };
        assert_eq!(budget(GIB / 8), None);
        // Half a GiB of links, held twice more by the end of the solve.
        assert_eq!(budget(GIB / 2 + GIB / 8), Some(Stop::MemoryLimit));
    }
}
