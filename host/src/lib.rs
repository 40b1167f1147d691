//! # vistaf-host
//!
//! The robot computer's side of a vistaf skin: open a link ([`link`]), shake hands and
//! send commands ([`client`]), map the device's clock onto the host's ([`clock`]), read one
//! skin or many ([`multi`]) with sequence-gap accounting ([`seq`]) until told to stop
//! ([`stream`]), show it live ([`monitor`]), record what arrives ([`record`]), publish it
//! as ROS 2 messages ([`ros2`]) to DDS (feature `ros2`), MCAP and JSON lines
//! ([`bridge`]), calibrate a skin in one guided session ([`calibrate`]), and draw a frame
//! as a figure from its full maps ([`maps`], [`snapshot`]). The `vistaf-host` binary is a
//! thin CLI over this library. It depends on the wire (`vistaf-protocol`) and the figures
//! (`vistaf-figure`, which draws plain grids and knows nothing of ours) alone: nothing of
//! the pipeline or the camera is built on the robot computer.
//!
//! ```text
//!  skin ─▶ serial ─▶ Link ─▶ Client (DeviceDecoder) ─▶ Received { msg, at }
//!                                  ▲                        │
//!                       commands ──┘                        ├─▶ monitor (live readout)
//!                                                           └─▶ Recorder (.csv/.jsonl)
//! ```
//!
//! ```no_run
//! use vistaf_host::{client::{Client, Next, DEFAULT_TIMEOUT}, link::{Link, LinkSpec}};
//! # fn main() -> Result<(), vistaf_host::HostError> {
//! let spec: LinkSpec = "/dev/ttyACM0".parse()?;
//! let mut skin = Client::new(Link::open(&spec)?);
//! let hello = skin.handshake(DEFAULT_TIMEOUT)?;
//! println!("skin {} at {}×{}", hello.serial, hello.frame_width_px, hello.frame_height_px);
//! while let Next::Message(r) = skin.next(None)? {
//!     println!("{:?}", r.msg);
//! }
//! # Ok(()) }
//! ```
#![deny(missing_docs)]

pub mod bridge;
pub mod calibrate;
pub mod client;
pub mod clock;
pub mod error;
pub mod heatmap;
pub mod link;
pub mod maps;
pub mod monitor;
pub mod multi;
pub mod record;
pub mod ros2;
pub use vistaf_session::scale;
pub mod seq;
pub mod snapshot;
pub mod stream;

pub use error::HostError;
