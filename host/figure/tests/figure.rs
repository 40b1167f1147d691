//! Figures rendered and read back: the SVG twin's text says what the picture shows.

use vistaf_figure::{Frame, Grid, Picture, Ranges, Readout};

/// A 1.2 mm deep spherical dimple in a 32 × 24 mm skin, warm at its centre, under a grating.
fn press() -> Frame {
    let (w, h, pitch) = (160usize, 120usize, 0.2);
    let (cx, cy, r2) = (90.0, 50.0, 30.0f64 * 30.0);
    let depth: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            let q = 1.0 - ((x - cx).powi(2) + (y - cy).powi(2)) / r2;
            (1.2 * q.max(0.0).powf(1.5)) as f32
        })
        .collect();
    let (tw, th) = (16usize, 12usize);
    let temp: Vec<f32> = (0..tw * th)
        .map(|i| {
            let (x, y) = ((i % tw) as f64, (i / tw) as f64);
            (26.0 + 6.0 * (-((x - 9.0).powi(2) + (y - 5.0).powi(2)) / 8.0).exp()) as f32
        })
        .collect();
    let rgb = (0..w * h)
        .flat_map(|i| {
            let s = ((i % w) as f64 * std::f64::consts::TAU / 10.0).sin();
            [(120.0 + 100.0 * s) as u8, 60, (120.0 - 100.0 * s) as u8]
        })
        .collect();
    Frame {
        camera: Some(Picture {
            width: w,
            height: h,
            pitch_mm: pitch,
            rgb,
        }),
        depth_mm: Some(Grid {
            width: w,
            height: h,
            pitch_mm: pitch,
            values: depth,
        }),
        temperature_c: Some(Grid {
            width: tw,
            height: th,
            pitch_mm: 2.0,
            values: temp,
        }),
        readout: Readout {
            label: "frame 93".into(),
            force_n: Some(12.36),
            depth_mm: Some(1.2),
            contact_temp_c: Some(31.4),
            flags: vec!["phase_slope".into()],
        },
    }
}

/// Every `<text>` element's content, in document order.
fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = &t[t.find('>')? + 1..];
            Some(body[..body.find("</text>")?].trim().to_string())
        })
        .collect()
}

/// The numbers of the colour bar titled `title`: the labels ending in ` unit` that follow
/// its title.
fn bar_labels(texts: &[String], title: &str, unit: &str) -> Vec<f64> {
    let suffix = format!(" {unit}");
    texts
        .iter()
        .skip_while(|t| t.as_str() != title)
        .skip(1)
        .map_while(|t| t.strip_suffix(&suffix))
        .filter_map(|n| n.parse().ok())
        .collect()
}

#[test]
fn the_colour_bars_are_numbered_over_their_fixed_ranges() {
    let dir = std::env::temp_dir().join(format!("vistaf-figure-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let frame = press();
    let ranges = Ranges {
        depth_mm: (0.0, 1.5),
        temperature_c: (24.0, 34.0),
    };
    let written = vistaf_figure::write(&frame, &ranges, &dir.join("fig.png")).unwrap();
    let png = std::fs::read(&written.png).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let svg = std::fs::read_to_string(&written.svg).unwrap();
    let t = texts(&svg);

    // Depth: 0 to 1.5 mm in round steps, every tick numbered with its unit.
    let depth = bar_labels(&t, "depth", "mm");
    assert_eq!(depth.first(), Some(&0.0), "{t:?}");
    assert_eq!(depth.last(), Some(&1.5));
    assert!(depth.len() >= 3 && depth.windows(2).all(|w| w[1] > w[0]));
    // Temperature: 24 to 34 °C.
    let temp = bar_labels(&t, "temperature", "°C");
    assert_eq!(temp.first(), Some(&24.0), "{t:?}");
    assert_eq!(temp.last(), Some(&34.0));
    assert!(temp.len() >= 4);
    // The bars say what they are, the axes are in mm, the marks name the extremes.
    for want in [
        "depth",
        "temperature",
        "x, mm",
        "y, mm",
        "max 32.0 °C",
        "min 26.0 °C",
    ] {
        assert!(t.iter().any(|s| s == want), "no {want:?} in {t:?}");
    }
    // The title carries the frame's numbers and flags.
    let title = t.iter().find(|s| s.starts_with("frame 93")).expect("title");
    for want in [
        "force 12.36 N",
        "depth 1.200 mm",
        "contact 31.4 °C",
        "flags: phase_slope",
    ] {
        assert!(title.contains(want), "{title}");
    }
    if std::env::var_os("VISTAF_KEEP_FIGURE").is_none() {
        std::fs::remove_dir_all(&dir).ok();
    }
}

#[test]
fn the_same_ranges_give_the_same_colours_across_frames() {
    let dir = std::env::temp_dir().join(format!("vistaf-figure-r-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let strong = press();
    let mut weak = press();
    if let Some(g) = weak.depth_mm.as_mut() {
        g.values.iter_mut().for_each(|v| *v /= 2.0);
    }
    let ranges = Ranges::covering([&strong, &weak]);
    assert_eq!(ranges.depth_mm, (0.0, 1.5));
    for (name, f) in [("strong.png", &strong), ("weak.png", &weak)] {
        let svg = std::fs::read_to_string(
            vistaf_figure::write(f, &ranges, &dir.join(name))
                .unwrap()
                .svg,
        )
        .unwrap();
        let labels = bar_labels(&texts(&svg), "depth", "mm");
        assert!(
            labels.contains(&1.5),
            "{name}: the weak press keeps the session's bar"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
