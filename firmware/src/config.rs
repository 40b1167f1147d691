//! The service's configuration file (TOML), `vistaf-skin run --config FILE`.
//!
//! Every key is optional; command-line flags override the file, and the file overrides the
//! built-in defaults, which fit the reference build (24-LED ring on SPI0, USB gadget serial
//! `/dev/ttyGS0`, the first camera). Unknown keys are refused, and every error names the
//! file and the key. `firmware/deploy/skin.toml` is the documented default.
//!
//! ```toml
//! source = "camera-serial:0123456789"   # camera:/dev/videoN, camera-name:NAME, set:DIR, sim:SCENE
//! link = "serial:/dev/ttyGS0@921600"    # /dev/ttyX, serial:PATH[@BAUD], file:PATH, - (stdout)
//! serial = "VSK-0042"                   # sent in Hello
//! calibration = "/var/lib/vistaf/calibration.json"
//! kit = "/var/lib/vistaf/kit"           # guided calibrations' frames [default: beside the calibration]
//! pipeline = "fixed"                    # or float
//! max_rate_hz = 0                       # 0: a summary per frame
//! camera_hold_s = 2.0                   # hold the camera's automatic light this long after it starts (0: never)
//!
//! [led]
//! ring = "spi0"                         # spi0 (WS2812 on SPI0 MOSI) or none
//! count = 24
//! brightness = 96
//! rgb = [255, 244, 229]
//! lit_mask = 0xAAAAAA
//!
//! [reference]
//! stable_dn = 1.5          # mean |Δ luminance| between frames below which the image is stable
//! max_wait_frames = 60     # take the reference after this many frames even if never stable
//! auto_after_s = 30.0      # re-reference after this long without contact, if drifted (0: never)
//! drift_rad = 0.3          # registration offset that counts as drift
//! drift_brightness = 0.08  # relative brightness change that counts as drift
//! ```

use std::path::{Path, PathBuf};

use serde::Deserialize;
use vistaf_protocol::link::LinkSpec;

/// What went wrong with a configuration file.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// Unreadable.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        cause: std::io::Error,
    },
    /// Not valid TOML, a wrong type, or an unknown key (the parser names it).
    #[error("{path}: {detail}")]
    Parse {
        /// The file.
        path: String,
        /// The parser's message, with the key and line.
        detail: String,
    },
    /// A value out of range.
    #[error("{path}: key `{key}`: {detail}")]
    Invalid {
        /// The file.
        path: String,
        /// The key.
        key: &'static str,
        /// Why.
        detail: String,
    },
}

/// `[led]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LedSection {
    /// `spi0` or `none`.
    pub ring: String,
    /// LEDs on the ring.
    pub count: usize,
    /// Global brightness, 0–255.
    pub brightness: u8,
    /// Colour of the lit LEDs.
    pub rgb: [u8; 3],
    /// Bit i lights LED i.
    pub lit_mask: u32,
}

impl Default for LedSection {
    fn default() -> Self {
        let d = vistaf_hardware::led::LedConfig::default();
        LedSection {
            ring: "spi0".into(),
            count: d.count,
            brightness: d.brightness,
            rgb: [d.rgb.r, d.rgb.g, d.rgb.b],
            lit_mask: d.lit_mask,
        }
    }
}

impl LedSection {
    /// As the LED driver's configuration.
    pub fn led_config(&self) -> vistaf_hardware::led::LedConfig {
        vistaf_hardware::led::LedConfig {
            count: self.count,
            rgb: smart_leds::RGB8 {
                r: self.rgb[0],
                g: self.rgb[1],
                b: self.rgb[2],
            },
            brightness: self.brightness,
            lit_mask: self.lit_mask,
        }
    }
}

/// `[reference]`: when the reference is taken and when it is renewed.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferencePolicy {
    /// Mean absolute luminance change between frames (8-bit steps) below which the image is
    /// stable enough to be the reference.
    pub stable_dn: f32,
    /// Frames after which the reference is taken even if the image never settled.
    pub max_wait_frames: u32,
    /// Seconds without contact after which a drifted reference is renewed; 0: never (the
    /// summaries carry `stale_reference` instead).
    pub auto_after_s: f32,
    /// Registration offset (rad) beyond which the reference has drifted.
    pub drift_rad: f32,
    /// Relative change of the mean brightness beyond which the reference has drifted.
    pub drift_brightness: f32,
}

impl Default for ReferencePolicy {
    fn default() -> Self {
        ReferencePolicy {
            stable_dn: 1.5,
            max_wait_frames: 60,
            auto_after_s: 30.0,
            drift_rad: 0.3,
            drift_brightness: 0.08,
        }
    }
}

/// The whole file.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Frame source spec.
    pub source: Option<String>,
    /// Link spec.
    pub link: Option<String>,
    /// Serial sent in `Hello`.
    pub serial: Option<String>,
    /// Calibration file.
    pub calibration: Option<PathBuf>,
    /// Where calibration kits captured on the device are kept.
    pub kit: Option<PathBuf>,
    /// Use a calibration made for another geometry.
    pub force_calibration: Option<bool>,
    /// `fixed` or `float`.
    pub pipeline: Option<String>,
    /// Stop after this many processed frames.
    pub frames: Option<u64>,
    /// Pace sets and simulated scenes at this rate.
    pub fps: Option<f32>,
    /// Summary rate limit, Hz (0: every frame).
    pub max_rate_hz: Option<u16>,
    /// Seconds a camera streams before its automatic exposure, gain, white balance and
    /// focus are held where they settled (0: left automatic).
    pub camera_hold_s: Option<f32>,
    /// The LED ring.
    #[serde(default)]
    pub led: LedSection,
    /// Reference management.
    #[serde(default)]
    pub reference: ReferencePolicy,
}

