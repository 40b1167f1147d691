//! The grating phase the pigment's colour moves, and taking it out of a frame.
//!
//! Away from the reference's temperature the coloured stripes change colour, and with it
//! the fringe's amplitude. Wherever something fixed in the image adds to the band (a lamp's
//! reflection, pigment mottle near the carrier), the phase read there is the fringe's
//! pulled by that term, and the pull changes with the amplitude: a uniform skin shows
//! raised and sunk spots against the reference. The contact test takes such a spot for a
//! press, and a real press beside a spot of the other sign can be dropped as a dipole.
//!
//! The calibration's temperature kit shows that field at every setpoint
//! ([`ColourPhase`](crate::calibration::colour_phase::ColourPhase),
//! on a sparse grid of nodes, kept only where it stands out of the kit frames' noise). A
//! frame's phase is compared with each setpoint's field, taken relative to the
//! reference's temperature ([`Candidates`]), and the field that explains it best, if any
//! explains it better than none, is taken out before registration. The field is chosen by
//! the phase itself, not by the temperature the frame reads: the thermometer places its
//! stripes by that phase, and a phase-borne choice needs no thermometer at all. Where the
//! field saturates (the pigment cleared), every warmer setpoint's field is the same, and
//! which of them is chosen does not matter.

mod choice;

