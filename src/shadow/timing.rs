//! Wall time of a technique's passes: one helper, so that every technique reports its passes
//! the same way (`timings`, `penumbra bench technique`, the sweep's per-pass columns).
//!
//! ```
//! use penumbra::shadow::timing::Passes;
//! let mut passes = Passes::start();
//! // ... the light pass ...
//! passes.end("light pass");
//! // ... the lookup pass ...
//! passes.end("lookup pass");
//! let times = passes.finish();
//! assert_eq!(times.iter().map(|t| t.0).collect::<Vec<_>>(), ["light pass", "lookup pass"]);
//! ```

use std::time::Instant;

/// Times passes run one after another: each [`Passes::end`] closes the pass that began at the
/// previous one (or at [`Passes::start`]).
#[derive(Clone, Debug)]
pub struct Passes {
    at: Instant,
    times: Vec<(&'static str, f64)>,
}

impl Passes {
    /// Starts timing the first pass.
    pub fn start() -> Passes {
        Passes {
            at: Instant::now(),
            times: Vec::new(),
        }
    }

    /// Ends pass `name` (its time: since the last end, or the start) and starts the next. A
    /// name ended again adds to its time (a pass run once per sample, per layer...).
    pub fn end(&mut self, name: &'static str) {
        let now = Instant::now();
        let ms = (now - self.at).as_secs_f64() * 1e3;
        self.at = now;
        self.add(name, ms);
    }

    /// Adds `ms` milliseconds to pass `name` (passes timed elsewhere, such as those of a
    /// sub-pass that reports its own), keeping the order in which names first came.
    pub fn add(&mut self, name: &'static str, ms: f64) {
        match self.times.iter_mut().find(|(n, _)| *n == name) {
            Some(e) => e.1 += ms,
            None => self.times.push((name, ms)),
        }
    }

    /// [`Passes::end`] of pass `name` whose sub-passes, reported with [`Passes::add`], took
    /// `timed` of its milliseconds: the pass keeps the rest.
    pub fn end_after(&mut self, name: &'static str, timed: f64) {
        let now = Instant::now();
        let ms = (now - self.at).as_secs_f64() * 1e3;
        self.at = now;
        self.add(name, (ms - timed).max(0.0));
    }

    /// Leaves the time since the last end out of every pass (work that is not a pass of the
    /// technique).
    pub fn skip(&mut self) {
        self.at = Instant::now();
    }

    /// The passes' times in milliseconds, in the order they first ended.
    pub fn finish(self) -> Vec<(&'static str, f64)> {
        self.times
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_keep_their_order_and_add_up() {
        let mut p = Passes::start();
        p.end("a");
        p.end("b");
        p.add("a", 2.0);
        p.end("c");
        let t = p.finish();
        assert_eq!(t.iter().map(|t| t.0).collect::<Vec<_>>(), ["a", "b", "c"]);
        assert!(t[0].1 >= 2.0 && t.iter().all(|t| t.1 >= 0.0));
    }
}
