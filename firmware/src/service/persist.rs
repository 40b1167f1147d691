//! The calibration file across activations: the active calibration is the configured
//! file, and the one it replaced is kept beside it as `<file>.previous`, so a rollback
//! survives a restart of the service. Files are replaced by renaming a complete file over
//! them, so a power cut leaves either the old or the new calibration, never half of one.

use std::path::{Path, PathBuf};

use vistaf_pipeline::Calibration;

/// Where the calibration replaced by the last activation is kept.
pub fn previous_path(path: &Path) -> PathBuf {
    sibling(path, ".previous")
}

fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(suffix);
    PathBuf::from(p)
}

/// The calibration the last activation replaced, as kept beside `path`; `None` when there
/// is none, or it does not read (then there is only nothing to roll back to).
pub fn previous(path: &Path) -> Option<Calibration> {
    Calibration::load(&previous_path(path)).ok()
}

/// Makes `new` the calibration at `path`, the file there now kept as the previous one.
pub fn activate(path: &Path, new: &Calibration) -> Result<(), String> {
    let tmp = sibling(path, ".new");
    new.save(&tmp).map_err(|e| e.to_string())?;
    if path.exists() {
        std::fs::copy(path, previous_path(path))
            .map_err(|e| format!("keeping {}: {e}", path.display()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Swaps the calibration at `path` with the previous one.
pub fn roll_back(path: &Path) -> Result<(), String> {
    let prev = previous_path(path);
    if !prev.exists() {
        return Err(format!("{}: no previous calibration file", prev.display()));
    }
    let tmp = sibling(path, ".swap");
    std::fs::rename(path, &tmp)
        .and_then(|()| std::fs::rename(&prev, path))
        .and_then(|()| std::fs::rename(&tmp, &prev))
        .map_err(|e| format!("rolling back {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_activation_keeps_the_old_file_and_a_rollback_swaps_them() {
        let dir = std::env::temp_dir().join(format!("vistaf-persist-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("calibration.json");
        let old = Calibration::default_sim();
        old.save(&path).unwrap();
        let mut new = old.clone();
        new.phase_sign = -old.phase_sign;
        activate(&path, &new).unwrap();
        assert_eq!(Calibration::load(&path).unwrap().id(), new.id());
        assert_eq!(
            Calibration::load(&previous_path(&path)).unwrap().id(),
            old.id()
        );
        roll_back(&path).unwrap();
        assert_eq!(Calibration::load(&path).unwrap().id(), old.id());
        assert_eq!(
            Calibration::load(&previous_path(&path)).unwrap().id(),
            new.id()
        );
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(roll_back(&path).is_err());
    }
}
