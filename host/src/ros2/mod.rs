//! A skin in ROS 2 terms: its topics, its frame, and each of its summaries and health
//! reports as standard messages (CDR-encoded), ready for an MCAP file or a DDS writer.
//!
//! | topic | type | when |
//! |---|---|---|
//! | `/vistaf/<serial>/wrench` | `geometry_msgs/WrenchStamped` | every summary |
//! | `/vistaf/<serial>/contact` | `geometry_msgs/PointStamped` | every summary with contact |
//! | `/vistaf/<serial>/contact_temperature` | `sensor_msgs/Temperature` | contact, measured |
//! | `/vistaf/<serial>/skin_temperature` | `sensor_msgs/Temperature` | measured |
//! | `/vistaf/<serial>/depth` | `sensor_msgs/Image` `32FC1`, m | every depth map asked for |
//! | `/vistaf/<serial>/temperature_map` | `sensor_msgs/Image` `32FC1`, °C | every temperature map |
//! | `/diagnostics` | `diagnostic_msgs/DiagnosticArray` | every `Status` (1 Hz) |
//!
//! The frame (`vistaf_<serial>` unless configured) is the camera's optical frame moved to
//! the skin's surface: origin at the image's top-left corner, x along the image's rows
//! (right), y down its columns, z away from the camera, out of the palm. A press pushes the
//! skin towards the camera, so the force on the skin is along −z.

pub mod msgs;

use vistaf_protocol::msg::MAP_NO_DATA;
use vistaf_protocol::{Map, MapKind, Status, Summary};

use msgs::{
    DiagnosticArray, DiagnosticStatus, Header, ImageF32, Level, PointStamped, RosMessage,
    Temperature, WrenchStamped,
};

/// Any of the message types a skin publishes; serializes as the message itself.
#[derive(Debug, Clone, PartialEq)]
pub enum AnyMsg {
    /// A force.
    Wrench(WrenchStamped),
    /// A contact centre.
    Point(PointStamped),
    /// A temperature.
    Temperature(Temperature),
    /// A map.
    Image(ImageF32),
    /// Health.
    Diagnostics(DiagnosticArray),
}

impl serde::Serialize for AnyMsg {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            AnyMsg::Wrench(m) => m.serialize(s),
            AnyMsg::Point(m) => m.serialize(s),
            AnyMsg::Temperature(m) => m.serialize(s),
            AnyMsg::Image(m) => m.serialize(s),
            AnyMsg::Diagnostics(m) => m.serialize(s),
        }
    }
}

/// A message ready to go out: topic, type, the message and its time.
#[derive(Debug, Clone)]
pub struct Outgoing {
    /// Topic name, ROS style (`/vistaf/<serial>/wrench`).
    pub topic: String,
    /// Type name, `package/msg/Type`.
    pub type_name: &'static str,
    /// The type's definition (`ros2msg`).
    pub definition: fn() -> String,
    /// The message.
    pub msg: AnyMsg,
    /// The header's stamp, ns since the Unix epoch (or on the device's clock for a replay
    /// without a clock map).
    pub stamp_ns: i64,
}

impl Outgoing {
    fn of<M: RosMessage + Into<AnyMsg>>(topic: String, stamp_ns: i64, m: M) -> Outgoing {
        Outgoing {
            topic,
            type_name: M::NAME,
            definition: M::definition,
            msg: m.into(),
            stamp_ns,
        }
    }

    /// The message in CDR with its encapsulation header, as MCAP stores it.
    pub fn cdr(&self) -> Vec<u8> {
        msgs::cdr(&self.msg)
    }
}

macro_rules! any_msg_from {
    ($($t:ident => $v:ident),*) => {
        $(impl From<$t> for AnyMsg {
            fn from(m: $t) -> AnyMsg {
                AnyMsg::$v(m)
            }
        })*
    };
}

any_msg_from!(WrenchStamped => Wrench, PointStamped => Point, Temperature => Temperature,
    ImageF32 => Image, DiagnosticArray => Diagnostics);

