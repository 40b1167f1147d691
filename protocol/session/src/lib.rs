//! A guided calibration of a vistaf skin, the same on the robot computer
//! (`vistaf-host calibrate`, over the link) and on the board (`vistaf-skin calibrate
//! --guided`, the service's own state machine in the same process).
//!
//! ```text
//!  Plan ─▶ for each step: Guide asks (a person, a script, a scale) ─▶ heater command
//!        ─▶ KitDevice::capture (bench set if software drives it, image settles, frame kept)
//!        ─▶ KitDevice::fit ─▶ verdict per model against its target ─▶ KitDevice::activate
//! ```
//!
//! The session speaks to a [`KitDevice`], so it knows nothing of links or cameras; the
//! host's client and the board's in-process service each implement it.

pub mod answer;
pub mod cli;
pub mod guide;
pub mod plan;
pub mod port;
pub mod scale;
pub mod session;

pub use cli::SessionArgs;
pub use guide::{instruction, Answer, Guide, Scripted, Terminal, WithScale};
pub use plan::{Activate, Plan};
pub use scale::{parse_newton, Scale, SerialScale};
pub use session::{run, verdict_text, KitDevice, KitError, Outcome, SessionError};
