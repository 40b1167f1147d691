//! `--source` strings: `camera:/dev/videoN`, `camera-serial:SERIAL`, `camera-name:NAME`,
//! `set:DIR`, `sim:SCENE`, `sim:bench` (a simulated unit on a calibration bench that a
//! guided calibration drives).

use std::path::PathBuf;

use anyhow::{anyhow, bail, Result};
use vistaf_hardware::bench::SharedBench;
use vistaf_hardware::source::{FrameSource, Pacing, SetReplay};
use vistaf_sim::{SensorUnit, SimSource};

/// A parsed `--source`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SourceSpec {
    /// A V4L2 device node.
    Camera(PathBuf),
    /// A camera by USB serial.
    CameraSerial(String),
    /// A camera by driver name.
    CameraName(String),
    /// A recorded frame set.
    Set(PathBuf),
    /// A simulated scene.
    Sim(String),
}

impl std::str::FromStr for SourceSpec {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<Self> {
        let (kind, arg) = s
            .split_once(':')
            .ok_or_else(|| anyhow!("source {s:?}: expected KIND:ARG (camera:, camera-serial:, camera-name:, set:, sim:)"))?;
        if arg.is_empty() {
            bail!("source {s:?}: nothing after '{kind}:'");
        }
        Ok(match kind {
            "camera" => SourceSpec::Camera(arg.into()),
            "camera-serial" => SourceSpec::CameraSerial(arg.into()),
            "camera-name" => SourceSpec::CameraName(arg.into()),
            "set" => SourceSpec::Set(arg.into()),
            "sim" => SourceSpec::Sim(arg.into()),
            other => bail!("source {s:?}: unknown kind {other:?} (camera, camera-serial, camera-name, set, sim)"),
        })
    }
}

/// Options that shape an opened source.
#[derive(Debug, Clone)]
pub struct OpenOptions {
    /// Frames a simulated scene lasts.
    pub sim_frames: usize,
    /// Simulated unit.
    pub unit_seed: u64,
    /// Noise seed of a simulated scene.
    pub seed: u64,
    /// Pace replay and simulation at this rate (None: as fast as possible).
    pub fps: Option<f32>,
    /// Loop sets and scenes.
    pub looping: bool,
    /// Requested camera size, pixels.
    pub size: (u32, u32),
    /// How long a camera streams before its automatic light settings are held; `None`
    /// leaves them automatic (`vistaf_hardware::light_hold`).
    pub camera_hold: Option<std::time::Duration>,
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions {
            sim_frames: 60,
            unit_seed: 0,
            seed: 1,
            fps: None,
            looping: false,
            size: (640, 480),
            camera_hold: Some(vistaf_hardware::light_hold::HOLD_AFTER),
        }
    }
}

/// The scene name of a simulated unit on a calibration bench.
pub const BENCH_SCENE: &str = "bench";

/// Opens the source a spec names.
pub fn open(spec: &SourceSpec, o: &OpenOptions) -> Result<Box<dyn FrameSource>> {
    Ok(open_with_bench(spec, o)?.0)
}

/// Opens the source a spec names, with the bench that sets what it films when software
/// can drive one (`sim:bench`).
pub fn open_with_bench(
    spec: &SourceSpec,
    o: &OpenOptions,
) -> Result<(Box<dyn FrameSource>, Option<SharedBench>)> {
    if let SourceSpec::Sim(scene) = spec {
        if scene == BENCH_SCENE {
            let unit = SensorUnit::from_seed(o.unit_seed);
            let (src, bench) = SimSource::on_bench(unit, o.fps, o.seed);
            let bench: SharedBench = std::sync::Arc::new(std::sync::Mutex::new(bench));
            return Ok((Box::new(src), Some(bench)));
        }
    }
    Ok((open_source(spec, o)?, None))
}

fn open_source(spec: &SourceSpec, o: &OpenOptions) -> Result<Box<dyn FrameSource>> {
    Ok(match spec {
        SourceSpec::Set(dir) => {
            let pacing = if o.fps.is_some() {
                Pacing::Recorded
            } else {
                Pacing::AsFastAsPossible
            };
            Box::new(SetReplay::open(dir, pacing, o.looping)?)
        }
        SourceSpec::Sim(scene) => {
            let unit = SensorUnit::from_seed(o.unit_seed);
            let src =
                SimSource::scene(scene, unit, o.sim_frames, o.fps, o.seed).ok_or_else(|| {
                    let names: Vec<&str> = vistaf_sim::scene::SCENES.iter().map(|s| s.0).collect();
                    anyhow!(
                        "unknown scene {scene:?}; scenes: {}, {BENCH_SCENE}",
                        names.join(", ")
                    )
                })?;
            Box::new(src.looping(o.looping))
        }
        #[cfg(feature = "v4l")]
        SourceSpec::Camera(_) | SourceSpec::CameraSerial(_) | SourceSpec::CameraName(_) => {
            use vistaf_hardware::camera::{Camera, CaptureRequest, Selector};
            let sel = match spec {
                SourceSpec::Camera(p) => Selector::Path(p.clone()),
                SourceSpec::CameraSerial(s) => Selector::Serial(s.clone()),
                SourceSpec::CameraName(s) => Selector::Name(s.clone()),
                _ => unreachable!("matched above"),
            };
            let req = CaptureRequest {
                width: o.size.0,
                height: o.size.1,
                hold_after: o.camera_hold,
                ..CaptureRequest::default()
            };
            let open = move || Camera::open(&sel, &req);
            Box::new(vistaf_hardware::source::Reconnect::new(open)?)
        }
        #[cfg(not(feature = "v4l"))]
        SourceSpec::Camera(_) | SourceSpec::CameraSerial(_) | SourceSpec::CameraName(_) => {
            bail!("this build has no camera support (built without the v4l feature)")
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_and_bad_ones_say_why() {
        assert_eq!(
            "sim:idle".parse::<SourceSpec>().unwrap(),
            SourceSpec::Sim("idle".into())
        );
        assert_eq!(
            "camera:/dev/video0".parse::<SourceSpec>().unwrap(),
            SourceSpec::Camera("/dev/video0".into())
        );
        assert!("webcam:0"
            .parse::<SourceSpec>()
            .unwrap_err()
            .to_string()
            .contains("unknown kind"));
        assert!("set:"
            .parse::<SourceSpec>()
            .unwrap_err()
            .to_string()
            .contains("nothing after"));
        assert!("idle"
            .parse::<SourceSpec>()
            .unwrap_err()
            .to_string()
            .contains("KIND:ARG"));
        let e = open(&SourceSpec::Sim("nope".into()), &OpenOptions::default())
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("unknown scene") && e.contains("press-sphere"),
            "{e}"
        );
    }
}