pub use choice::{Candidates, BETWEEN, REACH_SIGMAS, SCALES, SHOWN_SHARE};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::colour_phase::{at, at_nodes, nodes_of, ColourPhase};

    /// A 12 × 8 coarse grid's nodes (3 × 2) with a raised spot at node 1 and a sunk one at
    /// node 4, both `a` units.
    fn spots(a: i32) -> Vec<i32> {
        vec![0, a, 0, 0, -a, 0]
    }

    /// The phase of a `cw × ch` grid equal to `field` at the nodes, plus `offset`.
    fn grid_of(field: &[i32], offset: i32, (cw, ch): (usize, usize)) -> Vec<i32> {
        let c = Candidates::new(4, nodes_of((cw, ch), 4), (vec![30.0], vec![field.to_vec()]));
        c.spread(field, (cw, ch))
            .into_iter()
            .map(|v| v + offset)
            .collect()
    }

    fn kit(frames: &[(f64, Vec<i32>)]) -> ColourPhase {
        let frames: Vec<(f64, Vec<Option<i32>>)> = frames
            .iter()
            .map(|(t, v)| (*t, v.iter().map(|&u| Some(u)).collect()))
            .collect();
        ColourPhase::from_frames((4, [3, 2]), &frames).unwrap()
    }

    /// The kit keeps a setpoint's spots and zeroes what lies within its noise; a frame
    /// showing a setpoint's field (moved by a registration offset) gets that field back,
    /// spread over the grid, and one showing none gets none.
    #[test]
    fn a_frame_showing_a_setpoints_field_gets_it_back() {
        let (cw, ch) = (12, 8);
        let mut warm = spots(4000);
        warm[0] = 30; // within the noise the other nodes show
        warm[2] = -25;
        warm[3] = 20;
        warm[5] = -30;
        let cal = kit(&[(25.0, vec![10, -20, 15, -5, 20, -10]), (32.0, warm)]);
        assert_eq!(cal.setpoints[1].spots, vec![[1, 4000], [4, -4000]]);
        assert!(cal.setpoints[0].spots.is_empty());
        let candidates = Candidates::relative_to(&cal, Some(25.0));
        let rel = vec![true; cw * ch];
        let frame = grid_of(&spots(4000), 700, (cw, ch));
        let chosen = candidates.choose(&frame, &rel, (cw, ch)).unwrap();
        assert_eq!(chosen, grid_of(&spots(4000), 0, (cw, ch)));
        let flat = vec![700; cw * ch];
        assert_eq!(candidates.choose(&flat, &rel, (cw, ch)), None);
        // Another grid is not the calibration's.
        assert_eq!(candidates.choose(&frame, &rel, (cw + 8, ch)), None);
    }

    /// A press away from the spots leaves the choice to the spots: the field is taken out
    /// under it, and a press alone is not explained by any field.
    #[test]
    fn a_press_does_not_move_the_choice() {
        let (cw, ch) = (12, 8);
        let cal = kit(&[(25.0, vec![0; 6]), (32.0, spots(4000))]);
        let candidates = Candidates::relative_to(&cal, Some(25.0));
        let rel = vec![true; cw * ch];
        let press = |mut phase: Vec<i32>| {
            for y in 4..8 {
                for x in 8..12 {
                    phase[y * cw + x] += 9000;
                }
            }
            phase
        };
        let warm = press(grid_of(&spots(4000), 0, (cw, ch)));
        assert!(candidates.choose(&warm, &rel, (cw, ch)).is_some());
        let at_rest = press(vec![0; cw * ch]);
        assert_eq!(candidates.choose(&at_rest, &rel, (cw, ch)), None);
    }

    /// The record is written compactly and read back as it was; a spot off the grid makes
    /// it unusable.
    #[test]
    fn a_record_round_trips_and_a_stray_spot_is_refused() {
        let mut cal = kit(&[(25.0, vec![0; 6]), (32.0, spots(4000))]);
        let text = serde_json::to_string(&cal).unwrap();
        assert!(text.contains(r#""spots":"1:4000 4:-4000""#), "{text}");
        assert_eq!(serde_json::from_str::<ColourPhase>(&text).unwrap(), cal);
        assert_eq!(cal.invalid(), None);
        cal.setpoints[1].spots.push([6, 10]);
        assert!(cal.invalid().is_some_and(|why| why.contains("nodes 0…5")));
    }

    /// Two frames per setpoint give each node's noise; a setpoint the line between its
    /// neighbours reproduces within it is left out, one it does not is kept.
    #[test]
    fn a_setpoint_its_neighbours_reproduce_is_left_out() {
        let noisy = |field: Vec<i32>, k: i32| -> Vec<Option<i32>> {
            field
                .iter()
                .map(|&u| Some(u + if k == 0 { 20 } else { -20 }))
                .collect()
        };
        let record = |middle: Vec<i32>| {
            let temps = [
                (10.0, spots(0)),
                (15.0, spots(0)),
                (20.0, middle),
                (25.0, spots(4000)),
                (30.0, spots(4000)),
            ];
            let frames: Vec<(f64, Vec<Option<i32>>)> = (0..10)
                .map(|i| {
                    (
                        temps[i % 5].0,
                        noisy(temps[i % 5].1.clone(), (i / 5) as i32),
                    )
                })
                .collect();
            ColourPhase::from_frames((4, [3, 2]), &frames).unwrap()
        };
        let t = |c: &ColourPhase| c.setpoints.iter().map(|f| f.t_c).collect::<Vec<_>>();
        // Halfway on the line from 15 to 25 °C: left out (25 °C is kept, the line from 15
        // to 30 °C would not reach it).
        assert_eq!(t(&record(spots(2000))), vec![10.0, 15.0, 25.0, 30.0]);
        assert_eq!(t(&record(spots(3500))), vec![10.0, 15.0, 20.0, 25.0, 30.0]);
        // Each node's noise is 20 units: the spots stand out of it, the rest does not.
        assert_eq!(
            record(spots(2000)).setpoints[2].spots,
            vec![[1, 4000], [4, -4000]]
        );
    }

    /// A node reads the mean of the samples within half a period around it, less the
    /// registration: a ripple of the grating's period is averaged away, a step is kept.
    #[test]
    fn nodes_read_the_field_smoothed_over_a_period() {
        let (cw, ch) = (16, 8);
        // A working period of 6 pixels is 3 coarse samples: a ripple of +90, 0, −90.
        let ripple = [90, 0, -90];
        let coarse: Vec<i32> = (0..cw * ch)
            .map(|k| 500 + ripple[(k % cw) % 3] + if k % cw >= 8 { 1000 } else { 0 })
            .collect();
        let ((step, nodes), v) = at_nodes(&coarse, 500, (cw, ch), 6.0);
        assert_eq!((step, nodes), (2, [8, 4]));
        // Nodes at columns 2 and 12: well inside either side of the step.
        assert_eq!(v[1], Some(0));
        assert_eq!(v[6], Some(1000));
    }

    /// Relative to a reference taken at a setpoint, that setpoint's field moves nothing
    /// and is dropped; between setpoints the field is interpolated.
    #[test]
    fn fields_are_taken_against_the_references_temperature() {
        let cal = kit(&[(25.0, vec![0; 6]), (30.0, spots(4000)), (35.0, spots(8000))]);
        let (temps, dense) = ([25.0, 30.0, 35.0], cal.dense().unwrap());
        assert_eq!(at(&temps, &dense, 32.5), spots(6000));
        assert_eq!(at(&temps, &dense, 40.0), spots(8000));
        assert_eq!(at(&temps, &dense, 20.0), vec![0; 6]);
        let at_30 = Candidates::relative_to(&cal, Some(30.0));
        assert_eq!(at_30.fields, vec![spots(-4000), spots(4000)]);
        assert_eq!(Candidates::relative_to(&cal, None).fields.len(), 2);
    }
}
