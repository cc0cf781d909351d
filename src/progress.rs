//! What a long library call is doing now, for a command's progress line: the stage (building
//! the reference's BVH, tracing its rows) and how much of it is done. Process-wide and for
//! display only: no result reads it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

static STAGE: Mutex<Option<&'static str>> = Mutex::new(None);
static DONE: AtomicU64 = AtomicU64::new(0);
static TOTAL: AtomicU64 = AtomicU64::new(0);

/// A stage at work; it ends when this is dropped.
#[must_use = "the stage ends when the guard is dropped"]
pub struct Stage(());

/// Begins stage `what` of `total` steps (0: not counted).
pub fn stage(what: &'static str, total: u64) -> Stage {
    DONE.store(0, Ordering::Relaxed);
    TOTAL.store(total, Ordering::Relaxed);
    *STAGE.lock().unwrap_or_else(|e| e.into_inner()) = Some(what);
    Stage(())
}

/// `n` more steps of the stage done.
pub fn advance(n: u64) {
    DONE.fetch_add(n, Ordering::Relaxed);
}

impl Drop for Stage {
    fn drop(&mut self) {
        *STAGE.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }
}

/// The stage at work now, as text ("tracing the reference: 120/270 rows"), if any.
pub fn current() -> Option<String> {
    let what = (*STAGE.lock().unwrap_or_else(|e| e.into_inner()))?;
    let (done, total) = (DONE.load(Ordering::Relaxed), TOTAL.load(Ordering::Relaxed));
    Some(if total > 0 {
        format!("{what}: {}/{total}", done.min(total))
    } else {
        what.to_string()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stage_counts_and_ends() {
        {
            let _s = stage("tracing", 10);
            advance(3);
            assert_eq!(current().as_deref(), Some("tracing: 3/10"));
        }
        assert_eq!(current(), None);
    }
}
