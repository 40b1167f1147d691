//! Device time on the host's clock: when was a frame captured, in the robot's time?
//!
//! A summary carries its capture time on the device's clock (µs since the device's epoch).
//! The host asks the device for its clock now and then ([`vistaf_protocol::HostMsg::Clock`])
//! and notes when it sent the request and when the answer came back: four timestamps per
//! exchange, as NTP takes them. The time the request waited on the device (between two
//! frames) is measured by the device and drops out; what is left is the link's round trip,
//! whose asymmetry bounds the error of one exchange by half the round trip.
//!
//! As NTP does, the estimate keeps only the best exchanges: the exchanges are cut into
//! consecutive groups and the one with the shortest round trip of each group is kept (a
//! long round trip is a request that queued behind a frame or a busy USB bus). A line
//! through the kept exchanges gives the offset and the drift of the device's clock (a
//! crystal off by a few hundred ppm drifts by a millisecond every few seconds).
//!
//! Every mapped time carries its uncertainty: half the kept exchanges' round trip, plus the
//! line's scatter, plus the drift's uncertainty times the distance from the exchanges.

use std::collections::VecDeque;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Seconds since the Unix epoch, with µs resolution.
pub fn unix_s(t: SystemTime) -> f64 {
    t.duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// How many exchanges an estimate keeps (the oldest go first).
pub const WINDOW: usize = 256;
/// Exchanges per group, of which the shortest round trip is kept.
pub const GROUP: usize = 4;
/// The drift assumed unknown within this bound until two groups a while apart measure it
/// (ordinary crystals stay well within it).
pub const DRIFT_BOUND: f64 = 500e-6;
/// The device time the kept exchanges must span before their line's slope is trusted.
pub const MIN_SPAN_S: f64 = 2.0;

/// The host's time line: monotonic instants read as Unix seconds, anchored once, so a wall
/// clock stepped by NTP while streaming does not tear the estimates apart.
#[derive(Debug, Clone, Copy)]
pub struct HostTimeline {
    anchor: Instant,
    anchor_unix_s: f64,
}

impl HostTimeline {
    /// A time line anchored now.
    pub fn now() -> HostTimeline {
        HostTimeline {
            anchor: Instant::now(),
            anchor_unix_s: unix_s(SystemTime::now()),
        }
    }

    /// `at` in Unix seconds.
    pub fn unix_s(&self, at: Instant) -> f64 {
        if at >= self.anchor {
            self.anchor_unix_s + (at - self.anchor).as_secs_f64()
        } else {
            self.anchor_unix_s - (self.anchor - at).as_secs_f64()
        }
    }
}

/// One request and its answer: host times in seconds (any one time line), device times in
/// µs on the device's clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exchange {
    /// When the host sent the request, s.
    pub host_sent_s: f64,
    /// When the device decoded the request, µs.
    pub device_received_us: u64,
    /// When the device framed its answer, µs.
    pub device_sent_us: u64,
    /// When the host decoded the answer, s.
    pub host_received_s: f64,
}

impl Exchange {
    /// Time on the link, both ways, s: the round trip less the device's own wait.
    pub fn round_trip_s(&self) -> f64 {
        let device_s = self.device_sent_us.saturating_sub(self.device_received_us) as f64 * 1e-6;
        ((self.host_received_s - self.host_sent_s) - device_s).max(0.0)
    }

    fn host_mid_s(&self) -> f64 {
        0.5 * (self.host_sent_s + self.host_received_s)
    }

    fn device_mid_s(&self) -> f64 {
        0.5 * (self.device_received_us as f64 + self.device_sent_us as f64) * 1e-6
    }
}

/// A device time read on the host's clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MappedTime {
    /// Host time, s (Unix seconds on the [`HostTimeline`]).
    pub host_s: f64,
    /// Bound of the error, s.
    pub uncertainty_s: f64,
}

