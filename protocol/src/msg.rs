//! Every message that crosses the link, in both directions.
//!
//! Integers carry their unit in their name (`_us`, `_mn`, `_um`, `_centi_c`, ...). Postcard
//! encodes integers as varints, so small values (no contact, room temperature deltas) cost
//! one or two bytes; fixed-point sub-units keep the resolution that matters without floats.
//!
//! **The wire is append-only.** Never reorder, rename or delete a field or variant: add new
//! ones at the end and bump [`crate::PROTOCOL_VERSION`]. `DeviceMsg::Hello` is variant 0
//! and begins with the protocol version and schema hash, and that prefix never changes, so
//! a host can always tell *which* protocol a device speaks even when it cannot decode the
//! rest (see [`crate::schema::peek_hello`]).

use heapless::{String, Vec};
use postcard::experimental::max_size::MaxSize;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

use crate::flags::QualityFlags;

/// Maximum number of cells in one [`Map`] tile (for example 32 × 24).
pub const MAP_MAX_CELLS: usize = 768;

/// Maximum length of a device serial string, bytes of UTF-8.
pub const SERIAL_MAX_LEN: usize = 24;

/// Maximum length of the human-readable detail of a [`DeviceError`], bytes of UTF-8.
pub const ERROR_DETAIL_MAX_LEN: usize = 64;

/// The longest prefix of `s` that fits a wire string of `N` bytes, cut on a character
/// boundary (a serial or an error detail longer than the wire carries is shortened, never
/// refused).
pub fn truncated<const N: usize>(s: &str) -> String<N> {
    let mut out = String::new();
    for c in s.chars() {
        if out.push(c).is_err() {
            break;
        }
    }
    out
}

/// How long the device waits for a calibration kit step's image to settle before it
/// answers [`ErrorCode::NotSettled`], ms.
pub const KIT_SETTLE_TIMEOUT_MS: u32 = 20_000;

/// Number of LEDs the [`SetLed`] mask can address.
pub const LED_MASK_BITS: u32 = 32;

/// Marker of a [`Map`] cell without a trusted value.
pub const MAP_NO_DATA: i16 = i16::MIN;

/// Value of a [`Summary`] temperature field that was not measured (a build or calibration
/// without thermometry): never a plausible temperature, so it cannot be mistaken for one.
pub const TEMP_NOT_MEASURED: i16 = i16::MIN;

/// Semantic version of the firmware that sent a [`Hello`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub struct FirmwareVersion {
    /// Incompatible changes.
    pub major: u8,
    /// Compatible additions.
    pub minor: u8,
    /// Fixes.
    pub patch: u8,
}

/// Sent by the device on connect and in answer to [`HostMsg::GetInfo`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, MaxSize, Schema)]
pub struct Hello {
    /// [`crate::PROTOCOL_VERSION`] of the sender. Must stay the first field.
    pub protocol_version: u16,
    /// [`crate::schema_hash`] of the sender. Must stay the second field.
    pub schema_hash: u64,
    /// Firmware build.
    pub firmware: FirmwareVersion,
    /// Serial of the skin unit (as printed on its label).
    pub serial: String<SERIAL_MAX_LEN>,
    /// Width of the camera frames the pipeline receives, pixels.
    pub frame_width_px: u16,
    /// Height of the camera frames the pipeline receives, pixels.
    pub frame_height_px: u16,
    /// Identifier of the loaded calibration (a hash of the calibration file; 0 = none).
    pub calibration_id: u32,
}

/// Contact centre on the skin, in tenths of a millimetre from the image's top-left corner.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema,
)]
pub struct CentroidDeciMm {
    /// Horizontal position, 0.1 mm.
    pub x: i16,
    /// Vertical position, 0.1 mm.
    pub y: i16,
}

/// One processed frame: what the robot reads at camera rate.
///
/// Framed size is 31 bytes without contact, 42 with a heated contact, 71 at most (see the crate docs for the measured figures).
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema,
)]
pub struct Summary {
    /// Frame sequence number, +1 per processed frame; gaps mean frames the host missed.
    pub seq: u32,
    /// Capture time of the frame, µs on the device's clock (see [`ClockReading`]).
    pub capture_us: u64,
    /// Capture-to-send processing latency, µs.
    pub latency_us: u32,
    /// Normal force, mN.
    pub force_mn: u32,
    /// Peak indentation depth, µm.
    pub peak_depth_um: u32,
    /// Contact area, 0.01 mm².
    pub contact_area_centi_mm2: u32,
    /// Measurement volume, 0.001 mm³ (nanolitres).
    pub volume_milli_mm3: u32,
    /// Contact centre; `None` when there is no contact.
    pub centroid: Option<CentroidDeciMm>,
    /// Lowest skin temperature, 0.01 °C ([`TEMP_NOT_MEASURED`] when not measured).
    pub temp_min_centi_c: i16,
    /// Mean skin temperature, 0.01 °C.
    pub temp_mean_centi_c: i16,
    /// Highest skin temperature, 0.01 °C.
    pub temp_max_centi_c: i16,
    /// Mean temperature over the contact region, 0.01 °C; `None` without contact.
    pub contact_temp_centi_c: Option<i16>,
    /// What may be wrong with this frame's numbers.
    pub flags: QualityFlags,
}

