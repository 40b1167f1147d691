//! Protocol identity: a version number people bump and a schema hash the compiler computes.
//!
//! The hash is postcard-schema's 64-bit FNV-1a key over the full schema of both message
//! enums (field names and order, variant names, types). Any change to a wire type changes
//! it, and a test pins its value, so a silent schema change fails CI and forces a
//! [`PROTOCOL_VERSION`] bump. Type *names* are not hashed, so renaming a Rust type is free.

use postcard_schema::key::Key;

use crate::msg::{DeviceMsg, HostMsg};

/// Version of the wire protocol; bump it with every change to a message type.
pub const PROTOCOL_VERSION: u16 = 11;

const SCHEMA_KEY: Key = Key::for_path::<(DeviceMsg, HostMsg)>("vistaf/v1");

/// Hash of the schema of every message in both directions.
pub const fn schema_hash() -> u64 {
    u64::from_le_bytes(SCHEMA_KEY.to_bytes())
}

/// Reads the protocol version and schema hash from the payload of a `Hello`, even when the
/// rest of the message is in a layout this build does not know. Returns `None` when the
/// payload is not a `Hello`.
///
/// This works because `Hello` is variant 0 of `DeviceMsg` and starts with those two fields
/// (postcard encodes the variant index and both integers as varints).
pub fn peek_hello(payload: &[u8]) -> Option<(u16, u64)> {
    match postcard::take_from_bytes::<(u32, u16, u64)>(payload) {
        Ok(((0, version, hash), _)) => Some((version, hash)),
        _ => None,
    }
}

/// Whether a peer announcing `protocol_version` and `schema_hash` speaks this protocol.
pub const fn is_compatible(protocol_version: u16, schema_hash: u64) -> bool {
    protocol_version == PROTOCOL_VERSION && schema_hash == self::schema_hash()
}