/// The device's clock mapped onto the host's: `host = host_at + rate · (device − device_at)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockMap {
    /// A device time the line passes through, s (the kept exchanges' centre).
    pub device_at_s: f64,
    /// The host time there, s.
    pub host_at_s: f64,
    /// Host seconds per device second (1 − the device's drift).
    pub rate: f64,
    /// Error bound at `device_at_s`, s.
    pub uncertainty_s: f64,
    /// Bound of `rate`'s error.
    pub rate_uncertainty: f64,
    /// The shortest round trip kept, s.
    pub best_round_trip_s: f64,
}

impl ClockMap {
    /// `device_us` on the host's clock.
    pub fn host_time(&self, device_us: u64) -> MappedTime {
        let dt = device_us as f64 * 1e-6 - self.device_at_s;
        MappedTime {
            host_s: self.host_at_s + self.rate * dt,
            uncertainty_s: self.uncertainty_s + self.rate_uncertainty * dt.abs(),
        }
    }

    /// The device's drift against the host, parts per million (positive: the device runs
    /// fast).
    pub fn drift_ppm(&self) -> f64 {
        (1.0 / self.rate - 1.0) * 1e6
    }
}

/// Keeps the latest exchanges and maps device time from them.
#[derive(Debug, Clone, Default)]
pub struct ClockEstimator {
    exchanges: VecDeque<Exchange>,
    map: Option<ClockMap>,
}

impl ClockEstimator {
    /// An estimator with no exchange yet.
    pub fn new() -> ClockEstimator {
        ClockEstimator::default()
    }

    /// Adds an exchange and refits. An exchange whose own times run backwards (a broken
    /// answer) is dropped; one whose device times run back past the last exchange's (the
    /// device restarted) starts the estimate over.
    pub fn add(&mut self, e: Exchange) {
        if e.device_sent_us < e.device_received_us || e.host_received_s < e.host_sent_s {
            return;
        }
        let restarted = self
            .exchanges
            .back()
            .is_some_and(|last| e.device_received_us < last.device_sent_us);
        if restarted {
            self.exchanges.clear();
        }
        if self.exchanges.len() == WINDOW {
            self.exchanges.pop_front();
        }
        self.exchanges.push_back(e);
        self.map = fit(&self.exchanges);
    }

    /// The current map, once one exchange has been made.
    pub fn map(&self) -> Option<&ClockMap> {
        self.map.as_ref()
    }

    /// Exchanges held.
    pub fn len(&self) -> usize {
        self.exchanges.len()
    }

    /// Whether no exchange has been made.
    pub fn is_empty(&self) -> bool {
        self.exchanges.is_empty()
    }
}

/// The exchange of shortest round trip in each consecutive group of [`GROUP`] (the last
/// group may be shorter).
fn best_of_groups(exchanges: &VecDeque<Exchange>) -> Vec<Exchange> {
    let all: Vec<Exchange> = exchanges.iter().copied().collect();
    all.chunks(GROUP)
        .filter_map(|g| {
            g.iter()
                .copied()
                .min_by(|a, b| a.round_trip_s().total_cmp(&b.round_trip_s()))
        })
        .collect()
}

