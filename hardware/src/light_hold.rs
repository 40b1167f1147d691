//! Holding a camera's automatic exposure, gain, white balance and focus where they settled.
//!
//! A UVC camera adjusts these by itself, from what it sees. Under the skin it sees the
//! thermochromic stripes: a warm skin changes the image's colour and brightness, and the
//! camera's automatic white balance and exposure would answer by moving the very colours
//! the temperature is read from, and the fringe contrast the depth is read with, after the
//! reference was taken. The temperature's features are ratios that cancel such changes
//! in principle (`docs/temperature.md`); a compressed camera's chroma does not cancel them
//! wholly, and nothing is gained by letting them happen. So once the image has settled
//! under the LED ring, each automatic the camera has is switched off with its manual
//! counterpart written back at the value it had settled to: the image stays as the
//! reference saw it. (A camera that reports a default instead of the value its automatic
//! settled to may change once when held; the service's reference keeper sees that as
//! drift and renews the reference, `docs/service.md`.)
//!
//! The controls are V4L2's (`linux/v4l2-controls.h`); a camera that lacks one is left as
//! it is, and one that refuses a change is reported, never fatal: the service runs on,
//! and the report says which automatics still move.

/// How long a camera streams before its automatics are held by default: its exposure and
/// white balance settle within a second or two of the LED ring lighting the skin.
pub const HOLD_AFTER: std::time::Duration = std::time::Duration::from_secs(2);

/// The V4L2 controls a hold needs: read a value, write one. `None` from
/// [`Controls::get`] means the device has no such control.
pub trait Controls {
    /// The control's current value.
    fn get(&self, id: u32) -> Option<i64>;
    /// Sets the control.
    fn set(&mut self, id: u32, value: i64) -> std::io::Result<()>;
}

/// `V4L2_CID_EXPOSURE_AUTO` (a menu: 1 is manual).
pub const EXPOSURE_AUTO: u32 = 0x009a_0901;
/// `V4L2_CID_EXPOSURE_ABSOLUTE`, 100 µs units.
pub const EXPOSURE_ABSOLUTE: u32 = 0x009a_0902;
/// `V4L2_CID_AUTO_WHITE_BALANCE` (boolean).
pub const AUTO_WHITE_BALANCE: u32 = 0x0098_090c;
/// `V4L2_CID_WHITE_BALANCE_TEMPERATURE`, kelvin.
pub const WHITE_BALANCE_TEMPERATURE: u32 = 0x0098_091a;
/// `V4L2_CID_AUTOGAIN` (boolean).
pub const AUTOGAIN: u32 = 0x0098_0912;
/// `V4L2_CID_GAIN`.
pub const GAIN: u32 = 0x0098_0913;
/// `V4L2_CID_FOCUS_AUTO` (boolean).
pub const FOCUS_AUTO: u32 = 0x009a_090c;
/// `V4L2_CID_FOCUS_ABSOLUTE`.
pub const FOCUS_ABSOLUTE: u32 = 0x009a_090a;

/// One automatic: its switch, the switch's "off" value, and the manual control it hands
/// over to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Automatic {
    /// What the report calls it.
    pub name: &'static str,
    /// The switch.
    pub switch: u32,
    /// The switch's value for "manual".
    pub off: i64,
    /// The manual control that takes over.
    pub manual: u32,
}

/// The automatics a hold switches off, in the order it does.
pub const AUTOMATICS: [Automatic; 4] = [
    Automatic {
        name: "exposure",
        switch: EXPOSURE_AUTO,
        off: 1,
        manual: EXPOSURE_ABSOLUTE,
    },
    Automatic {
        name: "gain",
        switch: AUTOGAIN,
        off: 0,
        manual: GAIN,
    },
    Automatic {
        name: "white balance",
        switch: AUTO_WHITE_BALANCE,
        off: 0,
        manual: WHITE_BALANCE_TEMPERATURE,
    },
    Automatic {
        name: "focus",
        switch: FOCUS_AUTO,
        off: 0,
        manual: FOCUS_ABSOLUTE,
    },
];

/// What became of one automatic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Switched off; the manual value written back (`None` where the camera has no manual
    /// control to read or refused the value: the switch alone holds it, at whatever the
    /// camera keeps).
    Held(Option<i64>),
    /// The camera has no such automatic.
    Absent,
    /// The camera refused: the automatic may still move.
    Refused(String),
}

/// Switches off every automatic the camera has, each with its manual value as it had
/// settled written back after the switch (a camera may reset the manual value when its
/// automatic is switched off).
pub fn hold(c: &mut impl Controls) -> Vec<(&'static str, Outcome)> {
    AUTOMATICS
        .iter()
        .map(|a| (a.name, hold_one(c, a)))
        .collect()
}