/// A name made fit for a ROS topic token: letters, digits and `_`, not starting with a
/// digit.
pub fn topic_token(name: &str) -> String {
    let mut t: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if t.is_empty() || t.starts_with(|c: char| c.is_ascii_digit()) {
        t.insert_str(0, "skin_");
    }
    t
}

/// One skin's names on the ROS side.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkinTopics {
    /// The skin's serial as it sent it.
    pub serial: String,
    /// The frame its messages are stamped in.
    pub frame_id: String,
    token: String,
}

impl SkinTopics {
    /// Names for the skin `serial`; the frame is `vistaf_<serial>` unless given.
    pub fn new(serial: &str, frame_id: Option<&str>) -> SkinTopics {
        let token = topic_token(serial);
        SkinTopics {
            serial: serial.to_string(),
            frame_id: frame_id.map_or_else(|| format!("vistaf_{token}"), str::to_string),
            token,
        }
    }

    /// The topic `/vistaf/<serial>/<leaf>`.
    pub fn topic(&self, leaf: &str) -> String {
        format!("/vistaf/{}/{leaf}", self.token)
    }

    fn header(&self, stamp_ns: i64) -> Header {
        Header {
            stamp_ns,
            frame_id: self.frame_id.clone(),
        }
    }

    /// A summary as messages, stamped `stamp_ns`.
    pub fn summary(&self, s: &Summary, stamp_ns: i64) -> Vec<Outgoing> {
        let si = s.si();
        let mut out = vec![Outgoing::of(
            self.topic("wrench"),
            stamp_ns,
            WrenchStamped {
                header: self.header(stamp_ns),
                force_n: [0.0, 0.0, -f64::from(si.force_n)],
                torque_nm: [0.0; 3],
            },
        )];
        if let Some((x, y)) = si.centroid_mm {
            out.push(Outgoing::of(
                self.topic("contact"),
                stamp_ns,
                PointStamped {
                    header: self.header(stamp_ns),
                    point_m: [f64::from(x) * 1e-3, f64::from(y) * 1e-3, 0.0],
                },
            ));
        }
        let temperature = |leaf: &str, c: f32| {
            Outgoing::of(
                self.topic(leaf),
                stamp_ns,
                Temperature {
                    header: self.header(stamp_ns),
                    temperature_c: f64::from(c),
                    variance_c2: 0.0,
                },
            )
        };
        if let Some(c) = si.contact_temp_c {
            out.push(temperature("contact_temperature", c));
        }
        if !si.temp_mean_c.is_nan() {
            out.push(temperature("skin_temperature", si.temp_mean_c));
        }
        out
    }

    /// A map as a `32FC1` image: depth in m (ROS depth images are in metres), temperature
    /// in °C; NaN where the device trusts no value. `None` for a map whose cells do not fill
    /// it, and for the camera (which comes whole only).
    pub fn map(&self, m: &Map, stamp_ns: i64) -> Option<Outgoing> {
        if !m.is_consistent() {
            return None;
        }
        let (leaf, scale) = match m.kind {
            MapKind::Depth => ("depth", 1e-6),
            MapKind::Temperature => ("temperature_map", 1e-2),
            MapKind::Camera => return None,
        };
        let pixels = m
            .cells
            .iter()
            .map(|&c| {
                if c == MAP_NO_DATA {
                    f32::NAN
                } else {
                    f32::from(c) * scale
                }
            })
            .collect();
        Some(Outgoing::of(
            self.topic(leaf),
            stamp_ns,
            ImageF32 {
                header: self.header(stamp_ns),
                width: u32::from(m.width),
                height: u32::from(m.height),
                pixels,
            },
        ))
    }