/// Which quantity a [`Map`] holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub enum MapKind {
    /// Indentation depth, cells in µm.
    Depth,
    /// Skin temperature, cells in 0.01 °C.
    Temperature,
    /// The camera image the pipeline saw, at the working resolution; cells are RGB 5-6-5
    /// (red in the top five bits, read as `u16`). Sent whole only ([`MapChunk`]).
    Camera,
}

/// A downsampled depth or temperature map, sent once per [`HostMsg::RequestMap`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, MaxSize, Schema)]
pub struct Map {
    /// Sequence number of the frame the map was taken from (matches a [`Summary::seq`]).
    pub seq: u32,
    /// What the cells hold.
    pub kind: MapKind,
    /// Cells per row.
    pub width: u8,
    /// Rows.
    pub height: u8,
    /// Side of one cell on the skin, 0.01 mm.
    pub cell_pitch_centi_mm: u16,
    /// Row-major cells (µm or 0.01 °C, see [`MapKind`]); [`MAP_NO_DATA`] where untrusted.
    pub cells: Vec<i16, MAP_MAX_CELLS>,
}

impl Map {
    /// Whether `cells` holds exactly `width × height` values.
    pub fn is_consistent(&self) -> bool {
        usize::from(self.width) * usize::from(self.height) == self.cells.len()
    }
}

/// One piece of a map at the working resolution, sent after a
/// [`HostMsg::RequestFullMap`]: the map's cells in row-major order, [`MAP_MAX_CELLS`] at a
/// time, every piece of one map sent one after another, carrying the same `seq`, `kind` and
/// size. The host puts them together by `first_cell`; a map is whole when its
/// `width × height` cells have come.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, MaxSize, Schema)]
pub struct MapChunk {
    /// Sequence number of the frame the map was taken from (matches a [`Summary::seq`]).
    pub seq: u32,
    /// What the cells hold (units as in [`MapKind`]).
    pub kind: MapKind,
    /// Cells per row of the whole map.
    pub width: u16,
    /// Rows of the whole map.
    pub height: u16,
    /// Side of one cell on the skin, nm (a working pixel is tens of µm).
    pub cell_pitch_nm: u32,
    /// Row-major index of `cells[0]` in the whole map.
    pub first_cell: u32,
    /// The cells; [`MAP_NO_DATA`] where untrusted (depth, temperature).
    pub cells: Vec<i16, MAP_MAX_CELLS>,
}

impl MapChunk {
    /// Cells of the whole map.
    pub fn total_cells(&self) -> usize {
        usize::from(self.width) * usize::from(self.height)
    }

    /// Whether the piece is not empty and lies inside its map.
    pub fn is_consistent(&self) -> bool {
        !self.cells.is_empty()
            && usize::try_from(self.first_cell)
                .is_ok_and(|f| f.saturating_add(self.cells.len()) <= self.total_cells())
    }
}

/// What the service is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub enum RunState {
    /// Capturing and processing, summaries paused by [`HostMsg::Stop`].
    Stopped,
    /// Streaming summaries.
    Streaming,
    /// Waiting for a stable image to take a new reference.
    Referencing,
    /// The camera is gone; retrying with back-off.
    CameraLost,
}

/// Health counters, sent periodically and after every state change.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub struct Status {
    /// Time since the service started, ms.
    pub uptime_ms: u64,
    /// Current state.
    pub state: RunState,
    /// Summary rate limit, Hz (0 = camera rate).
    pub max_rate_hz: u16,
    /// Frames delivered by the camera.
    pub frames_captured: u32,
    /// Frames processed into summaries.
    pub frames_processed: u32,
    /// Frames dropped because a newer one arrived first (newest frame wins).
    pub frames_dropped: u32,
    /// Frames refused as malformed (wrong size, truncated).
    pub bad_frames: u32,
    /// Host frames the device could not decode.
    pub link_frames_dropped: u32,
    /// Age of the reference frame, ms.
    pub reference_age_ms: u32,
    /// Times the camera was reopened after a loss.
    pub camera_restarts: u16,
    /// Median time from a frame's capture to its summary's last byte written to the link,
    /// over the last 256 summaries, µs (0 before any).
    pub latency_p50_us: u32,
    /// The same, 99th percentile, µs.
    pub latency_p99_us: u32,
}

