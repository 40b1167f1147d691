//! The accuracy battery: units drawn wide ([`SensorUnit::wide`]), each calibrated on its own
//! kit (the 10 mm sphere, uniform temperatures) and measured blind on scenes the kit never
//! showed: the calibration sphere anywhere in view, other spheres, flat cylinders, letter
//! punches, heated presses, presses at other skin temperatures, presses whose contact
//! reaches the edge of the view or runs past it (as objects meet a palm's edge), uniform
//! skins, and the heat a warm object leaves with nothing pressed, with exposure and white
//! balance drifting from frame to frame.
//!
//! Every frame is scored against its truth. A quantity beyond its tolerance is a *failure*;
//! a failure without any flag is a *silent failure*, the one a robot cannot guard against.
//! Tolerances: peak depth 3 % + 0.02 mm; contact centre 1.5 mm; force 8 % + 0.3 N for the
//! calibration sphere wholly in view and 25 % + 0.3 N for other indenters and for presses
//! at the edge (0.3 N for a contact reported where nothing is pressed); temperature 1 °C
//! (contact and skin mean), and a skin's hottest and coldest places (`temp_max_c`,
//! `temp_min_c`) within 1.5 °C of the truth's hottest and coldest points. A press of 0.2 mm
//! or more reported as no contact is *missed*; a contact reported more than 3 mm from any
//! press (or on an untouched skin) is a *phantom*.

use std::path::Path;

use vistaf_calibrate::{calibrate, Quiet};
use vistaf_hardware::decode::Decoded;
use vistaf_hardware::encode::Encoding;
use vistaf_hardware::frameset::{FrameSet, FrameSetError};
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Measurement};
use vistaf_protocol::{Flag, QualityFlags, Reading};
use vistaf_sim::contact::{Contact, Footprint, Indenter};
use vistaf_sim::rng::Rng;
use vistaf_sim::scene::{ROOM_C, SPHERE_R_MM};
use vistaf_sim::sets::{write_calibration_kit, write_renders, Render, SetOptions};
use vistaf_sim::thermal::HeatSource;
use vistaf_sim::{Renderer, SensorUnit, SkinState, Truth};

/// What a scene presses with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// The calibration sphere.
    CalibrationSphere,
    /// A sphere of another radius.
    OtherSphere,
    /// A flat cylinder.
    Cylinder,
    /// A letter-shaped punch.
    Letter,
    /// A sphere hotter than the skin.
    Heated,
    /// The calibration sphere at the skin's temperature, the skin not at room temperature.
    SkinWarm,
    /// A sphere or a flat cylinder whose contact reaches the edge of the view or runs past
    /// it, as a palm's edge meets an object.
    AtEdge,
    /// No contact, a uniform skin.
    Uniform,
    /// No contact, the heat a warm object leaves where it pressed (lifted off, or resting
    /// without weight): the pigment clears as under a heated press, and nothing is pressed.
    HeatPrint,
}

impl Kind {
    /// Name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Kind::CalibrationSphere => "calibration sphere",
            Kind::OtherSphere => "other spheres",
            Kind::Cylinder => "flat cylinders",
            Kind::Letter => "letter punches",
            Kind::Heated => "heated sphere",
            Kind::SkinWarm => "sphere at skin temperature",
            Kind::AtEdge => "press at the edge",
            Kind::Uniform => "uniform skin",
            Kind::HeatPrint => "heat without a press",
        }
    }
}

/// The names a frame's failures go by ([`Scored::failures`]), one per quantity scored; the
/// tolerances are the scoring's (`score`, `score_temperature`).
pub mod failure {
    /// The peak depth beyond its tolerance.
    pub const DEPTH: &str = "depth";
    /// The force beyond its tolerance (tighter for the calibrated sphere).
    pub const FORCE: &str = "force";
    /// The contact's centre beyond its tolerance.
    pub const CENTRE: &str = "centre";
    /// A press deep enough to be seen reported as no contact.
    pub const MISSED: &str = "missed";
    /// A contact reported away from every press.
    pub const PHANTOM: &str = "phantom";
    /// No temperature read.
    pub const NO_TEMPERATURE: &str = "no temperature";
    /// The contact temperature beyond its tolerance.
    pub const CONTACT_TEMPERATURE: &str = "contact temperature";
    /// A skin at one temperature read beyond the tolerance on average.
    pub const MEAN_TEMPERATURE: &str = "mean temperature";
    /// The hottest place beyond the tolerance above the truth's hottest point.
    pub const HOTTEST_BLOCK: &str = "hottest block";
    /// The coldest place beyond the tolerance below the truth's coldest point.
    pub const COLDEST_BLOCK: &str = "coldest block";

    use vistaf_protocol::Reading;

    /// The summary's reading a failure of `name` is one of: a press missed or a contact
    /// reported away from every press is the contact's failure, its centre too; every
    /// other failure is of the skin's temperatures.
    pub fn reading(name: &str) -> Reading {
        match name {
            DEPTH => Reading::PeakDepth,
            FORCE => Reading::Force,
            CENTRE | MISSED | PHANTOM => Reading::Contact,
            CONTACT_TEMPERATURE => Reading::ContactTemperature,
            // NO_TEMPERATURE, MEAN_TEMPERATURE, HOTTEST_BLOCK, COLDEST_BLOCK.
            _ => Reading::Temperature,
        }
    }
}

