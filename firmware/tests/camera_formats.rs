//! A camera's own bytes from calibration to measurement: a 1280 × 720 unit whose frames come
//! as 4:2:2 JPEG calibrates at half scale (decoding straight to it), and measures as its
//! lossless twin does; frame sets hold JPEG and raw YUYV frames byte for byte.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use vistaf_hardware::frameset::{copy_set, FrameSet};
use vistaf_hardware::PixelFormat;

fn skin(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_vistaf-skin"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "vistaf-skin {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vistaf-formats-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The reference unit behind a 1280 × 720 sensor: the same optics, so its 16 px grating
/// period at 640 px is 32 px.
const CAMERA: [&str; 6] = ["--width", "1280", "--height", "720", "--period-px", "32"];

/// Depth and contact-centre errors (mm, camera px) of `vistaf-skin analyze` on `set` with
/// `cal`, against the set's labels, per pressed frame.
fn errors(set: &Path, cal: &Path) -> Vec<(f64, f64)> {
    let out = skin(&[
        "analyze",
        "--set",
        set.to_str().unwrap(),
        "--calibration",
        cal.to_str().unwrap(),
    ]);
    let labels = FrameSet::open(set).unwrap().manifest.frames;
    let lines = String::from_utf8(out.stdout).unwrap();
    let results: Vec<serde_json::Value> = lines
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(results.len(), labels.len());
    labels
        .iter()
        .zip(&results)
        .filter(|(l, _)| l.depth_mm.unwrap_or(0.0) > 0.3)
        .map(|(l, r)| {
            let depth = r["depth_mm"].as_f64().unwrap() - l.depth_mm.unwrap();
            let dx = r["contact_x_px"].as_f64().unwrap() - l.contact_x_px.unwrap();
            let dy = r["contact_y_px"].as_f64().unwrap() - l.contact_y_px.unwrap();
            (depth, dx.hypot(dy))
        })
        .collect()
}

#[test]
fn a_jpeg_camera_calibrates_at_half_scale_and_measures_as_its_lossless_twin() {
    let dir = tmp("jpeg-unit");
    // The twins are independent: each calibrates and measures in a process of its own.
    let worst = std::thread::scope(|s| {
        let dir = &dir;
        ["rgb", "mjpeg:85"]
            .map(|enc| s.spawn(move || worst_depth_error(dir, enc)))
            .map(|twin| twin.join().unwrap())
    });
    // The JPEG camera's depths are its lossless twin's, within a tenth and the
    // compression's own few microns.
    assert!(
        worst[0] < 0.06,
        "lossless worst depth error {:.3} mm",
        worst[0]
    );
    assert!(
        worst[1] <= worst[0] * 1.1 + 0.01,
        "JPEG worst depth error {:.3} mm, lossless {:.3} mm",
        worst[1],
        worst[0]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The camera encoding `enc`'s unit: its kit simulated and calibrated (at half scale), then
/// a depth sweep measured; the worst depth error, mm.
fn worst_depth_error(dir: &Path, enc: &str) -> f64 {
    let kit = dir.join(enc.replace(':', "-"));
    simulate(&kit, enc, &["--calibration-kit"]);
    let cal = kit.join("cal.json");
    let sets: Vec<String> = ["depth", "force", "temperature"]
        .iter()
        .map(|s| kit.join(s).display().to_string())
        .collect();
    skin(&[
        "calibrate",
        "--set",
        &sets[0],
        "--set",
        &sets[1],
        "--set",
        &sets[2],
        "--out",
        cal.to_str().unwrap(),
    ]);
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();
    assert_eq!(c["unit"]["decode_scale"], 2, "{enc}: {}", c["unit"]);
    assert_eq!(c["unit"]["width_px"], 640, "{enc}");
    let scene = kit.join("sweep");
    let sweep = ["--scene", "sweep-depth", "--frames", "6", "--seed", "9"];
    simulate(&scene, enc, &sweep);
    let e = errors(&scene, &cal);
    assert!(e.len() >= 4, "{enc}: {e:?}");
    let centre = e.iter().map(|v| v.1).fold(0.0, f64::max);
    // In the camera's pixels: a 1/2-scale position doubled back.
    assert!(centre < 4.0, "{enc}: centre off by {centre:.1} px");
    e.iter().map(|v| v.0.abs()).fold(0.0, f64::max)
}

/// `vistaf-skin simulate` of the 1280 × 720 camera into `out`, its frames encoded as `enc`,
/// with `what` to simulate.
fn simulate(out: &Path, enc: &str, what: &[&str]) {
    let mut args = vec!["simulate"];
    args.extend(what);
    args.extend([
        "--no-truth",
        "--out",
        out.to_str().unwrap(),
        "--encode",
        enc,
    ]);
    args.extend(CAMERA);
    skin(&args);
}

#[test]
fn frame_sets_keep_camera_frames_byte_for_byte() {
    let dir = tmp("sets");
    for (enc, format, ext) in [
        ("yuyv", PixelFormat::Yuyv, "yuyv"),
        ("mjpeg:90", PixelFormat::Mjpeg, "jpg"),
    ] {
        let set = dir.join(ext);
        skin(&[
            "simulate",
            "--scene",
            "idle",
            "--frames",
            "2",
            "--no-truth",
            "--width",
            "320",
            "--height",
            "240",
            "--out",
            set.to_str().unwrap(),
            "--encode",
            enc,
        ]);
        let s = FrameSet::open(&set).unwrap();
        assert_eq!(s.frame_format(), format, "{enc}");
        assert!(
            s.manifest.reference.ends_with(ext),
            "{}",
            s.manifest.reference
        );
        let f = s.frame(1).unwrap();
        assert_eq!((f.width, f.height, f.format), (320, 240, format));
        let bytes = std::fs::read(s.path_of(&s.manifest.frames[1].file)).unwrap();
        assert_eq!(f.data, bytes, "{enc}: the frame is the file's bytes");
        assert_eq!(s.load_frame(1).unwrap().dimensions(), (320, 240));
        // A copy keeps the camera's bytes, not a re-encoding.
        let copy = copy_set(&s, &dir.join(format!("{ext}-copy"))).unwrap();
        assert_eq!(copy.frame(1).unwrap().data, bytes, "{enc}");
        // And the whole set analyses.
        skin(&[
            "analyze",
            "--set",
            set.to_str().unwrap(),
            "--force-calibration",
        ]);
    }
    // Raw YUYV without its size in the manifest is refused by name.
    let set = dir.join("yuyv");
    let m = set.join("set.json");
    let text = std::fs::read_to_string(&m).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut v = v.as_object().unwrap().clone();
    v.remove("width_px");
    std::fs::write(&m, serde_json::to_string(&v).unwrap()).unwrap();
    let e = FrameSet::open(&set).unwrap_err().to_string();
    assert!(
        e.contains("width_px") && e.contains("reference.yuyv"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A camera that sends JPEG frames of a grating, each a little brighter.
struct JpegCamera {
    next: u64,
}

impl vistaf_hardware::FrameSource for JpegCamera {
    fn format(&self) -> vistaf_hardware::SourceFormat {
        vistaf_hardware::SourceFormat {
            width: 64,
            height: 48,
            pixel: PixelFormat::Mjpeg,
            interval: None,
        }
    }
    fn name(&self) -> String {
        "jpeg-camera".into()
    }
    fn next_frame(
        &mut self,
    ) -> Result<Option<vistaf_hardware::Frame>, vistaf_hardware::SourceError> {
        let k = self.next as u8;
        let img = image::RgbImage::from_fn(64, 48, |x, _| {
            let v = if x % 8 < 4 { 200 } else { 40 };
            image::Rgb([v + k, v, v / 2])
        });
        let data = vistaf_hardware::encode::Encoding::Mjpeg(85)
            .encode(&img)
            .unwrap();
        self.next += 1;
        Ok(Some(vistaf_hardware::Frame {
            width: 64,
            height: 48,
            format: PixelFormat::Mjpeg,
            data,
            timestamp: std::time::Duration::from_millis(33 * self.next),
            seq: self.next,
        }))
    }
}

#[test]
fn recording_keeps_what_the_camera_sent() {
    let dir = tmp("record");
    let mut cam = JpegCamera { next: 0 };
    let set = vistaf_hardware::source::record(&mut cam, &dir, 3, 2.0).unwrap();
    assert_eq!(set.manifest.reference, "reference.jpg");
    assert_eq!(set.frame_format(), PixelFormat::Mjpeg);
    let mut again = JpegCamera { next: 0 };
    let reference = vistaf_hardware::FrameSource::next_frame(&mut again)
        .unwrap()
        .unwrap();
    assert_eq!(set.reference_frame().unwrap().data, reference.data);
    for i in 0..3 {
        let sent = vistaf_hardware::FrameSource::next_frame(&mut again)
            .unwrap()
            .unwrap();
        assert_eq!(set.frame(i).unwrap().data, sent.data, "frame {i}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
