//! A load cell's indicator read over a serial port: the force of a guided calibration's
//! press steps taken from the scale instead of typed.
//!
//! Indicators and load-cell amplifier sketches stream one reading per line, in many
//! dialects (`12.34 N`, `ST,GS,+0001.258kg`, `W: 1258 g`); [`parse_newton`] takes the
//! line's first number and the unit that follows it. A reading is the median of a few
//! consecutive lines read after what was waiting in the port is thrown away, so it is the
//! load now, not when the step was asked for.

use std::io::{BufRead, BufReader, Read};
use std::time::{Duration, Instant};

use vistaf_protocol::link::LinkSpec;

use crate::port::{drain, with_ports_named};

/// Standard gravity, m/s²: a mass reading in kg or g as a force.
const G_N_PER_KG: f64 = 9.806_65;
/// Lines one reading is the median of.
pub const LINES_PER_READING: usize = 5;
/// The baud of a scale given as a bare path (the common indicators' default).
pub const SCALE_DEFAULT_BAUD: u32 = 9600;

/// Where a press's force comes from.
pub trait Scale {
    /// The load now, N (compression read as negative by the cell is given as positive).
    fn read_n(&mut self) -> Result<f64, String>;
}

/// The force a line says, N: its first number and the unit right after it (`N`, `kN`,
/// `kg`, `g`, `lb`; a bare number is N). `None` when the line has no number or a unit
/// that is not a force or a mass.
pub fn parse_newton(line: &str) -> Option<f64> {
    let digit = line.find(|c: char| c.is_ascii_digit())?;
    // A point right before the digits belongs to the number (".5 kN"); a sign is dropped,
    // as a cell mounted the other way round reads compression as negative.
    let start = digit - usize::from(line[..digit].ends_with('.'));
    let rest = &line[start..];
    let len = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(rest.len());
    let value: f64 = rest[..len].parse().ok()?;
    let unit: String = rest[len..]
        .trim_start()
        .chars()
        .take_while(char::is_ascii_alphabetic)
        .collect();
    let factor = match unit.to_ascii_lowercase().as_str() {
        "" | "n" => 1.0,
        "kn" => 1000.0,
        "kg" => G_N_PER_KG,
        "g" => G_N_PER_KG / 1000.0,
        "lb" | "lbs" => 0.453_592_37 * G_N_PER_KG,
        _ => return None,
    };
    Some(value * factor)
}

/// A scale on a serial port.
pub struct SerialScale {
    name: String,
    port: serialport::TTYPort,
    timeout: Duration,
}

impl std::fmt::Debug for SerialScale {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialScale")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

impl SerialScale {
    /// Opens the scale `spec` names (`serial:PATH@BAUD`, or a bare path at
    /// [`SCALE_DEFAULT_BAUD`]); a reading not complete in `timeout` is an error.
    pub fn open(spec: &str, timeout: Duration) -> Result<SerialScale, String> {
        let Ok(LinkSpec::Serial { path, baud }) = spec.parse::<LinkSpec>() else {
            return Err(format!("scale {spec:?}: a serial port, serial:PATH@BAUD"));
        };
        let baud = if spec.contains('@') {
            baud
        } else {
            SCALE_DEFAULT_BAUD
        };
        let port = serialport::new(&path, baud)
            .timeout(Duration::from_millis(100))
            .open_native()
            .map_err(|e| format!("scale {path}: {}", with_ports_named(e.into())))?;
        Ok(SerialScale {
            name: path,
            port,
            timeout,
        })
    }
}

impl Scale for SerialScale {
    fn read_n(&mut self) -> Result<f64, String> {
        // What waited in the port is the load before the step was set.
        drain(&mut self.port).map_err(|e| format!("scale {}: {e}", self.name))?;
        let end = Instant::now() + self.timeout;
        let mut lines = BufReader::new(TimedReader {
            port: &mut self.port,
            end,
        });
        let mut readings = Vec::with_capacity(LINES_PER_READING);
        // The first line may be the tail of one cut by the clearing.
        let mut first = true;
        while readings.len() < LINES_PER_READING {
            let mut line = String::new();
            match lines.read_line(&mut line) {
                Err(e) if e.kind() != std::io::ErrorKind::InvalidData => {
                    return Err(format!("scale {}: {e}", self.name))
                }
                Ok(0) => {
                    return Err(format!(
                        "scale {}: {} readings in {:.1} s, {LINES_PER_READING} needed (is it \
                         streaming, at this baud?)",
                        self.name,
                        readings.len(),
                        self.timeout.as_secs_f64()
                    ))
                }
                _ => {}
            }
            if !std::mem::take(&mut first) {
                readings.extend(parse_newton(&line));
            }
        }
        readings.sort_by(f64::total_cmp);
        Ok(readings[readings.len() / 2])
    }
}

/// A port read until a deadline: its timeouts retried, the deadline an end of input.
struct TimedReader<'a> {
    port: &'a mut serialport::TTYPort,
    end: Instant,
}

impl Read for TimedReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while Instant::now() < self.end {
            match self.port.read(buf) {
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                other => return other,
            }
        }
        Ok(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dialects_of_indicators_read_as_newtons() {
        let close = |line: &str, n: f64| {
            let got = parse_newton(line).unwrap_or(f64::NAN);
            assert!((got - n).abs() < 1e-9, "{line:?}: {got} N, not {n}");
        };
        close("12.34 N\r\n", 12.34);
        close("12.34", 12.34);
        close("ST,GS,+0001.258kg", 1.258 * G_N_PER_KG);
        close("W: 1258 g", 1.258 * G_N_PER_KG);
        close("-6.5N", 6.5);
        close("load - 6.5 N", 6.5);
        close(".5 kN", 500.0);
        close("2 lb", 0.907_184_74 * G_N_PER_KG);
        assert_eq!(parse_newton("OL"), None, "overload: no number");
        assert_eq!(parse_newton("12 mV"), None, "not a force");
    }

    #[test]
    fn a_streaming_scale_is_read_as_the_median_of_fresh_lines() {
        use serialport::{SerialPort, TTYPort};
        use std::io::Write;
        let (mut indicator, host) = TTYPort::pair().unwrap();
        let path = host.name().unwrap();
        let writer = std::thread::spawn(move || {
            for i in 0..40 {
                // A spike now and then, which the median leaves out.
                let n = if i % 7 == 3 {
                    99.0
                } else {
                    6.0 + 0.01 * f64::from(i % 3)
                };
                let _ = write!(indicator, "ST,GS,{n:+09.3} N\r\n");
                std::thread::sleep(Duration::from_millis(20));
            }
            indicator
        });
        let mut scale = SerialScale::open(&path, Duration::from_secs(5)).unwrap();
        let n = scale.read_n().unwrap();
        assert!((6.0..=6.02).contains(&n), "{n} N");
        drop(scale);
        // The indicator still there, but silent.
        let indicator = writer.join().unwrap();
        let mut silent = SerialScale::open(&path, Duration::from_millis(300)).unwrap();
        let e = silent.read_n().unwrap_err();
        assert!(e.contains("readings in 0.3 s"), "{e}");
        drop(indicator);
    }
}