/// One scored frame.
#[derive(Debug, Clone)]
pub struct Scored {
    /// Unit seed.
    pub unit: u64,
    /// Scene kind.
    pub kind: Kind,
    /// The indenter and its size (`sphere R5`, `disc r3`, `punch 10 mm` for a footprint of that
    /// extent such as a letter; `none`).
    pub indenter: String,
    /// True peak depth, mm.
    pub depth_mm: f32,
    /// How far inside the view the contact's rim lies at its nearest edge, mm (negative:
    /// the contact runs past the edge; a letter's rim is its bounding circle; None without
    /// a press).
    pub rim_inside_mm: Option<f32>,
    /// Peak depth error, mm (None without a press).
    pub depth_err_mm: Option<f32>,
    /// Centre error, mm.
    pub centre_err_mm: Option<f32>,
    /// Force error, N, and the true force (0 for a contact reported where nothing is
    /// pressed).
    pub force_err_n: Option<(f32, f32)>,
    /// Contact temperature error, °C.
    pub contact_temp_err_c: Option<f32>,
    /// Skin mean temperature error, °C (wherever the skin is at one temperature).
    pub mean_temp_err_c: Option<f32>,
    /// The contact temperature's standard deviation as the pipeline states it, °C.
    pub contact_temp_sigma_c: Option<f32>,
    /// The true contact temperature (the mean over the contact's disc), °C.
    pub contact_temp_c: Option<f32>,
    /// The skin's temperature away from any source, °C (wherever a temperature was read).
    pub skin_temp_c: Option<f32>,
    /// Hottest block above the truth's hottest point, °C.
    pub max_temp_excess_c: Option<f32>,
    /// Coldest block below the truth's coldest point, °C.
    pub min_temp_deficit_c: Option<f32>,
    /// Hottest minus coldest block on a skin at one temperature (untouched, or pressed at
    /// that temperature), °C.
    pub uniform_spread_c: Option<f32>,
    /// A press deep enough to be seen reported as no contact.
    pub missed: bool,
    /// A contact reported away from every press.
    pub phantom: bool,
    /// Which quantities failed their tolerance ([`failure`]).
    pub failures: Vec<&'static str>,
    /// Flags raised.
    pub flags: Vec<&'static str>,
    /// The frame's phase noise as the pipeline measured it, rad.
    pub noise_rad: f32,
    /// The contact's shape as the pipeline read it (`unknown` without a contact).
    pub shape: &'static str,
}

impl Scored {
    /// A failure no flag warned of.
    pub fn silent(&self) -> bool {
        !self.failures.is_empty() && self.flags.is_empty()
    }

    /// Whether `reading` failed its tolerance.
    pub fn failed(&self, reading: Reading) -> bool {
        self.failures.iter().any(|f| failure::reading(f) == reading)
    }

    /// Whether a raised flag concerns `reading` ([`Flag::concerns`]).
    pub fn flagged(&self, reading: Reading) -> bool {
        let set: QualityFlags = self
            .flags
            .iter()
            .filter_map(|n| Flag::from_name(n))
            .collect();
        !set.trusts(reading)
    }

    /// A failure of `reading` that no flag speaking for it warned of: silent to a robot
    /// that reads each reading with the flags that concern it, even where a flag about
    /// another reading was raised.
    pub fn silent_in(&self, reading: Reading) -> bool {
        self.failed(reading) && !self.flagged(reading)
    }
}

/// A unit that could not be calibrated, and why.
#[derive(Debug, Clone)]
pub struct Refused {
    /// Unit seed.
    pub unit: u64,
    /// The calibration's error.
    pub why: String,
}

/// The effect [`without`] reads as the layer's decay set to `decay_mm` (mm; infinite: a
/// half-space), for units whose surface returns to rest more slowly than drawn.
pub fn layer_decay(decay_mm: f32) -> String {
    format!("layer={decay_mm}")
}

/// Effects [`without`] can switch off, to find which one a failure needs.
pub const EFFECTS: [&str; 14] = [
    "oblique",
    "glare",
    "vignetting",
    "white-balance",
    "mottle",
    "wobble",
    "distortion",
    "phase-shape",
    "jpeg",
    "chromatic",
    "drift",
    "shading",
    "stripe-edges",
    "layer",
];

/// `unit` with the named effects switched off (names from [`EFFECTS`]; `drift` is the
/// per-frame exposure and white balance, applied in the scenes). `layer=D` sets the
/// layer's decay to `D` mm instead ([`layer_decay`]).
pub fn without(mut unit: SensorUnit, effects: &[String]) -> SensorUnit {
    let i = &mut unit.imperfections;
    for e in effects {
        if let Some(decay_mm) = e.strip_prefix("layer=").and_then(|d| d.parse().ok()) {
            unit.layer_decay_mm = decay_mm;
            continue;
        }
        match e.as_str() {
            "oblique" => i.oblique_gain = 0.0,
            "glare" => i.glare.clear(),
            "vignetting" => i.vignetting_offset = (0.0, 0.0),
            "white-balance" => i.white_balance = [1.0; 3],
            "mottle" => i.mottle = 0.0,
            "wobble" => i.wobble_rad = 0.0,
            "distortion" => i.distortion = 0.0,
            "phase-shape" => i.phase_shape = 0.0,
            "jpeg" => i.jpeg_quality = None,
            "chromatic" => i.chromatic = [0.0; 2],
            "shading" => unit.shading_gain = 0.0,
            "stripe-edges" => unit.edge_sharpness = unit.edge_sharpness.min(0.8),
            "layer" => unit.layer_decay_mm = f32::INFINITY,
            _ => {}
        }
    }
    unit
}

/// The camera the battery's units send their frames from: an encoding, and optionally
/// another image size behind the same optics (the grating's period in pixels scaled with
/// the width, so the field of view is the unit's).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Camera {
    /// How frames are sent.
    pub encoding: Encoding,
    /// Image size, pixels (`None`: the unit's own).
    pub size: Option<(u32, u32)>,
}

impl std::str::FromStr for Camera {
    type Err = String;
    /// `ENCODING[@WxH]`: `rgb`, `yuyv@640x480`, `mjpeg:90@1920x1080`.
    fn from_str(s: &str) -> Result<Camera, String> {
        let (enc, size) = s.split_once('@').map_or((s, None), |(e, z)| (e, Some(z)));
        let encoding = enc.parse()?;
        let size = size
            .map(|z| {
                let (w, h) = z
                    .split_once('x')
                    .ok_or_else(|| format!("camera size {z:?}: expected WxH"))?;
                let n = |v: &str| {
                    v.parse::<u32>()
                        .map_err(|e| format!("camera size {z:?}: {e}"))
                };
                Ok::<_, String>((n(w)?, n(h)?))
            })
            .transpose()?;
        Ok(Camera { encoding, size })
    }
}

