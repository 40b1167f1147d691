//! The live readout of `vistaf-host monitor`: one line per skin, redrawn in place on a
//! terminal, appended otherwise.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use vistaf_protocol::Summary;

use crate::multi::DeviceStats;

/// How long a skin may send nothing before the readout says it fell silent (a skin sends
/// a `Status` every second even when its summaries are paused).
pub const SILENT_AFTER: Duration = Duration::from_secs(2);

/// The live readout: one line per skin, redrawn at most 5 times a second.
#[derive(Debug)]
pub struct Monitor {
    last: Vec<Option<Summary>>,
    heard: Vec<Instant>,
    rate: Vec<(Instant, u64, f64)>,
    drawn: Option<Instant>,
    live: bool,
    tty: bool,
    lines_drawn: usize,
}

impl Monitor {
    /// A readout of `devices` skins on standard output; `live` off draws nothing.
    pub fn new(devices: usize, live: bool) -> Monitor {
        Monitor {
            last: vec![None; devices],
            heard: vec![Instant::now(); devices],
            rate: vec![(Instant::now(), 0, 0.0); devices],
            drawn: None,
            live,
            tty: std::io::stdout().is_terminal(),
            lines_drawn: 0,
        }
    }

    /// Notes that a skin sent something (any message).
    pub fn heard(&mut self, device: usize) {
        if let Some(t) = self.heard.get_mut(device) {
            *t = Instant::now();
        }
    }

    /// Takes a skin's newest summary.
    pub fn summary(&mut self, device: usize, s: &Summary) {
        if let Some(slot) = self.last.get_mut(device) {
            *slot = Some(*s);
        }
        if let Some((since, n, hz)) = self.rate.get_mut(device) {
            *n += 1;
            let dt = since.elapsed().as_secs_f64();
            if dt >= 1.0 {
                *hz = *n as f64 / dt;
                *since = Instant::now();
                *n = 0;
            }
        }
    }

    /// Redraws (at most every 200 ms unless `force`).
    pub fn draw(&mut self, stats: &[DeviceStats], force: bool) {
        if !self.live {
            return;
        }
        let now = Instant::now();
        if !force
            && self
                .drawn
                .is_some_and(|t| now.duration_since(t) < Duration::from_millis(200))
        {
            return;
        }
        self.drawn = Some(now);
        let mut text = String::new();
        if self.tty && self.lines_drawn > 0 {
            text.push_str(&format!("\x1b[{}A", self.lines_drawn));
        }
        for (i, st) in stats.iter().enumerate() {
            let body = self.line(i, st, now);
            text.push_str(&format!("{}: {body}", st.name));
            text.push_str(if self.tty { "\x1b[K\n" } else { "\n" });
        }
        self.lines_drawn = stats.len();
        let mut out = std::io::stdout().lock();
        let _ = out.write_all(text.as_bytes());
        let _ = out.flush();
    }

    /// Skin `i`'s line after its name: its newest summary, or that it fell silent.
    fn line(&self, i: usize, st: &DeviceStats, now: Instant) -> String {
        let hz = self.rate.get(i).map_or(0.0, |r| r.2);
        let silent = self
            .heard
            .get(i)
            .map_or(Duration::ZERO, |t| now.saturating_duration_since(*t));
        if silent >= SILENT_AFTER {
            return format!("no data for {} s", silent.as_secs());
        }
        let Some(s) = self.last.get(i).copied().flatten() else {
            return "waiting for summaries…".to_string();
        };
        let si = s.si();
        let flags: Vec<&str> = s.flags.iter().map(|f| f.name()).collect();
        format!(
            "#{:<7} F {:7.3} N  d {:6.3} mm  A {:7.2} mm²  T {}{}  \
             {:5.1} Hz  lost {}  dropped {}  {}",
            s.seq,
            si.force_n,
            si.peak_depth_mm,
            si.contact_area_mm2,
            if si.temp_mean_c.is_nan() {
                "— (not measured)".to_string()
            } else {
                format!(
                    "{:5.2} °C [{:5.2}…{:5.2}]",
                    si.temp_mean_c, si.temp_min_c, si.temp_max_c
                )
            },
            si.contact_temp_c
                .map(|t| format!(" contact {t:5.2} °C"))
                .unwrap_or_default(),
            hz,
            st.seq.missing,
            st.drops.total(),
            if flags.is_empty() {
                "ok".to_string()
            } else {
                flags.join(",")
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_skin_that_falls_silent_is_said_to_be() {
        let mut m = Monitor::new(1, false);
        let st = DeviceStats::default();
        m.heard(0);
        m.summary(0, &Summary::default());
        let t = m.heard[0];
        assert!(m
            .line(0, &st, t + Duration::from_millis(500))
            .starts_with("#0"));
        assert_eq!(
            m.line(0, &st, t + Duration::from_secs(3)),
            "no data for 3 s"
        );
        m.heard(0);
        assert!(m.line(0, &st, Instant::now()).starts_with("#0"));
    }
}
