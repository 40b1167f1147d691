//! The device's clock: one monotonic epoch per process, taken the first time anything asks.
//!
//! Frame timestamps, the summaries' capture times and the answers to the host's clock
//! requests all read this one time line, so the host can map it onto its own clock; a
//! camera opened again after a loss does not restart it.

use std::sync::OnceLock;
use std::time::{Duration, Instant};

static EPOCH: OnceLock<Instant> = OnceLock::new();

/// The process's epoch (the first call's instant). A service calls it before it times
/// anything: an instant from before the epoch reads as zero.
pub fn epoch() -> Instant {
    *EPOCH.get_or_init(Instant::now)
}

/// `at` on the device's clock: the time since the epoch (zero for an instant before it).
pub fn since_epoch(at: Instant) -> Duration {
    at.saturating_duration_since(epoch())
}

/// Now, on the device's clock.
pub fn now() -> Duration {
    since_epoch(Instant::now())
}

/// `at` on the device's clock, whole µs (the unit of the wire's times).
pub fn micros(at: Instant) -> u64 {
    u64::try_from(since_epoch(at).as_micros()).unwrap_or(u64::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_is_one_time_line() {
        let e = epoch();
        let later = Instant::now();
        assert_eq!(epoch(), e, "the epoch is taken once");
        assert!(since_epoch(later) >= since_epoch(e));
        assert_eq!(since_epoch(e), Duration::ZERO);
        assert_eq!(micros(e + Duration::from_micros(1500)), 1500);
    }
}