impl std::fmt::Display for Camera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.encoding)?;
        if let Some((w, h)) = self.size {
            write!(f, "@{w}x{h}")?;
        }
        Ok(())
    }
}

impl Camera {
    /// `unit` behind this camera.
    pub fn unit(&self, mut unit: SensorUnit) -> SensorUnit {
        if let Some((w, h)) = self.size {
            unit.period_px *= w as f32 / unit.width_px as f32;
            unit.width_px = w;
            unit.height_px = h;
        }
        unit
    }
}

/// Calibrates unit `seed` on its kit (in `work`, removed afterwards) and scores its scenes,
/// with the named effects switched off (none for the battery), its frames sent by `camera`
/// (kit and scenes alike) and decoded as the device decodes them.
pub fn run_unit(
    seed: u64,
    work: &Path,
    off: &[String],
    camera: Camera,
) -> Result<Vec<Scored>, Refused> {
    let unit = camera.unit(without(SensorUnit::wide(seed), off));
    let refused = |why: String| Refused { unit: seed, why };
    let dir = work.join(format!("unit-{seed}"));
    let opts = kit_options(seed, camera, false);
    let sets = write_calibration_kit(&dir, &unit, &opts, |_, _, _| {})
        .map_err(|e| refused(format!("kit: {e}")))?;
    let calib = calibrate(&sets, Implementation::Fixed, &mut Quiet);
    let _ = std::fs::remove_dir_all(&dir);
    let calib = calib.map_err(|e| refused(format!("{e:#}")))?;
    let r = Renderer::new(unit.clone());
    let scale = calib.unit.scale_for(unit.width_px, unit.height_px);
    let decode = |img: &image::RgbImage, out: &mut Decoded| {
        camera
            .encoding
            .frame(img)
            .and_then(|f| f.decode_into(scale, out).map_err(|e| e.to_string()))
    };
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), reference_noise_seed(seed));
    let mut frame = Decoded::default();
    decode(&reference, &mut frame).map_err(|e| refused(format!("reference: {e}")))?;
    let a = Analyzer::new(
        &frame,
        calib,
        Implementation::Fixed,
        AnalyzerOptions::default(),
    )
    .map_err(|e| refused(format!("reference: {e}")))?;
    let mut out = Vec::new();
    for (k, (kind, state)) in unit_scenes(seed, &unit, off).into_iter().enumerate() {
        let (img, truth) = r.render(&state, scene_noise_seed(seed, k));
        decode(&img, &mut frame).map_err(|e| refused(format!("frame {k}: {e}")))?;
        match a.analyze(&frame) {
            Ok(mut m) => {
                // Positions in the camera's pixels, as the truth gives them.
                m.centroid_px = m
                    .centroid_px
                    .map(|(x, y)| (x * scale as f32, y * scale as f32));
                out.push(score(seed, kind, &unit, &state, &truth, &m))
            }
            Err(e) => return Err(refused(format!("frame {k}: {e}"))),
        }
    }
    Ok(out)
}

/// The options unit `seed`'s kit is written with (its noise seeds and the camera's
/// encoding), with truth maps beside the frames or without.
pub fn kit_options(seed: u64, camera: Camera, truth_maps: bool) -> SetOptions {
    SetOptions {
        truth_maps,
        seed: seed.wrapping_mul(7),
        unit_seed: seed,
        encoding: camera.encoding,
    }
}

/// The noise seed of unit `seed`'s reference (idle at [`ROOM_C`]).
fn reference_noise_seed(seed: u64) -> u64 {
    seed ^ 0x5eed
}

/// The noise seed of unit `seed`'s scene `k`.
fn scene_noise_seed(seed: u64, k: usize) -> u64 {
    seed.wrapping_mul(1000).wrapping_add(k as u64)
}

/// Writes unit `seed`'s scenes (drawn as `unit`, with the named effects switched off) into
/// `dir` as a frame set, reference and noise as [`run_unit`] renders them: analysed with
/// the calibration of the kit [`kit_options`] writes, each frame reads as the battery
/// scored it.
pub fn write_scenes(
    dir: &Path,
    seed: u64,
    unit: &SensorUnit,
    off: &[String],
    opts: &SetOptions,
) -> Result<FrameSet, FrameSetError> {
    let scenes = unit_scenes(seed, unit, off);
    let frames: Vec<Render<'_>> = scenes
        .iter()
        .enumerate()
        .map(|(k, (_, state))| Render {
            state,
            noise_seed: scene_noise_seed(seed, k),
        })
        .collect();
    let idle = SkinState::idle(ROOM_C);
    let reference = Render {
        state: &idle,
        noise_seed: reference_noise_seed(seed),
    };
    write_renders(
        dir,
        "accuracy scenes",
        unit,
        reference,
        &frames,
        opts,
        |_, _| {},
    )
}

/// The scenes unit `seed` (drawn as `unit`) is scored on, with the named effects switched
/// off: the battery's, for a closer look at one unit's frames.
pub fn unit_scenes(seed: u64, unit: &SensorUnit, off: &[String]) -> Vec<(Kind, SkinState)> {
    let drifts = !off.iter().any(|e| e == "drift");
    let mut rng = Rng::derive(seed, "accuracy scenes");
    let mut v = scenes(unit, &mut rng);
    // Drawn either way, so an ablation sees the same scenes.
    if !drifts {
        for (_, state) in &mut v {
            state.exposure_scale = 1.0;
            state.white_balance = [1.0; 3];
        }
    }
    v
}