    /// A health report as `/diagnostics`, with what the host counted beside it.
    pub fn diagnostics(&self, st: &Status, host: &HostCounts, stamp_ns: i64) -> Outgoing {
        use vistaf_protocol::RunState;
        let (level, message) = match st.state {
            RunState::CameraLost => (Level::Error, "camera lost".to_string()),
            RunState::Referencing => (Level::Warn, "taking a reference".to_string()),
            RunState::Stopped => (Level::Ok, "stopped".to_string()),
            RunState::Streaming if !host.last_flags.is_empty() => {
                (Level::Warn, format!("flags: {}", host.last_flags))
            }
            RunState::Streaming => (Level::Ok, "streaming".to_string()),
        };
        let v = |k: &str, v: String| (k.to_string(), v);
        let values = vec![
            v("flags", host.last_flags.clone()),
            v("doubted", host.last_doubted.clone()),
            v(
                "calibration_id",
                vistaf_protocol::CalibrationId(host.calibration_id).to_string(),
            ),
            v(
                "reference_age_s",
                format!("{:.1}", f64::from(st.reference_age_ms) / 1e3),
            ),
            v("frames_captured", st.frames_captured.to_string()),
            v("frames_processed", st.frames_processed.to_string()),
            v("frames_dropped", st.frames_dropped.to_string()),
            v("bad_frames", st.bad_frames.to_string()),
            v(
                "latency_p50_p99_ms",
                format!(
                    "{:.1} / {:.1}",
                    f64::from(st.latency_p50_us) / 1e3,
                    f64::from(st.latency_p99_us) / 1e3
                ),
            ),
            v("summary_rate_hz", format!("{:.1}", host.summary_rate_hz)),
            v("summaries_missing", host.summaries_missing.to_string()),
            v("link_frames_dropped", host.link_frames_dropped.to_string()),
            v("clock_uncertainty_ms", host.clock_uncertainty_ms.clone()),
        ];
        Outgoing::of(
            "/diagnostics".to_string(),
            stamp_ns,
            DiagnosticArray {
                header: self.header(stamp_ns),
                status: vec![DiagnosticStatus {
                    level,
                    name: format!("vistaf/{}", self.token),
                    message,
                    hardware_id: self.serial.clone(),
                    values,
                }],
            },
        )
    }
}

/// What the host knows of a skin beside its `Status`, for `/diagnostics`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HostCounts {
    /// The latest summary's flags, `|`-separated.
    pub last_flags: String,
    /// The readings those flags doubt (`QualityFlags::doubted`), `|`-separated.
    pub last_doubted: String,
    /// The loaded calibration's id.
    pub calibration_id: u32,
    /// Summaries received per second since the previous `Status`.
    pub summary_rate_hz: f64,
    /// Summaries lost on the link (sequence gaps).
    pub summaries_missing: u64,
    /// Frames the host's decoder dropped.
    pub link_frames_dropped: u64,
    /// The clock map's uncertainty, ms (empty before the first exchange).
    pub clock_uncertainty_ms: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use vistaf_protocol::msg::TEMP_NOT_MEASURED;
    use vistaf_protocol::CentroidDeciMm;

    #[test]
    fn serials_become_topic_tokens() {
        assert_eq!(topic_token("VSK-000042"), "VSK_000042");
        assert_eq!(topic_token("42a"), "skin_42a");
        let t = SkinTopics::new("VSK-1", None);
        assert_eq!(t.topic("wrench"), "/vistaf/VSK_1/wrench");
        assert_eq!(t.frame_id, "vistaf_VSK_1");
    }

    #[test]
    fn a_summary_without_contact_or_temperature_is_a_wrench_alone() {
        let t = SkinTopics::new("A", Some("palm"));
        let s = Summary {
            temp_min_centi_c: TEMP_NOT_MEASURED,
            temp_mean_centi_c: TEMP_NOT_MEASURED,
            temp_max_centi_c: TEMP_NOT_MEASURED,
            ..Default::default()
        };
        let out = t.summary(&s, 1);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].topic, "/vistaf/A/wrench");
        let touched = Summary {
            force_mn: 2500,
            centroid: Some(CentroidDeciMm { x: 120, y: 80 }),
            contact_temp_centi_c: Some(3150),
            temp_mean_centi_c: 2500,
            ..Default::default()
        };
        let topics: Vec<String> = t
            .summary(&touched, 1)
            .into_iter()
            .map(|o| o.topic)
            .collect();
        assert_eq!(
            topics,
            [
                "/vistaf/A/wrench",
                "/vistaf/A/contact",
                "/vistaf/A/contact_temperature",
                "/vistaf/A/skin_temperature"
            ]
        );
    }
}
