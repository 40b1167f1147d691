//! Quality flags: one bit per way a measurement can fail.
//!
//! A flagged quantity is never silently wrong: either it is within its stated tolerance or
//! the bit that explains why it may not be is set. Bits are append-only on the wire: a new
//! flag takes the next free bit and bumps [`crate::PROTOCOL_VERSION`].
//!
//! A flag speaks for some readings of a summary and not for others: `depth_uncertain`
//! says the peak depth may be off, not the force. [`Flag::concerns`] says which
//! [`Reading`]s each one does, and [`QualityFlags::trusts`] whether any set flag concerns
//! a reading, so a force controller need not drop a frame for a doubt about its depth.

use postcard::experimental::max_size::MaxSize;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Bitfield of [`Flag`]s carried in every [`crate::Summary`].
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize, Schema,
)]
#[serde(transparent)]
pub struct QualityFlags(pub u16);

/// One quality flag. The discriminant is the bit index on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Flag {
    /// Fringe contrast too low to demodulate (dark, washed out, no grating in view).
    LowContrast = 0,
    /// Local phase slope beyond the carrier band (the first order overlaps its neighbours,
    /// so depth at the steepest part of the indentation is underestimated), or a contact
    /// much sharper or blunter than the calibrated indenter (the band's blur takes a
    /// different share of its peak than the calibration learnt). The force, area and
    /// centre are read from the same map, and the contact's temperature from stripes
    /// placed by its phase: all are doubted with the depth.
    PhaseSlope = 1,
    /// Phase unwrapping met residues or paths that disagree: the depth map, and with it
    /// every reading of the contact (its temperature is read over its region), may be a
    /// turn of phase off.
    UnwrapFailure = 2,
    /// Frame and reference are shifted by more than the pipeline compensates.
    Misregistration = 3,
    /// Saturated pixels cover part of the measured area.
    OverExposure = 4,
    /// Some temperature lies outside the calibrated range (reported unclamped), reaches
    /// the setpoint above which the camera clipped the calibration kit (a warmer skin reads
    /// there too), or was read from stripes the camera clipped.
    TemperatureOutOfRange = 5,
    /// The reference frame has drifted from the no-contact image and was not refreshed.
    StaleReference = 6,
    /// The indentation is deeper than the calibration covers (reported extrapolated).
    DepthOutOfRange = 7,
    /// The force is beyond what the calibration covers (reported by the calibrated law
    /// read beyond its kit, saturated where the calibration stops vouching for the law).
    ForceOutOfRange = 8,
    /// The contact temperature's standard deviation exceeds the one-degree tolerance a
    /// reading is held to: its stripes say little about the temperature there (above the
    /// coloured pigments' transition only the black stripes' faint change is left, and a
    /// contact's stripe ratio is less sure than flat skin's). Or a reported temperature
    /// lies where the calibration's own held-out test missed by more than half of it, or
    /// where its kit's reading moved by as much with another uniform frame as the
    /// reference (the reading follows the temperature the reference was taken at). Or the
    /// skin's mean lies more than half a degree outside the span from its coldest place to
    /// its hottest (readings no neighbourhood confirmed move it). Or the contact is the
    /// skin's hottest place and another flag doubts its temperature (the phase its stripes
    /// are placed by): the hottest place is doubted with it. Reported as read.
    TemperatureUncertain = 9,
    /// The contact is narrower than the band resolves (a radius under two of its blur σ,
    /// about 1.6 mm whatever the camera): the band keeps a share of its peak that depends on
    /// its shape, so the peak depth reads low by an unknown part of it; or its peak stands
    /// barely above the noise. The force stands (it integrates the map, which the blur
    /// does not change). The contact's place rests on a few samples near the noise, and
    /// so faint a contact may be none; its temperature is read from stripes placed by the
    /// blurred phase: both are doubted.
    DepthUnresolved = 10,
    /// Half the contact's depth or more lies within a grating period of the edge of the
    /// view, where the demodulator's kernel reaches past the image: the contact may run on
    /// past the edge, unseen, so force, area and volume may read low and the centre lie
    /// inward; the peak is the deepest point in view, and the contact's temperature is read
    /// from stripes placed by the phase there.
    ContactAtEdge = 11,
    /// The calibration's own held-out test of its depth model missed by more than half the
    /// depth tolerance (3 % of the depth + 20 µm) at the depth read: on this unit a peak
    /// depth is not held to that tolerance (its kit's presses, read blind, scattered about
    /// as far). Or a deep press where the kit never pressed may read off by more than half
    /// that tolerance (one standard deviation, from how far the kit's places read apart).
    /// Or the contact's profile is neither clearly a dome's nor a plateau's, and a flat
    /// punch too narrow to show its plateau, whose blurred map is a sphere's a little
    /// deeper, would read beyond that tolerance; or it reads as a plateau too narrow to show
    /// its level, and a dome's fit of it reads beyond the tolerance from it. Reported as
    /// read.
    DepthUncertain = 12,
    /// The contact stands less than twice the contact threshold above the background, over
    /// too few samples to be found as a press is, and was found by its shape instead (the
    /// band spreads a press narrower than itself to its own width, and a speck of the image
    /// is narrower). So faint a contact may be none; its depth reads low by what the band
    /// spread, its force integrates only what stands above the threshold, and its place
    /// and temperature rest on samples near the noise: every reading of it is doubted.
    /// Raised too for a contact standing under three times the threshold, or under what the
    /// rim of a change of the pigment's colour can pull there, mostly where (or just
    /// beside where) that colour changed against the reference (a warm object's print,
    /// pressed or not): the colour's change pulls the phase there as far as such a press
    /// does.
    FaintContact = 13,
}