/// The line through the best exchanges; a single best exchange (or a short span) gives
/// the offset alone, the drift bounded by [`DRIFT_BOUND`].
fn fit(exchanges: &VecDeque<Exchange>) -> Option<ClockMap> {
    let kept = best_of_groups(exchanges);
    let best = kept
        .iter()
        .min_by(|a, b| a.round_trip_s().total_cmp(&b.round_trip_s()))?;
    let best_round_trip_s = best.round_trip_s();
    let n = kept.len() as f64;
    let d_mean = kept.iter().map(Exchange::device_mid_s).sum::<f64>() / n;
    let h_mean = kept.iter().map(Exchange::host_mid_s).sum::<f64>() / n;
    let span = kept.last()?.device_mid_s() - kept.first()?.device_mid_s();
    if kept.len() < 3 || span < MIN_SPAN_S {
        // Offset from the best exchange alone; drift unknown within its bound.
        return Some(ClockMap {
            device_at_s: best.device_mid_s(),
            host_at_s: best.host_mid_s(),
            rate: 1.0,
            uncertainty_s: 0.5 * best_round_trip_s,
            rate_uncertainty: DRIFT_BOUND,
            best_round_trip_s,
        });
    }
    // Half a round trip bounds each kept exchange's error; their mean is the bound of
    // the line's offset.
    let half_trip = kept.iter().map(|e| 0.5 * e.round_trip_s()).sum::<f64>() / n;
    let sxx: f64 = kept
        .iter()
        .map(|e| (e.device_mid_s() - d_mean).powi(2))
        .sum();
    let sxy: f64 = kept
        .iter()
        .map(|e| (e.device_mid_s() - d_mean) * (e.host_mid_s() - h_mean))
        .sum();
    let rate = (sxy / sxx).clamp(1.0 - DRIFT_BOUND, 1.0 + DRIFT_BOUND);
    let residual = |e: &Exchange| e.host_mid_s() - (h_mean + rate * (e.device_mid_s() - d_mean));
    let worst_residual = kept.iter().map(|e| residual(e).abs()).fold(0.0, f64::max);
    // A slope error that would move the line's ends by the exchanges' own error bound.
    let rate_uncertainty = ((half_trip + worst_residual) / (0.5 * span)).min(DRIFT_BOUND);
    Some(ClockMap {
        device_at_s: d_mean,
        host_at_s: h_mean,
        rate,
        uncertainty_s: half_trip + worst_residual,
        rate_uncertainty,
        best_round_trip_s,
    })
}

