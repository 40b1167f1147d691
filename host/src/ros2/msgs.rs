//! The standard ROS 2 message types a skin publishes, each with its `.msg` definition (as
//! MCAP's `ros2msg` schema encoding and ROS 2 bags carry it) and its serde form, whose CDR
//! (by `cdr-encoding`, the serializer RustDDS uses) is the message's bytes in an MCAP file
//! and on DDS alike, so a stock ROS 2 node or Foxglove reads them without a package of ours.
//!
//! The serde forms follow the `.msg` fields in order: CDR has no field names, only the
//! order and the types (a fixed array is its elements, a sequence or string has a length).

use byteorder::LittleEndian;
use serde::ser::{Serialize, Serializer};

/// The CDR encapsulation header: plain CDR, little-endian.
const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

const SEPARATOR: &str =
    "================================================================================\n";

const HEADER_DEF: &str = "MSG: std_msgs/Header\n\
builtin_interfaces/Time stamp\n\
string frame_id\n";

const TIME_DEF: &str = "MSG: builtin_interfaces/Time\n\
int32 sec\n\
uint32 nanosec\n";

const VECTOR3_DEF: &str = "MSG: geometry_msgs/Vector3\n\
float64 x\n\
float64 y\n\
float64 z\n";

/// A ROS 2 message type: its full name and its definition with its dependencies; its serde
/// form is its bytes ([`cdr`]).
pub trait RosMessage: Serialize {
    /// The type's name, `package/msg/Type`.
    const NAME: &'static str;
    /// The definition: the type's own fields, then each type it uses after a separator
    /// line and `MSG: package/Type`.
    fn definition() -> String;
}

/// `value` in little-endian CDR after the encapsulation header. The message types here have
/// no map or other form CDR cannot carry, so serializing cannot fail; were it to, the
/// message is the header alone, which no reader takes for data.
pub fn cdr<T: Serialize>(value: &T) -> Vec<u8> {
    let mut out = CDR_LE.to_vec();
    if let Ok(body) = cdr_encoding::to_vec::<_, LittleEndian>(value) {
        out.extend(body);
    }
    out
}

fn definition(own: &str, deps: &[&str]) -> String {
    let mut text = own.to_string();
    for d in deps {
        text.push_str(SEPARATOR);
        text.push_str(d);
    }
    text
}

/// `std_msgs/Header`: when and in which frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// Time, ns since the Unix epoch.
    pub stamp_ns: i64,
    /// The coordinate frame.
    pub frame_id: String,
}

impl Serialize for Header {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (split_ns(self.stamp_ns), &self.frame_id).serialize(s)
    }
}

/// Nanoseconds as `builtin_interfaces/Time`: whole seconds (clamped to the type's range)
/// and nanoseconds.
pub fn split_ns(t_ns: i64) -> (i32, u32) {
    let sec = t_ns.div_euclid(1_000_000_000);
    let nanosec = t_ns.rem_euclid(1_000_000_000);
    let sec = i32::try_from(sec).unwrap_or(if sec < 0 { i32::MIN } else { i32::MAX });
    (sec, u32::try_from(nanosec).unwrap_or(0))
}

/// `geometry_msgs/WrenchStamped`: force (N) and torque (N·m) in the header's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct WrenchStamped {
    /// When and where.
    pub header: Header,
    /// Force, N.
    pub force_n: [f64; 3],
    /// Torque, N·m.
    pub torque_nm: [f64; 3],
}

impl RosMessage for WrenchStamped {
    const NAME: &'static str = "geometry_msgs/msg/WrenchStamped";

    fn definition() -> String {
        definition(
            "std_msgs/Header header\nWrench wrench\n",
            &[
                HEADER_DEF,
                TIME_DEF,
                "MSG: geometry_msgs/Wrench\nVector3 force\nVector3 torque\n",
                VECTOR3_DEF,
            ],
        )
    }
}

/// `geometry_msgs/PointStamped`: a point, m, in the header's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PointStamped {
    /// When and where.
    pub header: Header,
    /// The point, m.
    pub point_m: [f64; 3],
}

impl RosMessage for PointStamped {
    const NAME: &'static str = "geometry_msgs/msg/PointStamped";

    fn definition() -> String {
        definition(
            "std_msgs/Header header\nPoint point\n",
            &[
                HEADER_DEF,
                TIME_DEF,
                "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n",
            ],
        )
    }
}

/// `sensor_msgs/Temperature`: °C, with its variance (0: unknown).
#[derive(Debug, Clone, PartialEq)]
pub struct Temperature {
    /// When and where.
    pub header: Header,
    /// Temperature, °C.
    pub temperature_c: f64,
    /// Variance, °C² (0 is "unknown" in ROS).
    pub variance_c2: f64,
}

