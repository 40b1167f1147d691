//! The background: the global phase offset between frame and reference (registration),
//! the phase noise floor, and the contact tiles found above it.
//!
//! Registration is the amplitude-weighted mean direction of the background phase: first
//! over everything, then without outliers, then outside the contact region once it is
//! known. Each later set is the reliable samples less some; its resultant is the whole's
//! less that of the samples it drops, or, when it keeps fewer than it drops, its own.
//! Where the whole background is the contact's far field (a thick skin's), registration
//! is on its level beyond the field ([`far_field`]).

use super::coarse::{contact_tiles, local_noise_units, samples_in, Coarse, ContactTiles};
use super::far_field;
use super::{Grid, CONTACT_SIGMAS, MIN_CONTACT_RAD, TILE_MIN_SAMPLES, TILE_PX};
use crate::ftp::carrier::Carrier;
use crate::mask::dilate;
use crate::phase::{PhaseNum, Resultant, GRID};

/// A first offset's neighbourhood: samples this close to it (rad) make the second estimate.
const NEAR_FIRST_RAD: f32 = 0.5;
/// A press's far field is looked for where at least one reliable sample in this many
/// stands raised above the registration by more than the contact threshold (a glare
/// spot's lobe or a warm spot's raises fewer).
const FAR_FIELD_RAISED_SHARE: usize = 50;
/// Samples a background must keep to register on: four tiles' worth (a mean direction
/// from 64 samples is a σ/8 estimate).
const MIN_BACKGROUND_TILES: usize = 4;

/// What the background says about a frame.
#[derive(Debug)]
pub(super) struct Background<P> {
    /// The global phase offset removed.
    pub(super) offset: P,
    /// Phase noise (1σ), units.
    pub(super) noise: i32,
    /// Whether the noise was measured on the background alone (a contact's curvature
    /// counts as noise in the first estimate).
    pub(super) noise_clean: bool,
    /// The contact threshold, units.
    pub(super) threshold: i32,
    /// The contact region's tiles (how many, and whether it was found faint), if any.
    pub(super) contact: Option<ContactTiles>,
    /// Where a contact's offset was registered.
    pub(super) registered_on: RegisteredOn,
}

/// Where a frame with contact was registered. The skin around a contact sinks with it (its
/// skirt), and background the skirt reaches sinks the registration with the contact: the
/// whole map then reads shallow by the share the registration took.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RegisteredOn {
    /// Background a tile clear of the contact region: the skirt has all but died out there.
    ClearOfSkirt,
    /// The background beside the contact region, where the skirt lies below the contact
    /// threshold.
    BesideContact,
    /// The background's level beyond the contact's far field ([`far_field`]): the skin
    /// sinks over the whole view, and that level is the frame's shift.
    BeyondFarField,
    /// Nothing: no background big enough (a contact filling the view) or no contact; the
    /// frame was taken as unshifted.
    Nothing,
}

impl<P> Background<P> {
    /// Whether the contact's skirt cannot have sunk the registration by more than the
    /// depth tolerance ([`super::DEPTH_TOLERANCE_SHARE`], [`super::DEPTH_TOLERANCE_UM`]),
    /// for a contact `depth_um` deep read with a threshold of `threshold_um`. Registered
    /// beside the contact, the skirt there lies below the contact threshold, so a threshold
    /// within the tolerance bounds what it took.
    pub(super) fn skirt_free(&self, threshold_um: i32, depth_um: f32) -> bool {
        match self.registered_on {
            RegisteredOn::ClearOfSkirt | RegisteredOn::BeyondFarField => true,
            RegisteredOn::BesideContact => {
                threshold_um as f32 <= super::depth_tolerance_um(depth_um)
            }
            RegisteredOn::Nothing => false,
        }
    }
}

/// The coarse samples' directions, and sums over subsets of them.
struct Directions<'c, P: PhaseNum> {
    coarse: &'c Coarse<'c, P>,
    /// Every reliable sample's resultant (an unreliable one weighs nothing).
    all: Resultant<P::Sum>,
}

