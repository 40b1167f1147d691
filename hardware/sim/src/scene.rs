//! Named scenes: scripted sequences of skin states for the CLI, fixtures, tests and demo.

use crate::contact::{Contact, Indenter};
use crate::footprint::Footprint;
use crate::state::SkinState;
use crate::thermal::{HeatSource, TempField};
use crate::unit::SensorUnit;

/// Skin temperature of scenes that do not set one, °C.
pub const ROOM_C: f32 = 25.0;

/// Radius of the calibrated spherical indenter, mm.
pub const SPHERE_R_MM: f32 = 10.0;

/// Every scene name, with a one-line description.
pub const SCENES: &[(&str, &str)] = &[
    ("idle", "no contact, uniform 25 °C"),
    ("press-sphere", "10 mm sphere pressed to 2 mm and released"),
    ("sweep-depth", "10 mm sphere at depths 0.1…2.5 mm"),
    ("letter-e", "letter E punch pressed to 1.2 mm"),
    ("letter-p", "letter P punch pressed to 1.2 mm"),
    ("letter-f", "letter F punch pressed to 1.2 mm"),
    ("heated-nut", "hex nut at 45 °C pressed to 0.8 mm"),
    ("heated-sphere", "sphere at 40 °C pressed to 1.5 mm"),
    (
        "hover-heat",
        "a 45 °C object close above the skin, no contact",
    ),
    (
        "heated-bar",
        "no contact, gradient 25 → 40 °C across the skin",
    ),
    ("uniform-temps", "no contact, uniform 15…45 °C"),
    (
        "misregistered",
        "no contact, skin shifted 0…3 px against the camera",
    ),
    (
        "creep",
        "no contact, the skin creeping 0…1.5 px and the light fading 6 %",
    ),
    (
        "demo",
        "idle, press a heated sphere, slide it, release, press E, heated bar",
    ),
];

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// `t` in [0, 1] for frame `i` of `n`.
fn frac(i: usize, n: usize) -> f32 {
    if n <= 1 {
        1.0
    } else {
        i as f32 / (n - 1) as f32
    }
}

/// Centre of the field of view, mm.
pub fn center_mm(unit: &SensorUnit) -> (f32, f32) {
    let s = unit.mm_per_px();
    (
        unit.width_px as f32 * s / 2.0,
        unit.height_px as f32 * s / 2.0,
    )
}

fn sphere_at(c: (f32, f32), depth_mm: f32) -> Contact {
    Contact {
        indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
        center_mm: c,
        depth_mm,
    }
}

fn heated(state: &mut SkinState, c: &Contact, temp_c: f32) {
    state
        .temperature
        .sources
        .push(HeatSource::under(c, temp_c, 1.5));
}

/// The skin states of scene `name` over `frames` frames, or `None` for an unknown name.
pub fn states(name: &str, unit: &SensorUnit, frames: usize) -> Option<Vec<SkinState>> {
    let n = frames.max(1);
    let c = center_mm(unit);
    // Keep letters inside small fields of view.
    let fov_h = unit.height_px as f32 * unit.mm_per_px();
    let letter_h = (0.5 * fov_h).min(12.0);
    let one = |f: &dyn Fn(usize) -> SkinState| (0..n).map(f).collect::<Vec<_>>();
    let ramp = |i: usize| 1.0 - (2.0 * frac(i, n) - 1.0).abs();
    let s = match name {
        "idle" => one(&|_| SkinState::idle(ROOM_C)),
        "press-sphere" => one(&|i| {
            let mut s = SkinState::idle(ROOM_C);
            s.contacts.push(sphere_at(c, 2.0 * ramp(i)));
            s
        }),
        "sweep-depth" => one(&|i| {
            let mut s = SkinState::idle(ROOM_C);
            s.contacts.push(sphere_at(c, lerp(0.1, 2.5, frac(i, n))));
            s
        }),
        "letter-e" | "letter-p" | "letter-f" => one(&|i| {
            let fp = match name {
                "letter-e" => Footprint::letter_e(letter_h),
                "letter-p" => Footprint::letter_p(letter_h),
                _ => Footprint::letter_f(letter_h),
            };
            let mut s = SkinState::idle(ROOM_C);
            s.contacts.push(Contact {
                indenter: Indenter::Punch(fp),
                center_mm: c,
                depth_mm: 1.2 * frac(i, n).clamp(0.25, 1.0),
            });
            s
        }),
        "heated-nut" => one(&|i| {
            let mut s = SkinState::idle(ROOM_C);
            let af = (0.45 * fov_h).min(10.0);
            let contact = Contact {
                indenter: Indenter::Punch(Footprint::HexNut {
                    af_mm: af,
                    hole_mm: af / 2.0,
                }),
                center_mm: c,
                depth_mm: 0.8 * frac(i, n).max(0.25),
            };
            heated(&mut s, &contact, 45.0);
            s.contacts.push(contact);
            s
        }),
        "heated-sphere" => one(&|i| {
            let mut s = SkinState::idle(ROOM_C);
            let contact = sphere_at(c, 1.5 * frac(i, n).max(0.2));
            heated(&mut s, &contact, 40.0);
            s.contacts.push(contact);
            s
        }),
        "hover-heat" => one(&|i| {
            let mut s = SkinState::idle(ROOM_C);
            s.temperature.sources.push(HeatSource::Spot {
                center_mm: c,
                footprint: Footprint::Disc { r_mm: 4.0 },
                temp_c: lerp(30.0, 45.0, frac(i, n)),
                spread_mm: 3.0,
            });
            s
        }),
        "heated-bar" => one(&|i| {
            let mut s = SkinState::idle(ROOM_C);
            let w = unit.width_px as f32 * unit.mm_per_px();
            s.temperature.sources.push(HeatSource::Gradient {
                from_mm: (0.1 * w, c.1),
                to_mm: (0.9 * w, c.1),
                hot_c: lerp(30.0, 40.0, frac(i, n)),
            });
            s
        }),
        "uniform-temps" => one(&|i| SkinState::idle(lerp(15.0, 45.0, frac(i, n)))),
        "misregistered" => one(&|i| {
            let mut s = SkinState::idle(ROOM_C);
            let t = frac(i, n);
            s.shift_px = (3.0 * t, 2.0 * t);
            s
        }),
        "creep" => one(&|i| {
            let mut s = SkinState::idle(ROOM_C);
            let t = frac(i, n);
            s.shift_px = (1.5 * t, 0.5 * t);
            s.exposure_scale = 1.0 - 0.06 * t;
            s
        }),
        "demo" => demo(unit, n),
        _ => return None,
    };
    Some(s)
}