fn hold_one(c: &mut impl Controls, a: &Automatic) -> Outcome {
    if c.get(a.switch).is_none() {
        return Outcome::Absent;
    }
    let settled = c.get(a.manual);
    if let Err(e) = c.set(a.switch, a.off) {
        return Outcome::Refused(e.to_string());
    }
    // Off either way; the value is known only where the camera took it back.
    Outcome::Held(settled.filter(|&v| c.set(a.manual, v).is_ok()))
}

/// One line for the log: what is held, at what, and what the camera refused.
pub fn describe(held: &[(&'static str, Outcome)]) -> String {
    let mut parts = Vec::new();
    for (name, outcome) in held {
        match outcome {
            Outcome::Held(Some(v)) => parts.push(format!("{name} held at {v}")),
            Outcome::Held(None) => parts.push(format!("{name} held")),
            Outcome::Refused(why) => parts.push(format!("{name} still automatic ({why})")),
            Outcome::Absent => {}
        }
    }
    if parts.is_empty() {
        "no automatic exposure, gain, white balance or focus to hold".into()
    } else {
        parts.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// A camera's controls in memory: each write recorded; a manual control reset to 0
    /// when its automatic is switched off (as some UVC cameras do); `refuse` fails writes
    /// to that control.
    #[derive(Default)]
    struct Fake {
        values: BTreeMap<u32, i64>,
        writes: Vec<(u32, i64)>,
        refuse: Option<u32>,
    }

    impl Controls for Fake {
        fn get(&self, id: u32) -> Option<i64> {
            self.values.get(&id).copied()
        }

        fn set(&mut self, id: u32, value: i64) -> std::io::Result<()> {
            if self.refuse == Some(id) {
                return Err(std::io::Error::other("Input/output error"));
            }
            self.writes.push((id, value));
            self.values.insert(id, value);
            if let Some(a) = AUTOMATICS.iter().find(|a| a.switch == id) {
                if let Some(v) = self.values.get_mut(&a.manual) {
                    *v = 0;
                }
            }
            Ok(())
        }
    }

    fn webcam() -> Fake {
        let mut f = Fake::default();
        f.values.extend([
            (EXPOSURE_AUTO, 3),
            (EXPOSURE_ABSOLUTE, 156),
            (AUTO_WHITE_BALANCE, 1),
            (WHITE_BALANCE_TEMPERATURE, 4600),
        ]);
        f
    }

    #[test]
    fn automatics_go_off_and_the_settled_values_stay() {
        let mut cam = webcam();
        let held = hold(&mut cam);
        assert_eq!(cam.get(EXPOSURE_AUTO), Some(1));
        assert_eq!(cam.get(EXPOSURE_ABSOLUTE), Some(156));
        assert_eq!(cam.get(AUTO_WHITE_BALANCE), Some(0));
        assert_eq!(cam.get(WHITE_BALANCE_TEMPERATURE), Some(4600));
        // The manual value is written after its switch, not before.
        let at = |w: (u32, i64)| cam.writes.iter().position(|&x| x == w);
        assert!(at((EXPOSURE_AUTO, 1)) < at((EXPOSURE_ABSOLUTE, 156)));
        // Gain and focus are not there: nothing is written to them.
        assert!(held.contains(&("gain", Outcome::Absent)));
        assert!(cam
            .writes
            .iter()
            .all(|&(id, _)| id != GAIN && id != FOCUS_AUTO));
        assert_eq!(
            describe(&held),
            "exposure held at 156, white balance held at 4600"
        );
    }

    /// The webcam held while it refuses writes to control `id`, and the report's line.
    fn held_refusing(id: u32) -> (Fake, String) {
        let mut cam = webcam();
        cam.refuse = Some(id);
        let line = describe(&hold(&mut cam));
        (cam, line)
    }

    #[test]
    fn a_refused_switch_is_reported_and_the_others_still_held() {
        let (cam, line) = held_refusing(AUTO_WHITE_BALANCE);
        assert_eq!(cam.get(EXPOSURE_AUTO), Some(1));
        assert_eq!(cam.get(AUTO_WHITE_BALANCE), Some(1));
        assert!(line.contains("exposure held at 156"), "{line}");
        assert!(
            line.contains("white balance still automatic (Input/output error)"),
            "{line}"
        );
    }

    #[test]
    fn a_refused_manual_value_still_leaves_the_automatic_off() {
        let (cam, line) = held_refusing(EXPOSURE_ABSOLUTE);
        assert_eq!(cam.get(EXPOSURE_AUTO), Some(1));
        assert_eq!(line, "exposure held, white balance held at 4600");
    }

    #[test]
    fn a_switch_without_a_manual_control_is_still_held() {
        let mut cam = Fake::default();
        cam.values.insert(FOCUS_AUTO, 1);
        let held = hold(&mut cam);
        assert_eq!(cam.get(FOCUS_AUTO), Some(0));
        assert_eq!(describe(&held), "focus held");
        assert_eq!(
            describe(&hold(&mut Fake::default())),
            "no automatic exposure, gain, white balance or focus to hold"
        );
    }
}