/// What went wrong on the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub enum ErrorCode {
    /// The camera disappeared or stopped delivering frames.
    CameraLost,
    /// A frame was malformed and skipped.
    BadFrame,
    /// The command is not supported by this firmware.
    UnsupportedCommand,
    /// A command argument was out of range.
    InvalidArgument,
    /// The calibration is missing or does not fit this unit.
    Calibration,
    /// The LED ring could not be driven.
    LedFault,
    /// Anything else; see the detail text.
    Internal,
    /// No reference could be taken (no grating in view, or the calibration does not fit);
    /// the device keeps trying with the next stable frames.
    Reference,
    /// A calibration kit step's image did not settle within [`KIT_SETTLE_TIMEOUT_MS`]
    /// (the skin still moving or warming); the step may be asked for again.
    NotSettled,
}

impl ErrorCode {
    /// Whether an error of this kind reports the device's own state (it cannot take a
    /// reference, the camera is gone, a frame was bad) rather than answering a command: a
    /// device repeats a reference error every second while its calibration does not fit
    /// the skin in view, as during the calibration of a new unit, and a command's wait
    /// must not end on it.
    pub const fn is_report(self) -> bool {
        matches!(
            self,
            ErrorCode::Reference | ErrorCode::CameraLost | ErrorCode::BadFrame
        )
    }
}

/// An error report from the device.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, MaxSize, Schema)]
pub struct DeviceError {
    /// Machine-readable cause.
    pub code: ErrorCode,
    /// Human-readable detail, truncated to [`ERROR_DETAIL_MAX_LEN`] bytes.
    pub detail: String<ERROR_DETAIL_MAX_LEN>,
}

/// Which host command an [`DeviceMsg::Ack`] answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub enum Command {
    /// [`HostMsg::CaptureReference`].
    CaptureReference,
    /// [`HostMsg::SetRate`].
    SetRate,
    /// [`HostMsg::SetLed`].
    SetLed,
    /// [`HostMsg::RequestMap`].
    RequestMap,
    /// [`HostMsg::Start`].
    Start,
    /// [`HostMsg::Stop`].
    Stop,
    /// [`HostMsg::KitCapture`]: waiting for a settled image; [`DeviceMsg::KitCaptured`]
    /// follows.
    KitCapture,
    /// [`HostMsg::KitFit`]: the fit started; its verdicts follow.
    KitFit,
    /// [`HostMsg::RequestFullMap`]: the next processed frame's map follows in pieces.
    RequestFullMap,
}

/// What a calibration kit step labels its frame with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub enum KitQuantity {
    /// The untouched skin, the kit's reference; begins a new kit. Value: its temperature,
    /// milli-°C.
    Reference,
    /// The calibration sphere pressed to a known depth; value in µm.
    Depth,
    /// The calibration sphere pressed with a known force; value in mN.
    Force,
    /// The untouched skin at a known uniform temperature; value in milli-°C.
    Temperature,
}

/// One labelled capture of a calibration kit ([`HostMsg::KitCapture`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub struct KitStep {
    /// What the frame shows.
    pub quantity: KitQuantity,
    /// The label, in the quantity's unit (µm, mN or milli-°C, see [`KitQuantity`]).
    pub value_milli: i32,
}

/// A kit frame captured ([`DeviceMsg::KitCaptured`]), once the image had settled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub struct KitCaptured {
    /// The step captured.
    pub step: KitStep,
    /// Frames of this quantity in the kit now.
    pub frames: u16,
    /// From the command to the capture: the time the image took to settle, ms.
    pub settle_ms: u32,
    /// Mean absolute change between the last two frames before the capture, 0.01 of an
    /// 8-bit step (what "settled" measured).
    pub change_centi_dn: u16,
}

/// A fitted model's held-out error against its target ([`DeviceMsg::KitVerdict`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub struct KitVerdict {
    /// Which model: `Depth` (phase → depth), `Force` or `Temperature`.
    pub quantity: KitQuantity,
    /// Samples the fit used: frames for depth and force, colour blocks for temperature
    /// (saturating).
    pub samples: u16,
    /// Cross-validated RMSE, in the quantity's milli-unit (µm, mN, milli-°C).
    pub error_milli: u32,
    /// The target that RMSE is held to, same unit.
    pub target_milli: u32,
    /// `error_milli <= target_milli`.
    pub pass: bool,
}

/// The kit's fit is done ([`DeviceMsg::CalibrationFitted`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub struct CalibrationFitted {
    /// Identifier of the fitted calibration (what `Hello` shows once it is active).
    pub calibration_id: u32,
    /// Whether every verdict passed.
    pub pass: bool,
}