/// A reading of a [`crate::Summary`] that flags speak for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reading {
    /// `peak_depth_um`.
    PeakDepth,
    /// `force_mn`.
    Force,
    /// Where and how large the contact is: `centroid`, `contact_area_centi_mm2`,
    /// `volume_milli_mm3`, and whether a contact is reported at all.
    Contact,
    /// The contact's temperature, `contact_temp_centi_c`.
    ContactTemperature,
    /// The skin's temperatures, `temp_min_centi_c`, `temp_mean_centi_c` and
    /// `temp_max_centi_c`.
    Temperature,
}

impl Reading {
    /// Every reading.
    pub const ALL: [Reading; 5] = [
        Reading::PeakDepth,
        Reading::Force,
        Reading::Contact,
        Reading::ContactTemperature,
        Reading::Temperature,
    ];

    /// Stable snake_case name used in JSON output and logs.
    pub const fn name(self) -> &'static str {
        match self {
            Reading::PeakDepth => "peak_depth",
            Reading::Force => "force",
            Reading::Contact => "contact",
            Reading::ContactTemperature => "contact_temperature",
            Reading::Temperature => "temperature",
        }
    }
}

impl Flag {
    /// Whether this flag says `reading` may lie beyond its tolerance. A flag about the
    /// fringes or the frame as a whole (`low_contrast`, `misregistration`,
    /// `over_exposure`, `stale_reference`) concerns every reading; one about the depth
    /// model, the peak depth alone; one about the colours, the temperatures alone. One
    /// that doubts the phase under the contact doubts the contact's temperature too: the
    /// temperature path places the contact's coloured and black stripes by that phase.
    /// Each flag's documentation says why.
    pub const fn concerns(self, reading: Reading) -> bool {
        use Reading::{ContactTemperature, Force, PeakDepth, Temperature};
        match self {
            Flag::LowContrast
            | Flag::Misregistration
            | Flag::OverExposure
            | Flag::StaleReference => true,
            // The phase under the contact is in doubt, and the temperature path places the
            // contact's stripes by that phase.
            Flag::PhaseSlope | Flag::UnwrapFailure | Flag::ContactAtEdge | Flag::FaintContact => {
                !matches!(reading, Temperature)
            }
            Flag::DepthUnresolved => !matches!(reading, Force | Temperature),
            Flag::TemperatureOutOfRange | Flag::TemperatureUncertain => {
                matches!(reading, ContactTemperature | Temperature)
            }
            Flag::DepthOutOfRange | Flag::DepthUncertain => matches!(reading, PeakDepth),
            Flag::ForceOutOfRange => matches!(reading, Force),
        }
    }

    /// Every flag, in bit order.
    pub const ALL: [Flag; 14] = [
        Flag::LowContrast,
        Flag::PhaseSlope,
        Flag::UnwrapFailure,
        Flag::Misregistration,
        Flag::OverExposure,
        Flag::TemperatureOutOfRange,
        Flag::StaleReference,
        Flag::DepthOutOfRange,
        Flag::ForceOutOfRange,
        Flag::TemperatureUncertain,
        Flag::DepthUnresolved,
        Flag::ContactAtEdge,
        Flag::DepthUncertain,
        Flag::FaintContact,
    ];

    /// The flag's bit in [`QualityFlags`].
    pub const fn bit(self) -> u16 {
        1 << (self as u8)
    }

    /// Stable snake_case name used in JSON output and logs.
    pub const fn name(self) -> &'static str {
        match self {
            Flag::LowContrast => "low_contrast",
            Flag::PhaseSlope => "phase_slope",
            Flag::UnwrapFailure => "unwrap_failure",
            Flag::Misregistration => "misregistration",
            Flag::OverExposure => "over_exposure",
            Flag::TemperatureOutOfRange => "temperature_out_of_range",
            Flag::StaleReference => "stale_reference",
            Flag::DepthOutOfRange => "depth_out_of_range",
            Flag::ForceOutOfRange => "force_out_of_range",
            Flag::TemperatureUncertain => "temperature_uncertain",
            Flag::DepthUnresolved => "depth_unresolved",
            Flag::ContactAtEdge => "contact_at_edge",
            Flag::DepthUncertain => "depth_uncertain",
            Flag::FaintContact => "faint_contact",
        }
    }

    /// Parses a name produced by [`Flag::name`].
    pub fn from_name(name: &str) -> Option<Flag> {
        Flag::ALL.into_iter().find(|f| f.name() == name)
    }
}