impl RosMessage for Temperature {
    const NAME: &'static str = "sensor_msgs/msg/Temperature";

    fn definition() -> String {
        definition(
            "std_msgs/Header header\nfloat64 temperature\nfloat64 variance\n",
            &[HEADER_DEF, TIME_DEF],
        )
    }
}

/// `sensor_msgs/Image` of encoding `32FC1`: one `f32` per pixel, row-major, NaN where
/// there is no value.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageF32 {
    /// When and where.
    pub header: Header,
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width × height` values.
    pub pixels: Vec<f32>,
}

impl RosMessage for ImageF32 {
    const NAME: &'static str = "sensor_msgs/msg/Image";

    fn definition() -> String {
        definition(
            "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n\
             uint8 is_bigendian\nuint32 step\nuint8[] data\n",
            &[HEADER_DEF, TIME_DEF],
        )
    }
}

/// Level of a [`DiagnosticStatus`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// Everything fine.
    Ok = 0,
    /// Working, with something to look at.
    Warn = 1,
    /// Not working.
    Error = 2,
    /// Nothing heard.
    Stale = 3,
}

/// One `diagnostic_msgs/DiagnosticStatus`.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnosticStatus {
    /// How it is.
    pub level: Level,
    /// What it is about.
    pub name: String,
    /// One line for a person.
    pub message: String,
    /// The hardware's identity (the skin's serial).
    pub hardware_id: String,
    /// Named values.
    pub values: Vec<(String, String)>,
}

/// `diagnostic_msgs/DiagnosticArray`, published on `/diagnostics`.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnosticArray {
    /// When.
    pub header: Header,
    /// One per component.
    pub status: Vec<DiagnosticStatus>,
}

impl RosMessage for DiagnosticArray {
    const NAME: &'static str = "diagnostic_msgs/msg/DiagnosticArray";

    fn definition() -> String {
        definition(
            "std_msgs/Header header\nDiagnosticStatus[] status\n",
            &[
                HEADER_DEF,
                TIME_DEF,
                "MSG: diagnostic_msgs/DiagnosticStatus\nbyte OK=0\nbyte WARN=1\nbyte ERROR=2\n\
                 byte STALE=3\nbyte level\nstring name\nstring message\nstring hardware_id\n\
                 KeyValue[] values\n",
                "MSG: diagnostic_msgs/KeyValue\nstring key\nstring value\n",
            ],
        )
    }
}

impl Serialize for WrenchStamped {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (&self.header, self.force_n, self.torque_nm).serialize(s)
    }
}

impl Serialize for PointStamped {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (&self.header, self.point_m).serialize(s)
    }
}

impl Serialize for Temperature {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (&self.header, self.temperature_c, self.variance_c2).serialize(s)
    }
}

impl Serialize for ImageF32 {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let data: Vec<u8> = self.pixels.iter().flat_map(|v| v.to_le_bytes()).collect();
        let step = self.width.saturating_mul(4);
        let is_bigendian = 0u8;
        (
            &self.header,
            self.height,
            self.width,
            "32FC1",
            is_bigendian,
            step,
            data,
        )
            .serialize(s)
    }
}

impl Serialize for DiagnosticStatus {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let level = self.level as u8;
        (
            level,
            &self.name,
            &self.message,
            &self.hardware_id,
            &self.values,
        )
            .serialize(s)
    }
}

impl Serialize for DiagnosticArray {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (&self.header, &self.status).serialize(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nanoseconds_split_into_sec_and_nanosec() {
        assert_eq!(split_ns(1_250_000_000), (1, 250_000_000));
        assert_eq!(
            split_ns(1_700_000_000_500_000_001),
            (1_700_000_000, 500_000_001)
        );
        assert_eq!(split_ns(-500_000_000), (-1, 500_000_000));
    }

    #[test]
    fn a_wrench_is_header_then_six_doubles() {
        let m = WrenchStamped {
            header: Header {
                stamp_ns: 2_500_000_000,
                frame_id: "skin".into(),
            },
            force_n: [0.0, 0.0, 3.0],
            torque_nm: [0.0; 3],
        };
        let b = cdr(&m);
        // Body: sec, nanosec, the frame's length and "skin\0" end at 17, padded to 24 for
        // the six doubles; z of the force is the third.
        assert_eq!(b.len(), 4 + 24 + 48);
        assert_eq!(&b[4 + 40..4 + 48], &3.0f64.to_le_bytes());
        assert!(WrenchStamped::definition().contains("MSG: geometry_msgs/Vector3"));
    }
}