/// The scenes of one unit.
fn scenes(unit: &SensorUnit, rng: &mut Rng) -> Vec<(Kind, SkinState)> {
    let mut v = Vec::new();
    let cal = Indenter::Sphere { r_mm: SPHERE_R_MM };
    for _ in 0..8 {
        let d = rng.range(0.15, 2.4) as f32;
        v.push((Kind::CalibrationSphere, pressed(unit, rng, cal.clone(), d)));
    }
    for _ in 0..3 {
        let r_mm = [2.5f32, 5.0, 7.5, 15.0, 20.0][(rng.next_u64() % 5) as usize];
        let d = rng.range(0.15, 1.5) as f32;
        v.push((
            Kind::OtherSphere,
            pressed(unit, rng, Indenter::Sphere { r_mm }, d),
        ));
    }
    for _ in 0..3 {
        let r_mm = [2.0f32, 3.0, 4.0, 6.0][(rng.next_u64() % 4) as usize];
        let d = rng.range(0.15, 1.0) as f32;
        let fp = Footprint::Disc { r_mm };
        v.push((Kind::Cylinder, pressed(unit, rng, Indenter::Punch(fp), d)));
    }
    for _ in 0..2 {
        let h = [8.0f32, 10.0, 12.0][(rng.next_u64() % 3) as usize];
        let fp = match rng.next_u64() % 3 {
            0 => Footprint::letter_e(h),
            1 => Footprint::letter_p(h),
            _ => Footprint::letter_f(h),
        };
        let d = rng.range(0.15, 0.8) as f32;
        v.push((Kind::Letter, pressed(unit, rng, Indenter::Punch(fp), d)));
    }
    for _ in 0..3 {
        let d = rng.range(0.3, 2.0) as f32;
        let mut s = pressed(unit, rng, cal.clone(), d);
        let heat = HeatSource::under(&s.contacts[0], rng.range(30.0, 45.0) as f32, 2.0);
        s.temperature.sources.push(heat);
        v.push((Kind::Heated, s));
    }
    for _ in 0..2 {
        let d = rng.range(0.3, 2.0) as f32;
        let mut s = pressed(unit, rng, cal.clone(), d);
        s.temperature.base_c = rng.range(20.0, 34.0) as f32;
        v.push((Kind::SkinWarm, s));
    }
    for _ in 0..3 {
        let mut s = SkinState::idle(rng.range(16.0, 45.0) as f32);
        drift(&mut s, rng);
        v.push((Kind::Uniform, s));
    }
    // Drawn after every other kind: each kind's draws stay the same whatever follows it.
    let d = rng.range(0.3, 2.0) as f32;
    v.push((Kind::AtEdge, at_edge(unit, rng, cal, d)));
    let other = match rng.next_u64() % 4 {
        0 => Indenter::Sphere { r_mm: 5.0 },
        1 => Indenter::Sphere { r_mm: 20.0 },
        k => Indenter::Punch(Footprint::Disc {
            r_mm: 1.0 + k as f32,
        }),
    };
    let d = rng.range(0.2, 1.0) as f32;
    v.push((Kind::AtEdge, at_edge(unit, rng, other, d)));
    v.push((Kind::HeatPrint, heat_print(unit, rng)));
    v
}

/// The heat a warm sphere leaves where it pressed 0.3–2 mm, at a random place wholly in
/// view, with no press: what the skin shows just after the object is lifted off.
fn heat_print(unit: &SensorUnit, rng: &mut Rng) -> SkinState {
    let d = rng.range(0.3, 2.0) as f32;
    let r_mm = [5.0f32, 10.0, 20.0][(rng.next_u64() % 3) as usize];
    let mut s = pressed(unit, rng, Indenter::Sphere { r_mm }, d);
    let lifted = s.contacts.remove(0);
    let heat = HeatSource::under(&lifted, rng.range(33.0, 45.0) as f32, 2.0);
    s.temperature.sources.push(heat);
    s
}

/// The radius within which the skin touches the indenter, mm: Hertz's for a sphere, the
/// footprint's bounding circle for a punch.
fn contact_reach_mm(indenter: &Indenter, depth_mm: f32) -> f32 {
    match indenter {
        Indenter::Sphere { r_mm } => (r_mm * depth_mm).sqrt(),
        Indenter::Punch(Footprint::Disc { r_mm }) => *r_mm,
        Indenter::Punch(fp) => fp.bound_mm() * std::f32::consts::SQRT_2,
    }
}

/// A press whose contact's rim lies at a random edge of the view, from 1 mm inside it to
/// past it by up to 0.6 of the contact's radius (the centre always in view).
fn at_edge(unit: &SensorUnit, rng: &mut Rng, indenter: Indenter, depth_mm: f32) -> SkinState {
    let (fw, fh) = unit.view_mm();
    let a = contact_reach_mm(&indenter, depth_mm);
    let from_edge = a + rng.range(-0.6 * f64::from(a), 1.0) as f32;
    let centre = match rng.next_u64() % 4 {
        0 => (from_edge, within(rng, fh, a + 1.0)),
        1 => (fw - from_edge, within(rng, fh, a + 1.0)),
        2 => (within(rng, fw, a + 1.0), from_edge),
        _ => (within(rng, fw, a + 1.0), fh - from_edge),
    };
    press_at(rng, indenter, centre, depth_mm)
}

/// How far inside the view the first contact's rim lies at its nearest edge, mm.
fn rim_inside_mm(unit: &SensorUnit, state: &SkinState) -> Option<f32> {
    let c = state.contacts.first()?;
    let (fw, fh) = unit.view_mm();
    let (x, y) = c.center_mm;
    let nearest = x.min(fw - x).min(y).min(fh - y);
    Some(nearest - contact_reach_mm(&c.indenter, c.depth_mm))
}