/// Device → host.
///
/// `Map` makes this enum about 1.6 kB; without an allocator it cannot be boxed, and a map
/// is rare, so the device keeps one `DeviceMsg` buffer rather than one per variant.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, MaxSize, Schema)]
pub enum DeviceMsg {
    /// Identity and versions. Must stay variant 0.
    Hello(Hello),
    /// One processed frame.
    Summary(Summary),
    /// A requested map tile.
    Map(Map),
    /// Health counters.
    Status(Status),
    /// An error report.
    Error(DeviceError),
    /// Answer to [`HostMsg::Ping`], echoing its nonce.
    Pong {
        /// The nonce of the ping.
        nonce: u32,
    },
    /// A command was accepted.
    Ack(Command),
    /// Answer to [`HostMsg::Clock`]: the device's clock when the request arrived and when
    /// the answer left.
    Clock(ClockReading),
    /// Answer to [`HostMsg::KitCapture`], once the frame is stored.
    KitCaptured(KitCaptured),
    /// One per fitted model, after [`HostMsg::KitFit`].
    KitVerdict(KitVerdict),
    /// After the verdicts of [`HostMsg::KitFit`]: the candidate, ready to activate.
    CalibrationFitted(CalibrationFitted),
    /// A piece of a map at the working resolution ([`HostMsg::RequestFullMap`]).
    MapChunk(MapChunk),
}

/// The device's clock around one [`HostMsg::Clock`] request, in the clock of
/// [`Summary::capture_us`] (µs since the device's epoch, monotonic, never reset while the
/// service runs).
///
/// With the host's own send and receive times this is one sample of the four-timestamp
/// exchange NTP uses: the time the request waited on the device (between two frames)
/// drops out of the estimate, and only the link's asymmetry is left as error.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema,
)]
pub struct ClockReading {
    /// The nonce of the request.
    pub nonce: u32,
    /// When the request's last byte was decoded, µs.
    pub received_us: u64,
    /// When the answer was framed for the link, µs.
    pub sent_us: u64,
}

/// An LED colour, 8-bit sRGB.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema,
)]
pub struct Rgb {
    /// Red.
    pub r: u8,
    /// Green.
    pub g: u8,
    /// Blue.
    pub b: u8,
}

/// LED ring settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub struct SetLed {
    /// Colour of the lit LEDs.
    pub rgb: Rgb,
    /// Global brightness, 0–255 (the reference build uses 30).
    pub brightness: u8,
    /// Bit i lights LED i (the reference build lights the odd ones of 24: `0xAA_AAAA`).
    pub lit_mask: u32,
}

/// Host → device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema)]
pub enum HostMsg {
    /// Liveness check; answered by [`DeviceMsg::Pong`] with the same nonce.
    Ping {
        /// Echoed back.
        nonce: u32,
    },
    /// Answered by [`DeviceMsg::Hello`].
    GetInfo,
    /// Take a new no-contact reference once the image is stable.
    CaptureReference,
    /// Limit the summary rate.
    SetRate {
        /// Maximum summaries per second; 0 = every frame.
        max_rate_hz: u16,
    },
    /// Change the LED ring.
    SetLed(SetLed),
    /// Send one coarse map (at most [`MAP_MAX_CELLS`] cells) of the next processed frame.
    RequestMap(MapKind),
    /// Resume streaming summaries.
    Start,
    /// Pause streaming summaries (processing continues, so the reference stays fresh).
    Stop,
    /// Read the device's clock; answered by [`DeviceMsg::Clock`] with the same nonce.
    Clock {
        /// Echoed back.
        nonce: u32,
    },
    /// Capture one labelled kit frame once the image has settled; answered by
    /// [`DeviceMsg::KitCaptured`] (or an error when it never settles). A `Reference` step
    /// begins a new kit.
    KitCapture(KitStep),
    /// Fit a calibration to the kit; answered by [`DeviceMsg::Ack`], then a
    /// [`DeviceMsg::KitVerdict`] per model and [`DeviceMsg::CalibrationFitted`].
    KitFit,
    /// Put the fitted calibration in use (and in the calibration file), keeping the one it
    /// replaces; answered by [`DeviceMsg::Hello`] with the new calibration id. The id
    /// must be the fitted one's: a host cannot activate what it did not see.
    CalibrationActivate {
        /// [`CalibrationFitted::calibration_id`].
        calibration_id: u32,
    },
    /// Go back to the calibration the last activation replaced; answered by
    /// [`DeviceMsg::Hello`] with its id.
    CalibrationRollback,
    /// Send the next processed frame's map at the working resolution, in
    /// [`DeviceMsg::MapChunk`]s after the [`DeviceMsg::Ack`].
    RequestFullMap(MapKind),
}