impl<'c, P: PhaseNum> Directions<'c, P> {
    fn new(coarse: &'c Coarse<'c, P>) -> Self {
        // Branch-free: an unreliable sample's amplitude counts zero.
        let all = P::resultant(
            coarse
                .phase
                .iter()
                .zip(&coarse.amp)
                .zip(&coarse.rel)
                .map(|((p, a), r)| (*p, a * u32::from(*r))),
        );
        Directions { coarse, all }
    }

    /// The resultant of the reliable samples `keep` leaves out.
    fn dropped(&self, keep: &[bool]) -> Resultant<P::Sum> {
        let c = self.coarse;
        let mask: Vec<bool> = c.rel.iter().zip(keep).map(|(r, k)| *r && !*k).collect();
        P::masked_resultant(&c.phase, &c.amp, &mask)
    }

    /// The mean direction of the reliable samples where `keep` holds, summing the whole's
    /// less what it drops.
    fn of_most(&self, keep: &[bool]) -> P {
        P::angle(self.all - self.dropped(keep))
    }

    /// The mean direction of the samples where `keep` holds (all reliable), summing the
    /// smaller side; `None` when they are too few to register on.
    fn of_background(&self, keep: &[bool]) -> Option<P> {
        let tile_samples = (TILE_PX / GRID) * (TILE_PX / GRID);
        let kept = keep.iter().filter(|k| **k).count();
        (kept >= MIN_BACKGROUND_TILES * tile_samples).then(|| {
            if 2 * kept < self.coarse.reliable_n {
                P::angle(P::masked_resultant(
                    &self.coarse.phase,
                    &self.coarse.amp,
                    keep,
                ))
            } else {
                self.of_most(keep)
            }
        })
    }

    /// Every sample's phase less `offset`, units.
    fn relative(&self, offset: P) -> Vec<i32> {
        self.coarse
            .phase
            .iter()
            .map(|p| p.minus(offset).units())
            .collect()
    }
}

/// The coarse samples a contact covers at least: a disc one period across, and no fewer
/// than a tile needs ([`TILE_MIN_SAMPLES`]).
pub(super) fn min_contact_samples(carrier: Carrier) -> usize {
    ((carrier.period_px() / GRID as f32).powi(2) * std::f32::consts::FRAC_PI_4)
        .round()
        .max(TILE_MIN_SAMPLES as f32) as usize
}

