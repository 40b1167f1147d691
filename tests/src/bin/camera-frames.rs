//! The whole device per frame, from the camera's bytes to the summary's bytes on the link,
//! for instruction counting (`scripts/camera-cost.sh`):
//!
//! ```sh
//! camera-frames mjpeg:90 1920 1080 1     # setup and one frame
//! camera-frames mjpeg:90 1920 1080 11    # setup and eleven
//! ```
//!
//! The difference of the two counts divided by 10 is one frame: decoding at the scale the
//! calibration would choose (`vistaf_pipeline::input::decode_scale`), the pipeline with
//! temperature, and the summary framed for the link. The reference unit's optics are kept:
//! a camera of more pixels sees its grating's period (16 px at 640 × 480) grow with its
//! width. Arguments: encoding (`rgb`, `yuyv`, `mjpeg:QUALITY`), width, height, frames,
//! optionally `idle` for no-contact frames or `decode` to decode the frames and nothing
//! else (the decoder's share).

use vistaf_firmware::service::wire::summary_of;
use vistaf_hardware::decode::Decoded;
use vistaf_hardware::encode::Encoding;
use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::input::decode_scale;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation};
use vistaf_protocol::{encode, DeviceMsg};
use vistaf_sim::{scene, Renderer, SensorUnit, SkinState};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let encoding: Encoding = args.get(1).map_or("rgb", String::as_str).parse()?;
    let w: u32 = args.get(2).map_or(Ok(640), |s| s.parse())?;
    let h: u32 = args.get(3).map_or(Ok(480), |s| s.parse())?;
    let n: usize = args.get(4).map_or(Ok(1), |s| s.parse())?;
    let idle = args.get(5).is_some_and(|s| s == "idle");
    let decode_only = args.get(5).is_some_and(|s| s == "decode");
    let reference_unit = SensorUnit::reference();
    let unit = SensorUnit {
        width_px: w,
        height_px: h,
        period_px: reference_unit.period_px * w as f32 / reference_unit.width_px as f32,
        ..reference_unit
    };
    let r = Renderer::new(unit.clone());
    let camera = |img: &image::RgbImage| encoding.frame(img);
    let (reference, _) = r.render(&SkinState::idle(scene::ROOM_C), 1);
    let state = if idle {
        SkinState::idle(scene::ROOM_C)
    } else {
        scene::states("sweep-depth", &unit, 5).ok_or("scene")?[3].clone()
    };
    let (pressed, truth) = r.render(&state, 2);
    let scale = decode_scale(w, h, f64::from(unit.period_px));
    let mut img = Decoded::default();
    camera(&reference)?.decode_into(scale, &mut img)?;
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    let a = Analyzer::new(
        &img,
        Calibration::default_sim(),
        Implementation::Fixed,
        opts,
    )?;
    let frame = camera(&pressed)?;
    let mm_per_px = a.mm_per_px();
    let mut scratch = vistaf_pipeline::Scratch::default();
    let mut link = vec![0u8; vistaf_protocol::frame::DEVICE_FRAME_MAX];
    let (mut peak, mut bytes) = (0.0, 0);
    for seq in 0..n {
        // As the device runs: the camera's buffer, decoded; the pipeline; the summary
        // framed for the link.
        frame.decode_into(scale, &mut img)?;
        if decode_only {
            continue;
        }
        let d = a.analyze_with(&img, &mut scratch)?;
        let summary = summary_of(&d, seq as u32, 0, 0, mm_per_px);
        bytes += encode(&DeviceMsg::Summary(summary), &mut link)?;
        peak += d.peak_depth_mm;
    }
    println!(
        "{encoding} {w}x{h} at 1/{scale}: {n} frames of {} bytes, mean peak {:.3} mm (truth {:.3} mm), {} link bytes",
        frame.data.len(),
        peak / n as f32,
        truth.peak_depth_mm,
        bytes
    );
    Ok(())
}