/// A press at a random place where its contact lies wholly in view.
fn pressed(unit: &SensorUnit, rng: &mut Rng, indenter: Indenter, depth_mm: f32) -> SkinState {
    let (fw, fh) = unit.view_mm();
    let reach = match &indenter {
        Indenter::Punch(fp) => fp.bound_mm() * std::f32::consts::SQRT_2,
        sphere => contact_reach_mm(sphere, depth_mm),
    } + 1.0;
    let centre = (within(rng, fw, reach), within(rng, fh, reach));
    press_at(rng, indenter, centre, depth_mm)
}

/// A random place along a span `span_mm` long, `margin_mm` or more from both ends (at most
/// 0.45 of the span, so a short span still leaves room).
fn within(rng: &mut Rng, span_mm: f32, margin_mm: f32) -> f32 {
    let m = margin_mm.min(0.45 * span_mm);
    rng.range(f64::from(m), f64::from(span_mm - m)) as f32
}

/// `indenter` pressed `depth_mm` at `centre_mm` on a skin at room temperature, the light
/// drifting ([`drift`]).
fn press_at(rng: &mut Rng, indenter: Indenter, centre_mm: (f32, f32), depth_mm: f32) -> SkinState {
    let mut s = SkinState::idle(ROOM_C);
    s.contacts.push(Contact {
        indenter,
        center_mm: centre_mm,
        depth_mm,
    });
    drift(&mut s, rng);
    s
}

/// Exposure within ±6 % and white balance within ±4 % of the reference's.
fn drift(s: &mut SkinState, rng: &mut Rng) {
    s.exposure_scale = rng.range(0.94, 1.06) as f32;
    s.white_balance = [
        rng.range(0.96, 1.04) as f32,
        1.0,
        rng.range(0.96, 1.04) as f32,
    ];
}

fn score(
    seed: u64,
    kind: Kind,
    unit: &SensorUnit,
    state: &SkinState,
    truth: &Truth,
    m: &Measurement,
) -> Scored {
    let mmpp = unit.mm_per_px();
    let mut s = Scored {
        unit: seed,
        kind,
        indenter: indenter_label(state),
        depth_mm: truth.peak_depth_mm,
        rim_inside_mm: rim_inside_mm(unit, state),
        depth_err_mm: None,
        centre_err_mm: None,
        force_err_n: None,
        contact_temp_err_c: None,
        contact_temp_sigma_c: None,
        contact_temp_c: None,
        skin_temp_c: None,
        mean_temp_err_c: None,
        max_temp_excess_c: None,
        min_temp_deficit_c: None,
        uniform_spread_c: None,
        missed: false,
        phantom: false,
        failures: Vec::new(),
        flags: m.flags.iter().map(|f| f.name()).collect(),
        noise_rad: m.noise_rad,
        shape: m.shape.name(),
    };
    let pressed = truth.peak_depth_mm > 0.0;
    if pressed {
        let e = m.peak_depth_mm - truth.peak_depth_mm;
        s.depth_err_mm = Some(e);
        if e.abs() > 0.03 * truth.peak_depth_mm + 0.02 {
            s.failures.push(failure::DEPTH);
        }
        s.missed = truth.peak_depth_mm >= 0.2 && !m.contact;
        let f = truth.force_n;
        s.force_err_n = Some((m.force_n - f, f));
        let rel = if kind == Kind::CalibrationSphere {
            0.08
        } else {
            0.25
        };
        if (m.force_n - f).abs() > rel * f + 0.3 {
            s.failures.push(failure::FORCE);
        }
    } else if m.contact {
        // Nothing pressed: a contact's force is all error, within the tolerance's floor.
        s.force_err_n = Some((m.force_n, 0.0));
        if m.force_n.abs() > 0.3 {
            s.failures.push(failure::FORCE);
        }
    }
    if let (Some(t), Some(c)) = (truth.contact_px, m.centroid_px) {
        let e = (c.0 - t.0).hypot(c.1 - t.1) * mmpp;
        s.centre_err_mm = Some(e);
        s.phantom = e > 3.0;
        if e > 1.5 {
            s.failures.push(failure::CENTRE);
        }
    } else if !pressed && m.contact {
        s.phantom = true;
    }
    if s.missed {
        s.failures.push(failure::MISSED);
    }
    if s.phantom {
        s.failures.push(failure::PHANTOM);
    }
    score_temperature(&mut s, state, truth, m);
    s
}

/// The scene's indenter and its size, for per-frame tables.
fn indenter_label(state: &SkinState) -> String {
    match state.contacts.first().map(|c| &c.indenter) {
        None => "none".into(),
        Some(Indenter::Sphere { r_mm }) => format!("sphere R{r_mm}"),
        Some(Indenter::Punch(Footprint::Disc { r_mm })) => format!("disc r{r_mm}"),
        Some(Indenter::Punch(fp)) => format!("punch {:.0} mm", 2.0 * fp.bound_mm()),
    }
}

/// Every scored frame as CSV, one row per frame (errors empty where not measured).
pub fn frames_csv(results: &[UnitResult]) -> String {
    use std::fmt::Write as _;
    let opt = |v: Option<f32>| v.map(|v| format!("{v:.4}")).unwrap_or_default();
    let mut s = String::from(
        "unit,kind,indenter,depth_mm,rim_inside_mm,depth_err_mm,force_err_n,force_n,centre_err_mm,\
         contact_temp_err_c,contact_temp_sigma_c,contact_temp_c,skin_temp_c,mean_temp_err_c,max_temp_excess_c,\
         min_temp_deficit_c,uniform_spread_c,failures,flags,noise_rad,shape\n",
    );
    for f in results.iter().flatten().flatten() {
        let _ = writeln!(
            s,
            "{},{},{},{:.4},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4},{}",
            f.unit,
            f.kind.name(),
            f.indenter,
            f.depth_mm,
            opt(f.rim_inside_mm),
            opt(f.depth_err_mm),
            opt(f.force_err_n.map(|e| e.0)),
            opt(f.force_err_n.map(|e| e.1)),
            opt(f.centre_err_mm),
            opt(f.contact_temp_err_c),
            opt(f.contact_temp_sigma_c),
            opt(f.contact_temp_c),
            opt(f.skin_temp_c),
            opt(f.mean_temp_err_c),
            opt(f.max_temp_excess_c),
            opt(f.min_temp_deficit_c),
            opt(f.uniform_spread_c),
            f.failures.join(" "),
            f.flags.join(" "),
            f.noise_rad,
            f.shape,
        );
    }
    s
}