/// Registers the frame on its background, measures the noise floor and finds the contact
/// tiles above it; with a contact, registration and noise are measured again outside it
/// (and on the rim instead when the rim stands raised above it, [`raised_rim`]). `sign` is
/// the indentation's phase sign; `amp_med` the reference's median fringe amplitude, where
/// the noise floor's threshold holds as measured ([`contact_tiles`]). Where the colour's
/// field was taken out of the phase (`colour_field`), what the field missed by a little is
/// left in floods of both signs that are no noise, and no faint press is looked for among
/// them.
pub(super) fn background<P: PhaseNum>(
    coarse: &Coarse<'_, P>,
    grid: &Grid,
    carrier: Carrier,
    (sign, colour_field): (i32, bool),
    amp_med: u32,
) -> Background<P> {
    let dirs = Directions::new(coarse);
    let first = P::angle(dirs.all);
    let near = P::from_rad(NEAR_FIRST_RAD).units();
    let close: Vec<bool> = coarse
        .phase
        .iter()
        .map(|p| p.minus(first).units().abs() < near)
        .collect();
    let offset = dirs.of_most(&close);
    let phi = dirs.relative(offset);
    let noise_box = ((2.0 * carrier.period_px()) / GRID as f32).round().max(2.0) as usize;
    let min_threshold = P::from_rad(MIN_CONTACT_RAD).units();
    let threshold_of = |noise: i32| ((CONTACT_SIGMAS * noise as f32) as i32).max(min_threshold);
    let min_total = min_contact_samples(carrier);
    let tiles_above = |phi: &[i32], thr: i32| {
        contact_tiles(
            phi,
            &coarse.rel_contact,
            (&coarse.amp_r, amp_med),
            (thr, (!colour_field).then_some(sign)),
            grid.coarse,
            grid.tiles,
            min_total,
        )
    };
    let noise = local_noise_units(&phi, &coarse.rel, grid.coarse.0, grid.coarse.1, noise_box);
    let threshold = threshold_of(noise);
    let Some(ContactTiles { on: region, .. }) = tiles_above(&phi, threshold) else {
        return Background {
            offset,
            noise,
            noise_clean: true,
            threshold,
            contact: None,
            registered_on: RegisteredOn::Nothing,
        };
    };
    // With the contact known, registration and noise come from the background only.
    let (mut registered, mut background, mut outside_n) = outside_contact(&dirs, &region, grid);
    let mut offset = registered.offset;
    let mut phi = dirs.relative(offset);
    // Registered on a contact that fills the middle of the view, the view's rim stands
    // raised above it: the rim was the background.
    let mut counts = raised_and_sunk(&phi, &coarse.rel, sign, threshold);
    let rim = raised_rim(&phi, &coarse.rel, grid.coarse, (sign, threshold), counts);
    if let Some(rim) = rim.and_then(|r| dirs.of_background(&r)) {
        if let Some(ContactTiles { on: rim_region, .. }) =
            tiles_above(&dirs.relative(rim), threshold)
        {
            (registered, background, outside_n) = outside_contact(&dirs, &rim_region, grid);
            offset = registered.offset;
            phi = dirs.relative(offset);
            counts = raised_and_sunk(&phi, &coarse.rel, sign, threshold);
        }
    }
    // Much of the view raised above the registration beside a press: the background may
    // be the contact's far field ([`far_field`]), and its level beyond the field the shift.
    let raised_widely = counts.0 as usize * FAR_FIELD_RAISED_SHARE >= coarse.reliable_n;
    let period_tiles = f64::from(carrier.period_px()) / TILE_PX as f64;
    let field = raised_widely
        .then(|| far_field::far_field(&phi, &coarse.rel, grid, sign, period_tiles))
        .flatten();
    if let Some(f) = &field {
        offset = offset.minus(P::from_units(-f.level));
        phi = dirs.relative(offset);
        registered.on = RegisteredOn::BeyondFarField;
    }
    // The background must be big enough to measure; otherwise keep the first estimate.
    let (noise, noise_clean) = if outside_n * 4 > phi.len() {
        let (cw, ch) = grid.coarse;
        (
            local_noise_units(&phi, &background, cw, ch, noise_box),
            true,
        )
    } else {
        (noise, false)
    };
    let threshold = threshold_of(noise);
    Background {
        offset,
        noise,
        noise_clean,
        threshold,
        // Beyond a far field, the contact is what stands out of it: the field itself is
        // read as is, with the contact's window as seeds for its unwrapping.
        contact: match &field {
            Some(f) => tiles_above(&f.residual(&phi, grid), threshold),
            None => tiles_above(&phi, threshold),
        },
        registered_on: registered.on,
    }
}

/// The reliable samples raised above the registration by more than `thr` (against the
/// indentation's `sign`), when they hold a quarter or more of the rim of the reliable area
/// (its outer [`TILE_PX`] on every side) and hardly any sample is sunk below it (fewer
/// than a quarter as many): the skin cannot stand out of its rest, so a raised rim over a
/// flat middle means the registration sat on a contact filling much of the view (a flat
/// punch wider than half of it), and the rim is the background. A real shift raises or
/// sinks everything alike; a press's wrapped centre lies inside, ringed by sunk samples; a
/// warm spot's or a glare spot's opposite-signed lobe comes with its sunk lobe and holds
/// a short stretch of the rim at most.
fn raised_rim(
    phi: &[i32],
    rel: &[bool],
    (cw, ch): (usize, usize),
    (sign, thr): (i32, i32),
    (n_raised, sunk): (u32, u32),
) -> Option<Vec<bool>> {
    // A press sinks samples and raises next to none, so nearly every frame leaves here.
    if n_raised <= 4 * sunk {
        return None;
    }
    let raised: Vec<bool> = phi
        .iter()
        .zip(rel)
        .map(|(&p, &r)| r & (sign * p < -thr))
        .collect();
    // The reliable area's box, in samples.
    let rows = || rel.chunks_exact(cw).take(ch).enumerate();
    let (mut x0, mut y0, mut x1, mut y1) = (cw, ch, 0, 0);
    for (y, row) in rows() {
        if let (Some(a), Some(b)) = (row.iter().position(|&r| r), row.iter().rposition(|&r| r)) {
            (x0, y0, x1, y1) = (x0.min(a), y0.min(y), x1.max(b + 1), y1.max(y + 1));
        }
    }
    let per = TILE_PX / GRID;
    let (mut rim, mut rim_raised) = (0usize, 0usize);
    for (y, row) in rows() {
        let whole_row = y < y0 + per || y + per >= y1;
        for (x, _) in row.iter().enumerate().filter(|(_, &r)| r) {
            if whole_row || x < x0 + per || x + per >= x1 {
                rim += 1;
                rim_raised += usize::from(raised[y * cw + x]);
            }
        }
    }
    (rim > 0 && 4 * rim_raised >= rim).then_some(raised)
}

