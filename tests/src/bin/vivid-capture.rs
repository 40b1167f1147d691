//! The camera code against a real V4L2 driver: run inside the `vivid` VM that
//! `tests/vivid/run.sh` boots (static build, it is the VM's only program). Prints one
//! `VIVID-CHECK name: ok|FAIL detail` line per check and `VIVID-RESULT PASS|FAIL` last.
//!
//! Checks: list the nodes; open by path and by driver name; negotiate YUYV and MJPEG (vivid
//! offers no MJPEG: the fallback must say what it chose) at two sizes; stream with the
//! newest-frame policy and count driver drops and stale buffers; convert frames to RGB and
//! run the pipeline on them (vivid's test pattern has no grating: a clear refusal or a
//! low-contrast flag, never a panic); unbind the driver through sysfs and rebind it, with a
//! clear error while it is gone and a resumed stream after.

#[cfg(not(feature = "v4l-test"))]
fn main() {}

#[cfg(feature = "v4l-test")]
fn main() {
    vivid::main();
}

#[cfg(feature = "v4l-test")]
mod vivid {
    use std::time::{Duration, Instant};

    use vistaf_hardware::camera::{list_nodes, Camera, CaptureRequest, Selector};
    use vistaf_hardware::frame::PixelFormat;
    use vistaf_hardware::source::{FrameSource, Reconnect};
    use vistaf_pipeline::calibration::Calibration;
    use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation};
    use vistaf_protocol::Flag;

    struct Report {
        failed: bool,
    }

    impl Report {
        fn check(&mut self, name: &str, r: Result<String, String>) {
            match r {
                Ok(detail) => println!("VIVID-CHECK {name}: ok {detail}"),
                Err(detail) => {
                    self.failed = true;
                    println!("VIVID-CHECK {name}: FAIL {detail}");
                }
            }
        }
    }

    fn stream(cam: &mut Camera, n: usize) -> Result<String, String> {
        let t0 = Instant::now();
        let mut got = 0;
        for _ in 0..n {
            match cam.next_frame() {
                Ok(Some(f)) => {
                    f.to_rgb().map_err(|e| format!("converting: {e}"))?;
                    got += 1;
                }
                Ok(None) => break,
                Err(e) => return Err(format!("after {got} frames: {e}")),
            }
        }
        Ok(format!(
            "{got} frames in {:.1} s, {} dropped by the driver, {} stale skipped",
            t0.elapsed().as_secs_f32(),
            cam.driver_dropped(),
            cam.stale_skipped()
        ))
    }

    /// A capture request for the checks.
    fn req(w: u32, h: u32, formats: Vec<PixelFormat>) -> CaptureRequest {
        CaptureRequest {
            width: w,
            height: h,
            fps: 30,
            formats,
            hold_after: None,
        }
    }

    pub fn main() {
        let mut r = Report { failed: false };
        r.check("list", list());
        let path = Selector::Path("/dev/video0".into());
        for (w, h) in [(320, 240), (640, 480)] {
            let name = format!("yuyv-{w}x{h}");
            match Camera::open(&path, &req(w, h, vec![PixelFormat::Yuyv])) {
                Ok(mut cam) => {
                    let f = cam.format();
                    let neg = format!("negotiated {:?} {}×{}", f.pixel, f.width, f.height);
                    r.check(&name, stream(&mut cam, 20).map(|s| format!("{neg}; {s}")));
                }
                Err(e) => r.check(&name, Err(e.to_string())),
            }
        }
        r.check("by-name-mjpeg-preferred", by_name_mjpeg_preferred());
        r.check("pipeline", pipeline(&path));
        r.check("light-held", light_held(&path));
        r.check("unbind-rebind", rebind());
        println!("VIVID-RESULT {}", if r.failed { "FAIL" } else { "PASS" });
    }

    /// The node listing names vivid's capture node.
    fn list() -> Result<String, String> {
        let nodes = list_nodes();
        nodes
            .iter()
            .any(|n| n.name.contains("vivid") && n.captures_video)
            .then(|| {
                format!(
                    "{} nodes: {:?}",
                    nodes.len(),
                    nodes
                        .iter()
                        .map(|n| n.path.display().to_string())
                        .collect::<Vec<_>>()
                )
            })
            .ok_or_else(|| format!("no vivid capture node among {nodes:?}"))
    }

    /// Opened by driver name, MJPEG asked for first: says what it chose.
    fn by_name_mjpeg_preferred() -> Result<String, String> {
        let cam = Camera::open(
            &Selector::Name("vivid".into()),
            &req(640, 480, vec![PixelFormat::Mjpeg, PixelFormat::Yuyv]),
        )
        .map_err(|e| e.to_string())?;
        let f = cam.format();
        Ok(format!(
            "opened {}, negotiated {:?} {}×{} (MJPEG offered: {})",
            cam.name(),
            f.pixel,
            f.width,
            f.height,
            f.pixel == PixelFormat::Mjpeg
        ))
    }

    /// The pipeline on vivid's pattern, which has no grating: a clear refusal or a
    /// low-contrast flag on every frame.
    fn pipeline(path: &Selector) -> Result<String, String> {
        let mut cam = Camera::open(path, &req(640, 480, vec![PixelFormat::Yuyv]))
            .map_err(|e| e.to_string())?;
        let mut frame = || -> Result<image::RgbImage, String> {
            cam.next_frame()
                .map_err(|e| e.to_string())?
                .ok_or("stream ended")?
                .into_rgb()
                .map_err(|e| e.to_string())
        };
        let reference = frame()?;
        let opts = AnalyzerOptions {
            force_calibration: true,
            ..Default::default()
        };
        match Analyzer::new(
            &reference,
            Calibration::default_sim(),
            Implementation::Fixed,
            opts,
        ) {
            Err(e) => Ok(format!("refused with a clear error: {e}")),
            Ok(a) => {
                let mut flagged = 0;
                for _ in 0..5 {
                    let d = a.analyze(&frame()?).map_err(|e| e.to_string())?;
                    flagged += usize::from(d.flags.contains(Flag::LowContrast));
                }
                if flagged == 5 {
                    Ok("5 of 5 frames flagged low_contrast".into())
                } else {
                    Err(format!("only {flagged} of 5 frames flagged low_contrast"))
                }
            }
        }
    }

    /// Held from the first frame on: vivid's automatic gain goes off at the gain it had,
    /// and the note says so once.
    fn light_held(path: &Selector) -> Result<String, String> {
        use vistaf_hardware::light_hold::{AUTOGAIN, GAIN};
        let mut ask = req(320, 240, vec![PixelFormat::Yuyv]);
        ask.hold_after = Some(Duration::ZERO);
        let mut cam = Camera::open(path, &ask).map_err(|e| e.to_string())?;
        cam.next_frame().map_err(|e| e.to_string())?;
        let note = cam.take_note().ok_or("no note after the first frame")?;
        if cam.take_note().is_some() {
            return Err("the note came twice".into());
        }
        match (cam.control(AUTOGAIN), cam.control(GAIN)) {
            (Some(0), Some(g)) if note.contains(&format!("gain held at {g}")) => Ok(note),
            other => Err(format!("autogain, gain {other:?} after \"{note}\"")),
        }
    }

    /// Unbinds and rebinds the driver under a running, reconnecting source.
    fn rebind() -> Result<String, String> {
        let open = || {
            Camera::open(
                &Selector::Name("vivid".into()),
                &req(320, 240, vec![PixelFormat::Yuyv]),
            )
        };
        let mut src = Reconnect::new(open).map_err(|e| e.to_string())?;
        src.min_backoff = Duration::from_millis(50);
        src.max_backoff = Duration::from_millis(400);
        for _ in 0..3 {
            src.next_frame().map_err(|e| e.to_string())?;
        }
        let drv = "/sys/bus/platform/drivers/vivid";
        std::fs::write(format!("{drv}/unbind"), "vivid.0").map_err(|e| format!("unbind: {e}"))?;
        let lost = match src.next_frame() {
            Err(e) if e.is_transient() => e.to_string(),
            other => return Err(format!("no error while unbound: {other:?}")),
        };
        std::fs::write(format!("{drv}/bind"), "vivid.0").map_err(|e| format!("bind: {e}"))?;
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            match src.next_frame() {
                Ok(Some(_)) => break,
                _ if Instant::now() > deadline => return Err("no frame after rebinding".into()),
                _ => {}
            }
        }
        Ok(format!(
            "while unbound: \"{lost}\"; resumed after {} reopen(s)",
            src.reopened
        ))
    }
}
