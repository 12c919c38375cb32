//! Two independent pieces of work on a long record, on two threads.
//!
//! Each piece computes exactly what it computes alone (no sum is split
//! between the threads), so the results do not depend on the machine's
//! cores.

/// Records at least this long share their work between two threads.
pub(crate) const PARALLEL_SAMPLES: usize = 1 << 16;

/// `(a(), b())`, with `a` on a second thread when `samples` reaches
/// [`PARALLEL_SAMPLES`] and the machine has a second core.
pub(crate) fn join<A: Send, B>(
    samples: usize,
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B,
) -> (A, B) {
    // The core count is asked only for a long record (it reads the
    // process's CPU limits).
    let one_core = || std::thread::available_parallelism().map_or(true, |n| n.get() < 2);
    if samples < PARALLEL_SAMPLES || one_core() {
        return (a(), b());
    }
    std::thread::scope(|scope| {
        let a = scope.spawn(a);
        let b = b();
        let a = a.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        (a, b)
    })
}
