//! The paper's Table II, refitted from its own per-image data, with honest figures beside it.

use std::path::Path;

use anyhow::Result;

/// Placeholder until the table lands.
pub fn table(_csv: &Path) -> Result<()> {
    anyhow::bail!("--table is not implemented yet")
}
