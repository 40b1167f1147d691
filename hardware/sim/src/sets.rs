//! Simulated frame sets: scenes and calibration kits as `vistaf-frames/1` sets, with labels
//! and richer ground truth under extra keys.
//!
//! Extra keys per frame: `truth_depth_png` (16-bit PNG, µm), `truth_temperature_png`
//! (16-bit PNG, `(T + 50 °C) × 100`), `truth_force_n`, `shift_px`. Top level: `simulator`
//! (scene, seeds, and the unit's parameters, for tests only: a blind pipeline must not use
//! them).

use std::path::Path;

use image::{ImageBuffer, Luma};
use serde_json::{json, Value};

use crate::contact::{Contact, Indenter};
use crate::render::{Renderer, Truth};
use crate::scene::{self, center_mm, SPHERE_R_MM};
use crate::state::SkinState;
use crate::unit::{SensorUnit, GRATING_PERIOD_MM};
use vistaf_hardware::encode::Encoding;
use vistaf_hardware::frameset::{FrameEntry, FrameSet, FrameSetError, FrameSetWriter};

/// Offset of the 16-bit temperature encoding, °C.
pub const TRUTH_TEMP_OFFSET_C: f32 = 50.0;

/// Options for writing a simulated set.
#[derive(Debug, Clone)]
pub struct SetOptions {
    /// Write 16-bit truth maps beside each frame.
    pub truth_maps: bool,
    /// Base noise seed (frame i uses seed + i in [`write_states`]), recorded in the manifest.
    pub seed: u64,
    /// Unit seed, recorded in the manifest.
    pub unit_seed: u64,
    /// How frames are written: PNG, or as a camera sends them (YUYV, MJPEG at a quality).
    pub encoding: Encoding,
}

fn truth_png(
    dir: &Path,
    name: &str,
    w: u32,
    h: u32,
    values: impl Iterator<Item = u16>,
) -> Result<(), FrameSetError> {
    let path = dir.join(name);
    let img: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_raw(w, h, values.collect())
        .ok_or_else(|| FrameSetError::Image {
            path: path.clone(),
            detail: "truth map size".into(),
        })?;
    img.save(&path).map_err(|e| FrameSetError::Image {
        path,
        detail: e.to_string(),
    })
}

/// Labels of a frame from its state and truth.
fn labels(state: &SkinState, truth: &Truth) -> FrameEntry {
    let contact = truth.contact_px;
    let uniform = state.temperature.sources.is_empty();
    // The depth label is the commanded indentation (what a lab records), not the peak of
    // the pixel-sampled truth map (which the truth PNG carries).
    let nominal = state
        .contacts
        .iter()
        .map(|c| c.depth_mm)
        .fold(0.0f32, f32::max);
    FrameEntry {
        depth_mm: Some(f64::from(nominal)),
        force_n: Some(f64::from(truth.force_n)),
        temperature_c: truth
            .contact_temp_c
            .filter(|_| !uniform)
            .or(uniform.then_some(state.temperature.base_c))
            .map(f64::from),
        contact_x_px: contact.map(|c| f64::from(c.0)),
        contact_y_px: contact.map(|c| f64::from(c.1)),
        ..Default::default()
    }
}

/// Renders `states` with `unit` into a new set in `dir`: the reference idle at the first
/// state's temperature, with noise seed `opts.seed ^ 0xfeed`, and frame `i` with noise seed
/// `opts.seed + i`.
pub fn write_states(
    dir: &Path,
    name: &str,
    unit: &SensorUnit,
    states: &[SkinState],
    opts: &SetOptions,
    progress: impl FnMut(usize, usize),
) -> Result<FrameSet, FrameSetError> {
    let base = states
        .first()
        .map_or(scene::ROOM_C, |s| s.temperature.base_c);
    let frames: Vec<Render<'_>> = (0u64..)
        .zip(states)
        .map(|(i, state)| Render {
            state,
            noise_seed: opts.seed.wrapping_add(i),
        })
        .collect();
    let idle = SkinState::idle(base);
    let reference = Render {
        state: &idle,
        noise_seed: opts.seed ^ 0xfeed,
    };
    write_renders(dir, name, unit, reference, &frames, opts, progress)
}