fn score_temperature(s: &mut Scored, state: &SkinState, truth: &Truth, m: &Measurement) {
    let Some(t) = &m.temperature else {
        s.failures.push(failure::NO_TEMPERATURE);
        return;
    };
    s.skin_temp_c = Some(state.temperature.base_c);
    if let (Some(want), Some(got)) = (truth.contact_temp_c, t.contact_c) {
        let e = got - want;
        s.contact_temp_err_c = Some(e);
        s.contact_temp_sigma_c = t.contact_sigma_c;
        s.contact_temp_c = Some(want);
        if e.abs() > 1.0 {
            s.failures.push(failure::CONTACT_TEMPERATURE);
        }
    }
    let hottest = truth.temperature_c.iter().copied().fold(f32::MIN, f32::max);
    if state.temperature.sources.is_empty() {
        let e = t.mean_c - state.temperature.base_c;
        s.mean_temp_err_c = Some(e);
        if e.abs() > 1.0 || e.is_nan() {
            s.failures.push(failure::MEAN_TEMPERATURE);
        }
    }
    let excess = t.max_c - hottest;
    s.max_temp_excess_c = Some(excess);
    if excess > 1.5 || excess.is_nan() {
        s.failures.push(failure::HOTTEST_BLOCK);
    }
    let coldest = truth.temperature_c.iter().copied().fold(f32::MAX, f32::min);
    let deficit = coldest - t.min_c;
    s.min_temp_deficit_c = Some(deficit);
    if deficit > 1.5 || deficit.is_nan() {
        s.failures.push(failure::COLDEST_BLOCK);
    }
    if state.temperature.sources.is_empty() {
        s.uniform_spread_c = Some(t.max_c - t.min_c);
    }
}

/// Median, 95th percentile and worst of `v` (absolute values), or None when empty.
pub fn spread(v: impl IntoIterator<Item = f32>) -> Option<[f32; 3]> {
    let mut a: Vec<f32> = v
        .into_iter()
        .map(f32::abs)
        .filter(|x| x.is_finite())
        .collect();
    if a.is_empty() {
        return None;
    }
    a.sort_by(f32::total_cmp);
    let at = |q: f32| a[((q * (a.len() - 1) as f32).round() as usize).min(a.len() - 1)];
    Some([at(0.5), at(0.95), a[a.len() - 1]])
}

/// One unit's outcome.
pub type UnitResult = Result<Vec<Scored>, Refused>;

/// Units run on `jobs` threads; results in seed order.
pub fn run_units(
    seeds: &[u64],
    work: &Path,
    jobs: usize,
    off: &[String],
    camera: Camera,
    done: impl Fn(u64) + Sync,
) -> Vec<UnitResult> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let slots: Vec<std::sync::Mutex<Option<UnitResult>>> =
        seeds.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..jobs.max(1) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(&seed) = seeds.get(i) else { break };
                let r = run_unit(seed, work, off, camera);
                if let Ok(mut slot) = slots[i].lock() {
                    *slot = Some(r);
                }
                done(seed);
            });
        }
    });
    slots
        .into_iter()
        .filter_map(|m| m.into_inner().ok().flatten())
        .collect()
}

/// `name n` pairs of `names`, most frequent first (ties by name), comma-separated.
fn count_by<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let mut counts = std::collections::BTreeMap::new();
    for name in names {
        *counts.entry(name).or_insert(0usize) += 1;
    }
    let mut counts: Vec<(&str, usize)> = counts.into_iter().collect();
    // Stable: names of equal count stay in the map's order.
    counts.sort_by_key(|&(_, n)| std::cmp::Reverse(n));
    let pairs: Vec<String> = counts.iter().map(|(n, c)| format!("{n} {c}")).collect();
    pairs.join(", ")
}

/// One silent failure for the report: the unit, the scene, what failed, and the frame's
/// depth, force and centre errors, signed (reading minus truth), with each temperature
/// error that failed; quantities not scored are left out.
fn silent_line(f: &Scored) -> String {
    let failed = |name: &str| f.failures.contains(&name);
    let mut errs = Vec::new();
    if let Some(e) = f.depth_err_mm {
        errs.push(format!("depth {e:+.3} mm of {:.2} mm", f.depth_mm));
    }
    if let Some((e, t)) = f.force_err_n {
        errs.push(format!("force {e:+.2} N of {t:.2} N"));
    }
    if let Some(e) = f.centre_err_mm {
        errs.push(format!("centre {e:.2} mm off"));
    }
    let temperatures = [
        (failure::CONTACT_TEMPERATURE, f.contact_temp_err_c),
        (failure::MEAN_TEMPERATURE, f.mean_temp_err_c),
        (failure::HOTTEST_BLOCK, f.max_temp_excess_c),
        (failure::COLDEST_BLOCK, f.min_temp_deficit_c.map(|d| -d)),
    ];
    for (name, err) in temperatures {
        if let Some(e) = err.filter(|_| failed(name)) {
            errs.push(format!("{name} {e:+.2} °C"));
        }
    }
    let scene = match f.depth_err_mm {
        Some(_) => format!("{}, read as {}", f.indenter, f.shape),
        None => f.indenter.clone(),
    };
    format!(
        "unit {} {} ({scene}): {} failed; {}",
        f.unit,
        f.kind.name(),
        f.failures.join(", "),
        errs.join(", ")
    )
}