/// When the next clock request goes out: quickly until a few exchanges are in, then every
/// `period`.
pub fn next_request(exchanges: usize, period: Duration) -> Duration {
    if exchanges < 2 * GROUP {
        Duration::from_millis(20).min(period)
    } else {
        period
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift64: deterministic jitter without a dependency.
    struct Rng(u64);

    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }

        /// An exponential delay of mean `mean_s`: mostly short, now and then long.
        fn exp(&mut self, mean_s: f64) -> f64 {
            -mean_s * (1.0 - self.uniform()).ln()
        }
    }

    /// A device whose clock starts `offset_s` behind the host's time line and runs
    /// `drift` fast, behind a link whose each leg takes 0.2 ms plus exponential jitter of
    /// mean `jitter_s`, and which answers after waiting up to 20 ms for a frame to end.
    struct Device {
        offset_s: f64,
        drift: f64,
        jitter_s: f64,
        rng: Rng,
    }

    impl Device {
        fn device_s(&self, host_s: f64) -> f64 {
            (host_s - self.offset_s) * (1.0 + self.drift)
        }

        fn host_s(&self, device_s: f64) -> f64 {
            device_s / (1.0 + self.drift) + self.offset_s
        }

        fn exchange(&mut self, host_sent_s: f64) -> Exchange {
            let arrives = host_sent_s + 2e-4 + self.rng.exp(self.jitter_s);
            let answered = arrives + 0.02 * self.rng.uniform();
            let back = answered + 2e-4 + self.rng.exp(self.jitter_s);
            let us = |s: f64| (s * 1e6).round() as u64;
            Exchange {
                host_sent_s,
                device_received_us: us(self.device_s(arrives)),
                device_sent_us: us(self.device_s(answered)),
                host_received_s: back,
            }
        }
    }

    fn device(seed: u64) -> Device {
        Device {
            offset_s: 1_700_000_000.0,
            drift: 200e-6,
            jitter_s: 1e-3,
            rng: Rng(seed),
        }
    }

    /// The mapping's error on summaries captured over `span_s` after the exchanges began,
    /// with exchanges every `period_s`: the worst error after the first ten seconds, and
    /// whether every error, from the first exchange on, was within its stated uncertainty.
    fn run(seed: u64, period_s: f64, span_s: f64) -> (f64, bool, ClockMap) {
        let mut dev = device(seed);
        let mut est = ClockEstimator::new();
        let start = dev.offset_s + 5.0;
        let mut worst = 0.0f64;
        let mut covered = true;
        let mut t = start;
        while t < start + span_s {
            let e = dev.exchange(t);
            est.add(e);
            // A summary captured now, read on the host's clock.
            let captured_host_s = e.host_received_s + 0.003;
            let device_us = (dev.device_s(captured_host_s) * 1e6).round() as u64;
            let got = est.map().unwrap().host_time(device_us);
            let err = (got.host_s - dev.host_s(device_us as f64 * 1e-6)).abs();
            if t > start + 10.0 {
                worst = worst.max(err);
            }
            covered &= err <= got.uncertainty_s + 1e-6;
            t += period_s;
        }
        (worst, covered, *est.map().unwrap())
    }

    #[test]
    fn a_device_200_ppm_fast_behind_a_jittery_link_maps_within_a_millisecond() {
        for seed in [1, 2, 3, 0xdead_beef] {
            let (worst, covered, map) = run(seed, 0.25, 120.0);
            assert!(worst < 1e-3, "seed {seed}: worst error {worst} s");
            assert!(covered, "seed {seed}: an error beyond its uncertainty");
            assert!(
                (map.drift_ppm() - 200.0).abs() < 20.0,
                "seed {seed}: drift {} ppm",
                map.drift_ppm()
            );
            assert!(map.uncertainty_s < 2e-3, "{map:?}");
        }
    }

    #[test]
    fn without_the_drift_the_error_would_grow_past_the_uncertainty() {
        // The same run with the slope forced to 1: 200 ppm over a minute is 12 ms, so a
        // plain offset would be wrong by far more than the fitted line.
        let (_, _, map) = run(7, 0.25, 60.0);
        let flat = ClockMap { rate: 1.0, ..map };
        let late_us = ((map.device_at_s + 60.0) * 1e6) as u64;
        let gap = (flat.host_time(late_us).host_s - map.host_time(late_us).host_s).abs();
        assert!(gap > 5e-3, "the drift moves a minute-old offset by {gap} s");
    }

    #[test]
    fn one_exchange_gives_an_offset_with_an_honest_bound() {
        let mut dev = device(11);
        let mut est = ClockEstimator::new();
        let e = dev.exchange(dev.offset_s + 1.0);
        est.add(e);
        let map = *est.map().unwrap();
        assert_eq!(map.rate, 1.0);
        for later_s in [0.0, 1.0, 10.0] {
            let device_us = ((e.device_sent_us as f64 * 1e-6 + later_s) * 1e6) as u64;
            let got = map.host_time(device_us);
            let err = (got.host_s - dev.host_s(device_us as f64 * 1e-6)).abs();
            assert!(err <= got.uncertainty_s, "{later_s} s on: {err} > {got:?}");
        }
    }

    #[test]
    fn a_device_that_restarts_starts_the_estimate_over() {
        let mut dev = device(5);
        let mut est = ClockEstimator::new();
        for i in 0..20 {
            est.add(dev.exchange(dev.offset_s + 1.0 + 0.25 * f64::from(i)));
        }
        // Restarted: its epoch is now 100 s later on the host.
        dev.offset_s += 100.0;
        let e = dev.exchange(dev.offset_s + 1.0);
        est.add(e);
        assert_eq!(est.len(), 1);
        let got = est.map().unwrap().host_time(e.device_sent_us);
        assert!((got.host_s - dev.host_s(e.device_sent_us as f64 * 1e-6)).abs() < 0.02);
    }

    #[test]
    fn the_host_timeline_reads_instants_as_unix_seconds() {
        let line = HostTimeline::now();
        let a = Instant::now();
        let b = a + Duration::from_millis(1500);
        assert!((line.unix_s(b) - line.unix_s(a) - 1.5).abs() < 1e-9);
        assert!((line.unix_s(a) - unix_s(SystemTime::now())).abs() < 1.0);
    }
}