/// The demo script, scaled to `n` frames: idle, press a heated sphere, slide it, release,
/// press the letter E, then a heated bar.
fn demo(unit: &SensorUnit, n: usize) -> Vec<SkinState> {
    let c = center_mm(unit);
    let fov_w = unit.width_px as f32 * unit.mm_per_px();
    let fov_h = unit.height_px as f32 * unit.mm_per_px();
    let phases = [0.1f32, 0.2, 0.2, 0.1, 0.2, 0.2];
    let bounds: Vec<usize> = phases
        .iter()
        .scan(0.0f32, |acc, p| {
            *acc += p;
            Some((*acc * n as f32).round() as usize)
        })
        .collect();
    let slide = 0.2 * fov_w;
    (0..n)
        .map(|i| {
            let k = bounds
                .iter()
                .position(|&b| i < b)
                .unwrap_or(phases.len() - 1);
            let start = if k == 0 { 0 } else { bounds[k - 1] };
            let len = (bounds[k] - start).max(1);
            let t = (i - start) as f32 / len as f32;
            let mut s = SkinState::idle(ROOM_C);
            match k {
                0 => {}
                1..=3 => {
                    let depth = match k {
                        1 => 1.5 * t,
                        2 => 1.5,
                        _ => 1.5 * (1.0 - t),
                    };
                    let x = match k {
                        1 => c.0 - slide,
                        2 => c.0 - slide + 2.0 * slide * t,
                        _ => c.0 + slide,
                    };
                    let contact = sphere_at((x, c.1), depth);
                    if depth > 0.02 {
                        heated(&mut s, &contact, 40.0);
                        s.contacts.push(contact);
                    }
                }
                4 => s.contacts.push(Contact {
                    indenter: Indenter::Punch(Footprint::letter_e((0.5 * fov_h).min(12.0))),
                    center_mm: c,
                    depth_mm: 1.0 * (2.0 * t).min(1.0),
                }),
                _ => s.temperature.sources.push(HeatSource::Gradient {
                    from_mm: (0.1 * fov_w, c.1),
                    to_mm: (0.9 * fov_w, c.1),
                    hot_c: lerp(28.0, 38.0, t),
                }),
            }
            s
        })
        .collect()
}

/// A uniform skin at `t_c` (convenience for calibration and tests).
pub fn uniform(t_c: f32) -> SkinState {
    SkinState {
        temperature: TempField::uniform(t_c),
        ..SkinState::idle(t_c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_named_scene_exists_and_unknown_is_none() {
        let u = SensorUnit::reference();
        for (name, _) in SCENES {
            let s = states(name, &u, 12).unwrap();
            assert_eq!(s.len(), 12, "{name}");
        }
        assert!(states("no-such-scene", &u, 3).is_none());
    }

    #[test]
    fn demo_presses_slides_and_releases() {
        let u = SensorUnit::reference();
        let s = states("demo", &u, 100).unwrap();
        assert!(s[..10].iter().all(|st| st.contacts.is_empty()));
        let pressed: Vec<f32> = s[30..50]
            .iter()
            .map(|st| st.contacts[0].center_mm.0)
            .collect();
        assert!(
            pressed.windows(2).all(|w| w[1] > w[0]),
            "slides to the right"
        );
        assert!(s[90..]
            .iter()
            .all(|st| st.contacts.is_empty() && !st.temperature.sources.is_empty()));
    }
}