/// The report's section by reading: per reading of the summary, its failures, those no
/// flag concerning it warned of ([`Scored::silent_in`]) and the frames whose flags doubted
/// it where it held; then the frames a flag about another reading alone excused.
fn by_reading(frames: &[&Scored]) -> String {
    use std::fmt::Write as _;
    let mut s = String::from(
        "\n### By reading\n\nEach reading judged by the flags that concern it \
         (`Flag::concerns`), as a robot reading it alone would: a depth failure under \
         `temperature_uncertain` alone is silent here.\n\n\
         | reading | failures | silent | flagged without failure |\n|---|---:|---:|---:|\n",
    );
    for r in Reading::ALL {
        let failed = frames.iter().filter(|f| f.failed(r)).count();
        let silent = frames.iter().filter(|f| f.silent_in(r)).count();
        let doubted = frames
            .iter()
            .filter(|f| !f.failed(r) && f.flagged(r))
            .count();
        let _ = writeln!(
            s,
            "| {} | {failed} | {silent} | {doubted} ({:.1} %) |",
            r.name(),
            100.0 * doubted as f64 / frames.len().max(1) as f64
        );
    }
    let excused: Vec<&&Scored> = frames
        .iter()
        .filter(|f| !f.silent() && Reading::ALL.into_iter().any(|r| f.silent_in(r)))
        .collect();
    let _ = writeln!(
        s,
        "\nFailures only a flag about another reading excused ({}):\n",
        excused.len()
    );
    for f in excused {
        let _ = writeln!(s, "- {}; flags: {}", silent_line(f), f.flags.join(", "));
    }
    s
}