impl QualityFlags {
    /// No flag set: the measurement is trusted.
    pub const NONE: QualityFlags = QualityFlags(0);

    /// Whether `flag` is set.
    pub const fn contains(self, flag: Flag) -> bool {
        self.0 & flag.bit() != 0
    }

    /// Sets `flag`.
    pub fn insert(&mut self, flag: Flag) {
        self.0 |= flag.bit();
    }

    /// Sets every flag set in `other` (unknown bits too).
    pub fn insert_all(&mut self, other: QualityFlags) {
        self.0 |= other.0;
    }

    /// Returns these flags with `flag` set.
    #[must_use]
    pub const fn with(self, flag: Flag) -> QualityFlags {
        QualityFlags(self.0 | flag.bit())
    }

    /// Whether no flag is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The set flags, in bit order. Bits no [`Flag`] names (from a newer device) are skipped;
    /// see [`QualityFlags::unknown_bits`].
    pub fn iter(self) -> impl Iterator<Item = Flag> {
        Flag::ALL.into_iter().filter(move |f| self.contains(*f))
    }

    /// Bits set that this build has no name for.
    pub fn unknown_bits(self) -> u16 {
        let known = Flag::ALL.iter().fold(0u16, |acc, f| acc | f.bit());
        self.0 & !known
    }

    /// Whether no set flag concerns `reading` ([`Flag::concerns`]): the reading is held to
    /// its tolerance. A bit this build has no name for (from a newer device) concerns
    /// every reading, since what it says is unknown here.
    pub fn trusts(self, reading: Reading) -> bool {
        self.unknown_bits() == 0 && !self.iter().any(|f| f.concerns(reading))
    }

    /// The readings a set flag concerns ([`QualityFlags::trusts`] denies), in
    /// [`Reading::ALL`]'s order.
    pub fn doubted(self) -> impl Iterator<Item = Reading> {
        Reading::ALL.into_iter().filter(move |r| !self.trusts(*r))
    }
}

impl FromIterator<Flag> for QualityFlags {
    fn from_iter<I: IntoIterator<Item = Flag>>(iter: I) -> Self {
        let mut flags = QualityFlags::NONE;
        for f in iter {
            flags.insert(f);
        }
        flags
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bits_are_distinct() {
        let mut seen = 0u16;
        for f in Flag::ALL {
            assert_eq!(Flag::from_name(f.name()), Some(f));
            assert_eq!(seen & f.bit(), 0, "{f:?} reuses a bit");
            seen |= f.bit();
        }
        assert_eq!(Flag::from_name("nonsense"), None);
    }

    /// Each flag concerns some reading; the frame-wide ones every reading; a doubt about
    /// the depth model leaves every other reading trusted, one about a faint contact its
    /// force, and one about the colours the geometry; a bit from a newer device leaves
    /// nothing trusted.
    #[test]
    fn flags_speak_for_their_readings() {
        for f in Flag::ALL {
            assert!(Reading::ALL.into_iter().any(|r| f.concerns(r)), "{f:?}");
        }
        let none = QualityFlags::NONE;
        assert!(Reading::ALL.into_iter().all(|r| none.trusts(r)));
        let frame_wide = none.with(Flag::LowContrast);
        assert!(Reading::ALL.into_iter().all(|r| !frame_wide.trusts(r)));
        let depth = none.with(Flag::DepthUncertain);
        assert!(!depth.trusts(Reading::PeakDepth));
        assert!(depth.trusts(Reading::Force) && depth.trusts(Reading::Contact));
        assert!(depth.trusts(Reading::ContactTemperature) && depth.trusts(Reading::Temperature));
        let faint = none.with(Flag::DepthUnresolved);
        assert!(faint.trusts(Reading::Force) && !faint.trusts(Reading::Contact));
        let colour = none.with(Flag::TemperatureUncertain);
        assert!(colour.trusts(Reading::PeakDepth) && colour.trusts(Reading::Force));
        assert!(!colour.trusts(Reading::ContactTemperature));
        let newer = QualityFlags(0x8000);
        assert!(Reading::ALL.into_iter().all(|r| !newer.trusts(r)));
        assert!(newer.doubted().eq(Reading::ALL));
        assert!(depth.doubted().eq([Reading::PeakDepth]));
        assert_eq!(none.doubted().count(), 0);
    }

    #[test]
    fn iter_skips_unknown_bits_and_reports_them() {
        let flags = QualityFlags(Flag::PhaseSlope.bit() | 0x8000);
        let listed: heapless::Vec<Flag, 9> = flags.iter().collect();
        assert_eq!(listed.as_slice(), &[Flag::PhaseSlope]);
        assert_eq!(flags.unknown_bits(), 0x8000);
        assert!(!flags.is_empty());
        assert!(QualityFlags::NONE.is_empty());
    }
}