/// A frame to render: the skin's state and the sensor noise's seed.
#[derive(Debug, Clone, Copy)]
pub struct Render<'s> {
    /// The skin's state.
    pub state: &'s SkinState,
    /// The sensor noise's seed ([`Renderer::render`]).
    pub noise_seed: u64,
}

/// Renders `reference` and `frames` with `unit` into a new set in `dir`, each with its own
/// noise seed: the frames another tool rendered in memory, written as it rendered them.
/// `opts.seed` is only recorded.
pub fn write_renders(
    dir: &Path,
    name: &str,
    unit: &SensorUnit,
    reference: Render<'_>,
    frames: &[Render<'_>],
    opts: &SetOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<FrameSet, FrameSetError> {
    let r = Renderer::new(unit.clone());
    let base = reference.state.temperature.base_c;
    let (reference, _) = r.render(reference.state, reference.noise_seed);
    let mut w =
        FrameSetWriter::encoded(dir, f64::from(GRATING_PERIOD_MM), &reference, opts.encoding)?;
    w.extra_mut().insert(
        "simulator".into(),
        json!({
            "scene": name,
            "seed": opts.seed,
            "unit_seed": opts.unit_seed,
            "reference_temperature_c": base,
            "encoding": opts.encoding.to_string(),
            "unit": unit_json(unit),
        }),
    );
    if opts.truth_maps {
        std::fs::create_dir_all(dir.join("truth")).map_err(|cause| FrameSetError::Io {
            path: dir.join("truth"),
            cause,
        })?;
    }
    for (i, frame) in frames.iter().enumerate() {
        let state = frame.state;
        let (img, truth) = r.render(state, frame.noise_seed);
        let mut entry = labels(state, &truth);
        entry.t_ms = Some(i as f64 * 1000.0 / 30.0);
        entry.extra.insert(
            "shift_px".into(),
            json!([state.shift_px.0, state.shift_px.1]),
        );
        if opts.truth_maps {
            let stem = w.next_name().trim_end_matches(".png").to_string();
            let (dn, tn) = (
                format!("truth/depth_{stem}.png"),
                format!("truth/temperature_{stem}.png"),
            );
            let (iw, ih) = (unit.width_px, unit.height_px);
            truth_png(
                dir,
                &dn,
                iw,
                ih,
                truth
                    .depth_mm
                    .iter()
                    .map(|d| (d * 1000.0).round().clamp(0.0, 65535.0) as u16),
            )?;
            truth_png(
                dir,
                &tn,
                iw,
                ih,
                truth.temperature_c.iter().map(|t| {
                    ((t + TRUTH_TEMP_OFFSET_C) * 100.0)
                        .round()
                        .clamp(0.0, 65535.0) as u16
                }),
            )?;
            entry.extra.insert("truth_depth_png".into(), dn.into());
            entry
                .extra
                .insert("truth_temperature_png".into(), tn.into());
        }
        w.add(&img, entry)?;
        progress(i + 1, frames.len());
    }
    w.finish()
}

/// The unit's parameters as JSON (truth for tests).
pub fn unit_json(u: &SensorUnit) -> Value {
    json!({
        "width_px": u.width_px, "height_px": u.height_px, "period_px": u.period_px,
        "tilt_deg": u.tilt_deg, "duty": u.duty, "edge_sharpness": u.edge_sharpness,
        "phase_gain_rad_per_mm": u.phase_gain_rad_per_mm,
        "phase_saturation_mm": u.phase_saturation_mm, "modulus_mpa": u.modulus_mpa,
        "blur_px": u.blur_px, "noise_dn": u.noise_dn, "mm_per_px": u.mm_per_px(),
    })
}

/// Depths of the depth calibration set, mm.
pub const KIT_DEPTHS_MM: [f32; 12] = [
    0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5,
];
/// Forces of the force calibration set, N.
pub const KIT_FORCES_N: [f32; 12] = [
    0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 15.0, 20.0, 25.0, 30.0,
];
/// Setpoints of the temperature calibration set, °C: dense in the coloured transition.
pub const KIT_TEMPS_C: [f32; 22] = [
    15.0, 17.5, 20.0, 22.0, 23.0, 24.0, 25.0, 26.0, 27.0, 28.0, 29.0, 30.0, 31.0, 32.0, 33.0, 34.0,
    35.0, 37.5, 40.0, 42.5, 45.0, 47.5,
];

/// Positions of calibration presses, as fractions of the field of view from its centre.
const KIT_OFFSETS: [(f32, f32); 2] = [(-0.12, -0.08), (0.1, 0.1)];

/// The calibration sphere pressed to `depth_mm` at the `k`-th of the kit's positions
/// (they alternate), the skin at room temperature.
pub fn press(unit: &SensorUnit, k: usize, depth_mm: f32) -> SkinState {
    let c = center_mm(unit);
    let (fw, fh) = (
        unit.width_px as f32 * unit.mm_per_px(),
        unit.height_px as f32 * unit.mm_per_px(),
    );
    let (ox, oy) = KIT_OFFSETS[k % KIT_OFFSETS.len()];
    let mut s = SkinState::idle(scene::ROOM_C);
    s.contacts.push(Contact {
        indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
        center_mm: (c.0 + ox * fw, c.1 + oy * fh),
        depth_mm,
    });
    s
}

/// The scripted states of the three calibration sets: known depths and known forces with
/// the 10 mm sphere at two positions each, and uniform temperature setpoints (two frames
/// each, no contact).
pub fn kit_states(unit: &SensorUnit) -> [Vec<SkinState>; 3] {
    let sphere = Indenter::Sphere { r_mm: SPHERE_R_MM };
    let depth: Vec<SkinState> = KIT_DEPTHS_MM
        .iter()
        .flat_map(|&d| (0..KIT_OFFSETS.len()).map(move |k| (k, d)))
        .map(|(k, d)| press(unit, k, d))
        .collect();
    let force: Vec<SkinState> = KIT_FORCES_N
        .iter()
        .flat_map(|&f| (0..KIT_OFFSETS.len()).map(move |k| (k, f)))
        .map(|(k, f)| press(unit, k, sphere.depth_for_force_mm(f, unit.modulus_mpa)))
        .collect();
    let temps: Vec<SkinState> = KIT_TEMPS_C
        .iter()
        .flat_map(|&t| [scene::uniform(t), scene::uniform(t)])
        .collect();
    [depth, force, temps]
}

/// The three sets a lab records to calibrate a unit: `depth/` (known depths), `force/`
/// (known forces with the 10 mm sphere), `temperature/` (uniform setpoints, no contact).
pub fn write_calibration_kit(
    dir: &Path,
    unit: &SensorUnit,
    opts: &SetOptions,
    mut progress: impl FnMut(&str, usize, usize),
) -> Result<[FrameSet; 3], FrameSetError> {
    let [depth, force, temps] = kit_states(unit);
    let d = write_states(
        &dir.join("depth"),
        "kit-depth",
        unit,
        &depth,
        opts,
        |i, n| progress("depth", i, n),
    )?;
    let f = write_states(
        &dir.join("force"),
        "kit-force",
        unit,
        &force,
        &SetOptions {
            seed: opts.seed.wrapping_add(1000),
            ..opts.clone()
        },
        |i, n| progress("force", i, n),
    )?;
    let mut t_opts = opts.clone();
    t_opts.seed = opts.seed.wrapping_add(2000);
    let t = write_states(
        &dir.join("temperature"),
        "kit-temperature",
        unit,
        &temps,
        &t_opts,
        |i, n| progress("temperature", i, n),
    )?;
    Ok([d, f, t])
}
