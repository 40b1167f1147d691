//! Host errors. Comms faults (the link, the bytes) are kept apart from what the device
//! itself reports ([`HostError::Device`]).

use std::io;
use std::time::Duration;

use vistaf_protocol::DeviceError;

/// Everything that can go wrong on the host side.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HostError {
    /// A link spec string could not be parsed.
    #[error(transparent)]
    BadLinkSpec(#[from] vistaf_protocol::link::LinkSpecError),
    /// The link could not be opened.
    #[error("cannot open {link}: {cause}")]
    Open {
        /// The link.
        link: String,
        /// The cause.
        cause: io::Error,
    },
    /// Reading or writing the link failed.
    #[error("{link}: {cause}")]
    Io {
        /// The link.
        link: String,
        /// The cause.
        cause: io::Error,
    },
    /// A command was sent on a link that cannot carry it (a file or stdin).
    #[error("{link} is read-only: commands need a serial link")]
    ReadOnly {
        /// The link.
        link: String,
    },
    /// The device did not answer in time.
    #[error("{link}: no {waiting_for} within {timeout:?}")]
    Timeout {
        /// The link.
        link: String,
        /// What was expected.
        waiting_for: &'static str,
        /// How long we waited.
        timeout: Duration,
    },
    /// The stream ended while an answer was expected.
    #[error("{link}: stream ended while waiting for {waiting_for}")]
    Closed {
        /// The link.
        link: String,
        /// What was expected.
        waiting_for: &'static str,
    },
    /// The device speaks another protocol version or schema.
    #[error(
        "{link}: device speaks protocol v{device_version} (schema {device_schema:#018x}), \
         this host speaks v{host_version} (schema {host_schema:#018x}); update the host or the firmware"
    )]
    Incompatible {
        /// The link.
        link: String,
        /// The device's protocol version.
        device_version: u16,
        /// The device's schema hash.
        device_schema: u64,
        /// Ours.
        host_version: u16,
        /// Ours.
        host_schema: u64,
    },
    /// A record file has an extension that names no format.
    #[error("{path}: unknown extension (use .csv or .jsonl)")]
    RecordFormat {
        /// The file.
        path: String,
    },
    /// A record file could not be created or written.
    #[error("writing {path}: {cause}")]
    Record {
        /// The file.
        path: String,
        /// The cause.
        cause: io::Error,
    },
    /// A lost link did not come back.
    #[error("{link}: lost ({last}) and not back within {after:?}; gave up")]
    GaveUp {
        /// The link.
        link: String,
        /// How long reconnecting was tried.
        after: Duration,
        /// Why the link was lost, or why the last attempt failed.
        last: String,
    },
    /// The ROS 2 side (DDS) could not be set up or refused a topic.
    #[error("ROS 2: {detail}")]
    Ros2 {
        /// What failed and why.
        detail: String,
    },
    /// The device refused a command.
    #[error("{link}: device error {:?}: {}", .error.code, .error.detail)]
    Device {
        /// The link.
        link: String,
        /// What the device said.
        error: DeviceError,
    },
}

impl HostError {
    /// Builds [`HostError::Incompatible`] for a device announcing `version` and `schema`.
    pub fn incompatible(link: &str, version: u16, schema: u64) -> HostError {
        HostError::Incompatible {
            link: link.to_string(),
            device_version: version,
            device_schema: schema,
            host_version: vistaf_protocol::PROTOCOL_VERSION,
            host_schema: vistaf_protocol::schema_hash(),
        }
    }
}