/// The battery's report as Markdown: per scene kind, the error spread and the failures,
/// silent ones first; then the silent failures, counted by indenter and each by name.
pub fn report(results: &[UnitResult]) -> String {
    use std::fmt::Write as _;
    let frames: Vec<&Scored> = results.iter().flatten().flatten().collect();
    let refused: Vec<&Refused> = results.iter().filter_map(|r| r.as_ref().err()).collect();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} units, {} frames; {} units refused calibration.\n",
        results.len(),
        frames.len(),
        refused.len()
    );
    let _ = writeln!(
        s,
        "| scenes | frames | silent failures | flagged failures | missed | phantom | flagged without failure | depth err mm (median / p95 / worst) | force err % | centre err mm | contact temp err °C |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---|---|---|---|");
    let mut kinds: Vec<Kind> = frames.iter().map(|f| f.kind).collect();
    kinds.sort();
    kinds.dedup();
    for k in kinds {
        let of: Vec<&&Scored> = frames.iter().filter(|f| f.kind == k).collect();
        let fmt = |v: Option<[f32; 3]>, digits: usize| {
            v.map_or("–".into(), |[a, b, c]| {
                format!("{a:.digits$} / {b:.digits$} / {c:.digits$}")
            })
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            k.name(),
            of.len(),
            of.iter().filter(|f| f.silent()).count(),
            of.iter()
                .filter(|f| !f.failures.is_empty() && !f.silent())
                .count(),
            of.iter().filter(|f| f.missed).count(),
            of.iter().filter(|f| f.phantom).count(),
            of.iter()
                .filter(|f| f.failures.is_empty() && !f.flags.is_empty())
                .count(),
            fmt(spread(of.iter().filter_map(|f| f.depth_err_mm)), 3),
            fmt(
                spread(
                    of.iter()
                        .filter_map(|f| f.force_err_n.filter(|&(_, t)| t > 0.0))
                        .map(|(e, t)| 100.0 * e / t.max(0.1))
                ),
                1
            ),
            fmt(spread(of.iter().filter_map(|f| f.centre_err_mm)), 2),
            fmt(spread(of.iter().filter_map(|f| f.contact_temp_err_c)), 2),
        );
    }
    let uniform = spread(frames.iter().filter_map(|f| f.mean_temp_err_c));
    let excess: Vec<f32> = frames.iter().filter_map(|f| f.max_temp_excess_c).collect();
    if let Some([a, b, c]) = uniform {
        let _ = writeln!(
            s,
            "\nUniform skin mean temperature error, °C: median {a:.2}, p95 {b:.2}, worst {c:.2}."
        );
    }
    if let Some([a, b, c]) = spread(excess) {
        let _ = writeln!(
            s,
            "Hottest block above the truth's hottest point, °C (absolute): median {a:.2}, p95 {b:.2}, worst {c:.2}."
        );
    }
    if let Some([a, b, c]) = spread(frames.iter().filter_map(|f| f.min_temp_deficit_c)) {
        let _ = writeln!(
            s,
            "Coldest block below the truth's coldest point, °C (absolute): median {a:.2}, p95 {b:.2}, worst {c:.2}."
        );
    }
    if let Some([a, b, c]) = spread(frames.iter().filter_map(|f| f.uniform_spread_c)) {
        let _ = writeln!(
            s,
            "Hottest minus coldest block on a skin at one temperature (untouched, or pressed at that temperature), °C: median {a:.2}, p95 {b:.2}, worst {c:.2}."
        );
    }
    let false_flags: Vec<&&Scored> = frames
        .iter()
        .filter(|f| f.failures.is_empty() && !f.flags.is_empty())
        .collect();
    let named = count_by(false_flags.iter().flat_map(|f| f.flags.iter().copied()));
    let _ = writeln!(
        s,
        "Flagged without failure: {} of {} frames ({:.1} %){}{}.",
        false_flags.len(),
        frames.len(),
        100.0 * false_flags.len() as f64 / frames.len().max(1) as f64,
        if named.is_empty() { "" } else { ": " },
        named
    );
    let silent: Vec<&&Scored> = frames.iter().filter(|f| f.silent()).collect();
    let _ = writeln!(s, "\n### Silent failures ({})\n", silent.len());
    if !silent.is_empty() {
        let _ = writeln!(
            s,
            "By indenter: {}.\n",
            count_by(silent.iter().map(|f| f.indenter.as_str()))
        );
    }
    for f in silent {
        let _ = writeln!(s, "- {}", silent_line(f));
    }
    s.push_str(&by_reading(&frames));
    if !refused.is_empty() {
        let _ = writeln!(s, "\n### Units refused\n");
        for r in refused {
            let _ = writeln!(s, "- unit {}: {}", r.unit, r.why);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scenes a unit is scored on are drawn from its seed alone, and without `drift`
    /// they are the same scenes with the light held still.
    #[test]
    fn scenes_are_the_unit_s_own_and_drift_only_moves_the_light() {
        let unit = SensorUnit::wide(7);
        let drawn = unit_scenes(7, &unit, &[]);
        assert_eq!(drawn, unit_scenes(7, &unit, &[]));
        assert_ne!(drawn, unit_scenes(8, &unit, &[]));
        assert!(drawn.iter().any(|(_, s)| s.exposure_scale != 1.0));
        let still = unit_scenes(7, &unit, &["drift".to_string()]);
        assert_eq!(still.len(), drawn.len());
        for ((k0, s0), (k1, s1)) in drawn.iter().zip(&still) {
            assert_eq!(k0, k1);
            assert_eq!((s1.exposure_scale, s1.white_balance), (1.0, [1.0; 3]));
            assert_eq!(s0.contacts, s1.contacts);
        }
    }

    /// Every effect but the per-frame drift (switched off in the scenes) changes a unit
    /// that shows it, and leaves the unit as drawn when it is not named.
    #[test]
    fn each_effect_switches_off_what_it_names() {
        let shows_all = |u: &SensorUnit| {
            let i = &u.imperfections;
            !i.glare.is_empty() && i.jpeg_quality.is_some() && u.edge_sharpness > 0.8
        };
        let unit = (1..500)
            .map(SensorUnit::wide)
            .find(shows_all)
            .expect("a unit drawn with every effect");
        assert_eq!(without(unit.clone(), &[]), unit);
        for e in EFFECTS.iter().filter(|e| **e != "drift") {
            let off = without(unit.clone(), &[e.to_string()]);
            assert_ne!(off, unit, "{e} changed nothing");
            assert_eq!(without(off.clone(), &[e.to_string()]), off, "{e} twice");
        }
        let thick = without(unit.clone(), &[layer_decay(15.0)]);
        assert_eq!(thick.layer_decay_mm, 15.0);
        assert_eq!(
            SensorUnit {
                layer_decay_mm: unit.layer_decay_mm,
                ..thick
            },
            unit
        );
    }

    /// A flat cylinder's frame whose depth failed, unflagged.
    fn cylinder_frame() -> Scored {
        Scored {
            unit: 7,
            kind: Kind::Cylinder,
            indenter: "disc r2".into(),
            depth_mm: 0.57,
            rim_inside_mm: Some(3.0),
            depth_err_mm: Some(0.0718),
            centre_err_mm: Some(0.016),
            force_err_n: Some((-0.378, 4.676)),
            contact_temp_err_c: None,
            mean_temp_err_c: Some(-0.01),
            contact_temp_sigma_c: None,
            contact_temp_c: None,
            skin_temp_c: None,
            max_temp_excess_c: None,
            min_temp_deficit_c: None,
            uniform_spread_c: None,
            missed: false,
            phantom: false,
            failures: vec![failure::DEPTH],
            flags: Vec::new(),
            noise_rad: 0.002,
            shape: "unknown",
        }
    }

    /// A silent failure reads as what failed and by how much, signed, with the indenter
    /// and the shape the pipeline read; the per-indenter count puts the commonest first.
    #[test]
    fn a_silent_failure_names_its_indenter_and_signed_errors() {
        let f = cylinder_frame();
        assert_eq!(
            silent_line(&f),
            "unit 7 flat cylinders (disc r2, read as unknown): depth failed; depth +0.072 mm \
             of 0.57 mm, force -0.38 N of 4.68 N, centre 0.02 mm off"
        );
        let uniform = Scored {
            kind: Kind::Uniform,
            indenter: "none".into(),
            depth_mm: 0.0,
            depth_err_mm: None,
            centre_err_mm: None,
            force_err_n: None,
            max_temp_excess_c: Some(1.85),
            min_temp_deficit_c: Some(1.95),
            failures: vec![failure::HOTTEST_BLOCK, failure::COLDEST_BLOCK],
            ..f
        };
        assert_eq!(
            silent_line(&uniform),
            "unit 7 uniform skin (none): hottest block, coldest block failed; hottest block \
             +1.85 °C, coldest block -1.95 °C"
        );
        let names = ["sphere R10", "disc r2", "none", "disc r2"];
        assert_eq!(
            count_by(names.into_iter()),
            "disc r2 2, none 1, sphere R10 1"
        );
    }

    /// A contact temperature off under a doubt about the depth model alone is silent for
    /// the contact's temperature, not for the frame; under a doubt about the phase beneath
    /// the contact it is not. The section by reading counts both ways.
    #[test]
    fn a_reading_is_silent_where_no_flag_about_it_warned() {
        let f = cylinder_frame();
        let warm = Scored {
            failures: vec![failure::CONTACT_TEMPERATURE],
            flags: vec!["depth_uncertain"],
            ..f.clone()
        };
        assert!(!warm.silent() && warm.silent_in(Reading::ContactTemperature));
        assert!(!warm.silent_in(Reading::PeakDepth) && warm.flagged(Reading::PeakDepth));
        let sloped = Scored {
            flags: vec!["phase_slope"],
            ..warm.clone()
        };
        assert!(!sloped.silent_in(Reading::ContactTemperature));
        let report = by_reading(&[&f, &warm, &sloped]);
        assert!(
            report.contains("| contact_temperature | 2 | 1 | 0 (0.0 %) |")
                && report.contains("| peak_depth | 1 | 1 | 2 (66.7 %) |")
                && report.contains("excused (1)"),
            "{report}"
        );
    }
}
