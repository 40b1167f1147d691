//! The live readout of `vistaf-host monitor`: one line per skin, named by its serial,
//! flags first, cut to the terminal's width (what matters most comes first, so an 80-column
//! terminal shows flags, force, depth and temperatures), redrawn in place on a terminal,
//! appended otherwise; with a map kind chosen, each skin's latest map under its line as a
//! small heat map ([`crate::heatmap`]).

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use vistaf_protocol::{Map, Summary};

use crate::maps::WholeMap;
use crate::multi::DeviceStats;

/// How long a skin may send nothing before the readout says it fell silent (a skin sends
/// a `Status` every second even when its summaries are paused).
pub const SILENT_AFTER: Duration = Duration::from_secs(2);

/// The live readout: one line per skin, redrawn at most 5 times a second.
#[derive(Debug)]
pub struct Monitor {
    last: Vec<Option<Summary>>,
    names: Vec<Option<String>>,
    heard: Vec<Instant>,
    rate: Vec<(Instant, u64, f64)>,
    maps: Vec<Option<WholeMap>>,
    map_range: Option<(f64, f64)>,
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
            names: vec![None; devices],
            heard: vec![Instant::now(); devices],
            rate: vec![(Instant::now(), 0, 0.0); devices],
            maps: vec![None; devices],
            map_range: None,
            drawn: None,
            live,
            tty: std::io::stdout().is_terminal(),
            lines_drawn: 0,
        }
    }

    /// Draws each skin's latest map under its line, coloured on the bar `range` (the map's
    /// unit: mm or °C). The maps must be asked for ([`crate::client::Client::keep_maps`]).
    pub fn with_maps(mut self, range: (f64, f64)) -> Monitor {
        self.map_range = Some(range);
        self
    }

    /// Takes a skin's newest coarse map.
    pub fn map(&mut self, device: usize, m: &Map) {
        if let Some(slot) = self.maps.get_mut(device) {
            *slot = WholeMap::from_coarse(m).or(slot.take());
        }
    }

    /// Names skin `device` (by the serial of its `Hello`).
    pub fn name(&mut self, device: usize, serial: &str) {
        if let Some(n) = self.names.get_mut(device) {
            *n = Some(serial.to_string());
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
        let width = self
            .tty
            .then(terminal_size::terminal_size)
            .flatten()
            .map(|(w, _)| usize::from(w.0));
        let names: Vec<&str> = stats
            .iter()
            .enumerate()
            .map(|(i, st)| {
                self.names
                    .get(i)
                    .and_then(|n| n.as_deref())
                    .unwrap_or(&st.name)
            })
            .collect();
        let name_width = names.iter().map(|n| n.chars().count()).max().unwrap_or(0);
        let mut drawn = 0;
        for (i, st) in stats.iter().enumerate() {
            let line = fit(
                &format!("{:<name_width$}", names[i]),
                &self.parts(i, st, now),
                width,
            );
            let mut lines = vec![line];
            lines.extend(self.heat_map(i, width));
            for line in lines {
                text.push_str(&line);
                text.push_str(if self.tty { "\x1b[K\n" } else { "\n" });
                drawn += 1;
            }
        }
        self.lines_drawn = drawn;
        let mut out = std::io::stdout().lock();
        let _ = out.write_all(text.as_bytes());
        let _ = out.flush();
    }

    /// Skin `i`'s heat map lines, indented by two columns (none without a map).
    fn heat_map(&self, i: usize, width: Option<usize>) -> Vec<String> {
        let (Some(range), Some(Some(map))) = (self.map_range, self.maps.get(i)) else {
            return Vec::new();
        };
        let cols = width.unwrap_or(80).saturating_sub(2);
        crate::heatmap::render(map, range, cols)
            .into_iter()
            .map(|l| format!("  {l}"))
            .collect()
    }

    /// Skin `i`'s readout, most important first: its state or flags, force, depth,
    /// temperatures, area, rate, losses.
    fn parts(&self, i: usize, st: &DeviceStats, now: Instant) -> Vec<String> {
        let silent = self
            .heard
            .get(i)
            .map_or(Duration::ZERO, |t| now.saturating_duration_since(*t));
        if silent >= SILENT_AFTER {
            return vec![format!("NO DATA for {} s", silent.as_secs())];
        }
        let Some(s) = self.last.get(i).copied().flatten() else {
            return vec!["waiting for summaries…".to_string()];
        };
        let si = s.si();
        let flags: Vec<&str> = s.flags.iter().map(|f| f.name()).collect();
        let mut parts = vec![
            if flags.is_empty() {
                "ok".to_string()
            } else {
                flags.join(",")
            },
            format!("F {:6.2} N", si.force_n),
            format!("d {:5.3} mm", si.peak_depth_mm),
        ];
        if !si.temp_mean_c.is_nan() {
            parts.push(format!("T {:5.2} °C", si.temp_mean_c));
        }
        if let Some(t) = si.contact_temp_c {
            parts.push(format!("contact {t:5.2} °C"));
        }
        let hz = self.rate.get(i).map_or(0.0, |r| r.2);
        parts.push(format!("A {:6.2} mm²", si.contact_area_mm2));
        parts.push(format!("{hz:4.0} Hz"));
        parts.push(format!(
            "lost {} dropped {}",
            st.seq.missing,
            st.drops.total()
        ));
        parts
    }
}

/// `name` and as many of `parts` as fit `width` columns (all of them without a width),
/// two spaces apart.
fn fit(name: &str, parts: &[String], width: Option<usize>) -> String {
    let mut line = name.to_string();
    for p in parts {
        let len = line.chars().count() + 2 + p.chars().count();
        if width.is_some_and(|w| len > w) {
            break;
        }
        line.push_str("  ");
        line.push_str(p);
    }
    line
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
        assert_eq!(m.parts(0, &st, t + Duration::from_millis(500))[0], "ok");
        assert_eq!(
            m.parts(0, &st, t + Duration::from_secs(3)),
            ["NO DATA for 3 s"]
        );
        m.heard(0);
        assert_eq!(m.parts(0, &st, Instant::now())[0], "ok");
    }

    #[test]
    fn a_line_fits_80_columns_with_flags_and_force_first() {
        use vistaf_protocol::{Flag, QualityFlags};
        let mut m = Monitor::new(1, false);
        m.heard(0);
        m.summary(
            0,
            &Summary {
                force_mn: 12_345,
                peak_depth_um: 1_497,
                temp_mean_centi_c: 2_542,
                contact_temp_centi_c: Some(4_007),
                flags: QualityFlags::NONE.with(Flag::PhaseSlope),
                ..Default::default()
            },
        );
        let parts = m.parts(0, &DeviceStats::default(), Instant::now());
        let line = fit("VSK-DEMO", &parts, Some(80));
        assert!(line.chars().count() <= 80, "{line}");
        assert!(
            line.starts_with("VSK-DEMO  phase_slope  F  12.35 N  d 1.497 mm  T 25.42 °C"),
            "{line}"
        );
        // Without a terminal, nothing is cut.
        assert!(fit("VSK-DEMO", &parts, None).ends_with("lost 0 dropped 0"));
    }
}