impl Config {
    /// How long a camera streams before its automatic light settings are held; `None`
    /// where the file says never (0).
    pub fn camera_hold(&self) -> Option<std::time::Duration> {
        match self.camera_hold_s {
            Some(s) if s > 0.0 => Some(std::time::Duration::from_secs_f32(s)),
            Some(_) => None,
            None => Some(vistaf_hardware::light_hold::HOLD_AFTER),
        }
    }

    /// Reads and checks a file.
    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|cause| ConfigError::Io {
            path: p.clone(),
            cause,
        })?;
        Config::parse(&text, &p)
    }

    /// Parses and checks TOML; `path` names it in errors.
    pub fn parse(text: &str, path: &str) -> Result<Config, ConfigError> {
        let c: Config = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: path.into(),
            detail: e.to_string().trim_end().to_string(),
        })?;
        c.check(path)?;
        Ok(c)
    }

    fn check(&self, path: &str) -> Result<(), ConfigError> {
        let bad = |key, detail: String| ConfigError::Invalid {
            path: path.into(),
            key,
            detail,
        };
        if let Some(s) = &self.source {
            s.parse::<crate::source_spec::SourceSpec>()
                .map_err(|e| bad("source", e.to_string()))?;
        }
        if let Some(l) = &self.link {
            l.parse::<LinkSpec>()
                .map_err(|e| bad("link", e.to_string()))?;
        }
        if let Some(p) = &self.pipeline {
            p.parse::<vistaf_pipeline::Implementation>()
                .map_err(|e| bad("pipeline", e))?;
        }
        if let Some(f) = self.fps {
            if !(f.is_finite() && f > 0.0) {
                return Err(bad("fps", format!("{f}: must be a positive rate")));
            }
        }
        if let Some(h) = self.camera_hold_s {
            if !(h.is_finite() && (0.0..=3600.0).contains(&h)) {
                return Err(bad(
                    "camera_hold_s",
                    format!("{h}: seconds from 0 (never) to 3600"),
                ));
            }
        }
        if !matches!(self.led.ring.as_str(), "spi0" | "none") {
            return Err(bad(
                "led.ring",
                format!("{:?}: expected \"spi0\" or \"none\"", self.led.ring),
            ));
        }
        if !(1..=32).contains(&self.led.count) {
            return Err(bad(
                "led.count",
                format!("{}: 1 to 32 LEDs", self.led.count),
            ));
        }
        let r = &self.reference;
        let positive = [
            ("reference.stable_dn", r.stable_dn),
            ("reference.drift_rad", r.drift_rad),
            ("reference.drift_brightness", r.drift_brightness),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(key, format!("{v}: must be positive")));
            }
        }
        if !(r.auto_after_s.is_finite() && r.auto_after_s >= 0.0) {
            return Err(bad(
                "reference.auto_after_s",
                format!("{}: seconds ≥ 0 (0: never)", r.auto_after_s),
            ));
        }
        if r.max_wait_frames == 0 {
            return Err(bad(
                "reference.max_wait_frames",
                "must be at least 1".into(),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documented_example_parses() {
        let doc = include_str!("config.rs")
            .lines()
            .filter_map(|l| l.strip_prefix("//! "))
            .skip_while(|l| !l.starts_with("```toml"))
            .skip(1)
            .take_while(|l| !l.starts_with("```"))
            .collect::<Vec<_>>()
            .join("\n");
        let c = Config::parse(&doc, "doc").unwrap();
        assert_eq!(c.link.as_deref(), Some("serial:/dev/ttyGS0@921600"));
        assert_eq!(c.led.count, 24);
        assert_eq!(c.reference.auto_after_s, 30.0);
    }

    #[test]
    fn the_shipped_default_parses() {
        let c = Config::parse(include_str!("../deploy/skin.toml"), "skin.toml").unwrap();
        assert_eq!(c.led.ring, "spi0");
        assert_eq!(
            c.camera_hold(),
            Some(vistaf_hardware::light_hold::HOLD_AFTER)
        );
        let never = Config::parse("camera_hold_s = 0", "skin.toml").unwrap();
        assert_eq!(never.camera_hold(), None);
    }

    #[test]
    fn errors_name_the_key() {
        let e = |t: &str| Config::parse(t, "skin.toml").unwrap_err().to_string();
        assert!(
            e("lnk = \"stdout\"").contains("lnk"),
            "{}",
            e("lnk = \"stdout\"")
        );
        assert!(e("[led]\ncount = 40").contains("led.count"));
        assert!(e("[led]\nbrightness = 300").contains("brightness"));
        assert!(e("link = \"serial:/dev/ttyGS0@fast\"").contains("`link`"));
        assert!(e("source = \"webcam\"").contains("`source`"));
        assert!(e("pipeline = \"gpu\"").contains("`pipeline`"));
        assert!(e("[reference]\ndrift_rad = -1").contains("reference.drift_rad"));
        assert!(e("fps = 0").contains("`fps`"));
        assert!(e("camera_hold_s = -1").contains("`camera_hold_s`"));
        assert!(e("source = [").contains("skin.toml"));
        assert!(Config::parse("", "empty").unwrap() == Config::default());
    }
}
