//! A frame as a figure, end to end: the device service films a simulated press over a
//! real pseudo-terminal, the host asks for the next frame's full maps (camera, depth,
//! temperature at the working resolution, sent in pieces), and draws them. The maps are
//! checked against the scene's truth, and the figure's SVG twin is read back.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::time::Duration;

use vistaf_firmware::service::Settings;
use vistaf_host::snapshot::{self, FIGURE_MAPS};
use vistaf_pipeline::calibration::Calibration;
use vistaf_protocol::MapKind;
use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::{center_mm, ROOM_C, SPHERE_R_MM};
use vistaf_sim::{SensorUnit, SimSource, SkinState};

const DEPTH_MM: f32 = 1.0;

#[test]
fn full_maps_cross_the_link_whole_and_draw_as_a_labelled_figure() {
    let unit = SensorUnit::reference_sized(320, 240);
    let (cx, cy) = center_mm(&unit);
    let mut pressed = SkinState::idle(ROOM_C);
    pressed.contacts.push(Contact {
        indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
        center_mm: (cx, cy),
        depth_mm: DEPTH_MM,
    });
    let mut states = vec![SkinState::idle(ROOM_C); 3];
    states.extend(std::iter::repeat_n(pressed, 200));
    let mm_per_px = f64::from(unit.mm_per_px());
    let source = SimSource::new("press", unit, states, Some(30.0), 11);
    let settings = Settings {
        serial: "VSK-SNAP".into(),
        // The default calibration is for 640 × 480: used at 320 × 240 on purpose.
        force_calibration: true,
        ..Settings::new(Calibration::default_sim())
    };
    let mut served = vistaf_tests::pty::serve(Box::new(source), settings);
    let host = &mut served.client;
    host.handshake(Duration::from_secs(5)).unwrap();
    // Past the untouched frames: the press is on.
    std::thread::sleep(Duration::from_millis(400));
    let shot = host
        .request_full_maps(&FIGURE_MAPS, Duration::from_secs(20))
        .unwrap();
    served
        .stop
        .store(true, std::sync::atomic::Ordering::Relaxed);

    let kinds: Vec<MapKind> = shot.maps.iter().map(|m| m.kind).collect();
    assert_eq!(kinds, FIGURE_MAPS.to_vec());
    let seq = shot.maps[0].seq;
    assert!(shot.maps.iter().all(|m| m.seq == seq), "one frame's maps");
    let summary = shot.summary.expect("the frame's summary");
    assert_eq!(summary.seq, seq);

    // Depth at the working resolution: every working pixel, the scene's press at its place.
    let depth = &shot.maps[1];
    assert!(depth.width * depth.height > vistaf_protocol::msg::MAP_MAX_CELLS * 10);
    assert!((depth.width as f64 * depth.pitch_mm - 320.0 * mm_per_px).abs() < 0.5);
    let values = depth.si().unwrap();
    let (at, deepest) = values
        .iter()
        .enumerate()
        .filter(|(_, v)| v.is_finite())
        .fold((0, f32::MIN), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
    assert!(
        (0.8 * DEPTH_MM..=1.05 * DEPTH_MM).contains(&deepest),
        "deepest working pixel {deepest} mm for a {DEPTH_MM} mm press"
    );
    let (x_mm, y_mm) = (
        (at % depth.width) as f64 * depth.pitch_mm,
        (at / depth.width) as f64 * depth.pitch_mm,
    );
    let off = ((x_mm - f64::from(cx)).powi(2) + (y_mm - f64::from(cy)).powi(2)).sqrt();
    assert!(off < 1.5, "deepest place {off:.2} mm from the contact");
    // The summary's peak (the blur taken out) is at least the map's.
    assert!(f64::from(summary.peak_depth_um) / 1000.0 >= f64::from(deepest) - 0.02);

    // The camera image: same grid, the grating's stripes across it.
    let camera = &shot.maps[0];
    assert_eq!((camera.width, camera.height), (depth.width, depth.height));
    let rgb = camera.rgb().unwrap();
    let row: Vec<f64> = rgb[..camera.width * 3]
        .chunks(3)
        .map(|p| p.iter().map(|&c| f64::from(c)).sum::<f64>() / 3.0)
        .collect();
    let mean = row.iter().sum::<f64>() / row.len() as f64;
    let crossings = row
        .windows(2)
        .filter(|w| (w[0] - mean) * (w[1] - mean) < 0.0)
        .count();
    assert!(crossings >= 10, "{crossings} stripe edges along a row");

    // Temperature: the skin at room temperature.
    let temp = shot.maps[2].si().unwrap();
    let measured: Vec<f32> = temp.iter().copied().filter(|v| v.is_finite()).collect();
    let mean_c = measured.iter().sum::<f32>() / measured.len() as f32;
    assert!(
        (mean_c - ROOM_C).abs() < 1.0,
        "mean {mean_c} °C at {ROOM_C} °C"
    );

    // The figure, its SVG read back, and the surface as PLY.
    let dir = std::env::temp_dir().join(format!("vistaf-snapshot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let frame = snapshot::frame(&shot);
    let ranges = vistaf_figure::Ranges::covering([&frame]);
    let written = vistaf_figure::write(&frame, &ranges, &dir.join("fig.png")).unwrap();
    let svg = std::fs::read_to_string(&written.svg).unwrap();
    let texts: Vec<&str> = svg
        .split("<text")
        .skip(1)
        .filter_map(|t| Some(t[t.find('>')? + 1..t.find("</text>")?].trim()))
        .collect();
    let bar: Vec<f64> = texts
        .iter()
        .skip_while(|t| **t != "depth")
        .skip(1)
        .map_while(|t| t.strip_suffix(" mm"))
        .map(|n| n.parse().unwrap())
        .collect();
    assert_eq!(bar.first(), Some(&0.0));
    assert!(
        *bar.last().unwrap() >= f64::from(deepest),
        "the bar holds the press: {bar:?}"
    );
    let title = texts.iter().find(|t| t.starts_with("frame ")).unwrap();
    assert!(
        title.contains(&format!("frame {seq}")) && title.contains(" N"),
        "{title}"
    );
    snapshot::write_ply(&frame, &dir.join("surface.ply")).unwrap();
    let ply = std::fs::read_to_string(dir.join("surface.ply")).unwrap();
    assert!(ply.starts_with("ply\n") && ply.contains("element face "));
    std::fs::remove_dir_all(&dir).ok();
    served.device.join().unwrap().unwrap();
}