/// How many reliable samples of `phi` stand raised above the registration by more than
/// `thr` (against the indentation's `sign`), and how many sunk below it: one branch-free
/// count.
fn raised_and_sunk(phi: &[i32], rel: &[bool], sign: i32, thr: i32) -> (u32, u32) {
    let (mut raised, mut sunk) = (0u32, 0u32);
    for (&p, &r) in phi.iter().zip(rel) {
        raised += u32::from(r & (sign * p < -thr));
        sunk += u32::from(r & (sign * p > thr));
    }
    (raised, sunk)
}

/// An offset registered outside a contact, and where.
struct Registered<P> {
    offset: P,
    on: RegisteredOn,
}

/// The offset registered outside a contact `region` (tiles), the reliable samples outside
/// it (`true` = background), and how many samples lie outside it, reliable or not.
///
/// An indentation's skirt (the skin around a contact sinks with it, and the band-pass
/// spreads it a period further) stays below the contact threshold but moves the mean: the
/// offset comes from the background a tile further out still. With too few samples there,
/// the nearer background; with too few there too (a contact filling the view), there is
/// nothing outside the contact to register on, and the frame is taken as unshifted.
fn outside_contact<P: PhaseNum>(
    dirs: &Directions<'_, P>,
    region: &[bool],
    grid: &Grid,
) -> (Registered<P>, Vec<bool>, usize) {
    let rel = &dirs.coarse.rel;
    // The reliable samples outside a set of tiles (`inside`: the samples in them).
    let outside = |inside: &[bool]| -> Vec<bool> {
        inside.iter().zip(rel).map(|(i, ok)| !i && *ok).collect()
    };
    let (tw, th) = grid.tiles;
    let in_region = samples_in(region, grid.coarse, tw);
    let near = outside(&in_region);
    let far = outside(&samples_in(&dilate(region, tw, th), grid.coarse, tw));
    let registered = if let Some(offset) = dirs.of_background(&far) {
        Registered {
            offset,
            on: RegisteredOn::ClearOfSkirt,
        }
    } else if let Some(offset) = dirs.of_background(&near) {
        Registered {
            offset,
            on: RegisteredOn::BesideContact,
        }
    } else {
        Registered {
            offset: P::from_units(0),
            on: RegisteredOn::Nothing,
        }
    };
    let outside_n = in_region.iter().filter(|i| !**i).count();
    (registered, near, outside_n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn registered_on(registered_on: RegisteredOn) -> Background<()> {
        Background {
            offset: (),
            noise: 0,
            noise_clean: true,
            threshold: 0,
            contact: None,
            registered_on,
        }
    }

    /// Background clear of the skirt always leaves a contact's depth alone; background
    /// beside it only while the threshold the skirt lies under is within the depth's
    /// tolerance (3 % + 20 µm: 50 µm at 1 mm, 23 µm at 0.1 mm); no background never does.
    #[test]
    fn the_skirt_is_left_out_of_the_registration_only_where_it_cannot_matter() {
        let clear = registered_on(RegisteredOn::ClearOfSkirt);
        assert!(clear.skirt_free(500, 100.0));
        let beside = registered_on(RegisteredOn::BesideContact);
        assert!(beside.skirt_free(49, 1000.0));
        assert!(!beside.skirt_free(52, 1000.0));
        assert!(beside.skirt_free(22, 100.0));
        assert!(!beside.skirt_free(25, 100.0));
        let nothing = registered_on(RegisteredOn::Nothing);
        assert!(!nothing.skirt_free(0, 1000.0));
    }
}
