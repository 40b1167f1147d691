//! Frame sets: byte-exact round trips, and a precise refusal for every malformed set.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::fs;
use std::path::{Path, PathBuf};

use vistaf_hardware::frameset::{copy_set, FrameEntry, FrameSet, FrameSetWriter};
use vistaf_hardware::source::{FrameSource, Pacing, SetReplay};
use vistaf_sim::{scene, sets, SensorUnit};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vistaf-fs-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    d
}

fn small_unit() -> SensorUnit {
    SensorUnit::reference_sized(96, 64)
}

fn sample_set(dir: &Path) -> FrameSet {
    let unit = small_unit();
    let states = scene::states("press-sphere", &unit, 3).unwrap();
    let opts = sets::SetOptions {
        truth_maps: true,
        seed: 5,
        unit_seed: 0,
        encoding: Default::default(),
    };
    sets::write_states(dir, "press-sphere", &unit, &states, &opts, |_, _| {}).unwrap()
}

fn all_bytes(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((
                    p.strip_prefix(dir).unwrap().display().to_string(),
                    fs::read(&p).unwrap(),
                ));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn write_read_write_is_byte_exact() {
    let a = tmp("rt-a");
    let set = sample_set(&a);
    assert_eq!(set.len(), 3);
    assert_eq!(set.size(), (96, 64));
    // Labels and unknown keys survive.
    let f = &set.manifest.frames[1];
    assert!(f.depth_mm.unwrap() > 1.9 && f.force_n.unwrap() > 0.0 && f.contact_x_px.is_some());
    assert!(f.extra.contains_key("truth_depth_png"));
    assert!(set.manifest.extra.contains_key("simulator"));
    // Same inputs → same bytes.
    let b = tmp("rt-b");
    sample_set(&b);
    assert_eq!(all_bytes(&a), all_bytes(&b));
    // Read and rewrite → same frames and manifest.
    let c = tmp("rt-c");
    let copy = copy_set(&set, &c).unwrap();
    for name in std::iter::once("set.json".to_string())
        .chain(set.manifest.frames.iter().map(|f| f.file.clone()))
    {
        assert_eq!(
            fs::read(a.join(&name)).unwrap(),
            fs::read(c.join(&name)).unwrap(),
            "{name}"
        );
    }
    assert_eq!(copy.manifest, set.manifest);
    for d in [a, b, c] {
        fs::remove_dir_all(d).unwrap();
    }
}

/// Writes a valid two-frame set and returns its directory.
fn valid(name: &str) -> PathBuf {
    let d = tmp(name);
    let img = image::RgbImage::from_pixel(8, 6, image::Rgb([10, 20, 30]));
    let mut w = FrameSetWriter::create(&d, 2.0, &img).unwrap();
    w.add(
        &img,
        FrameEntry {
            depth_mm: Some(0.5),
            ..Default::default()
        },
    )
    .unwrap();
    w.add(&img, FrameEntry::default()).unwrap();
    w.finish().unwrap();
    d
}

fn edit_manifest(d: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let p = d.join("set.json");
    let mut v: serde_json::Value = serde_json::from_str(&fs::read_to_string(&p).unwrap()).unwrap();
    f(&mut v);
    fs::write(p, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

fn refused(d: &Path) -> String {
    let e = FrameSet::open(d).unwrap_err();
    fs::remove_dir_all(d).unwrap();
    e.to_string()
}

#[test]
fn missing_manifest() {
    let d = valid("no-manifest");
    fs::remove_file(d.join("set.json")).unwrap();
    let e = refused(&d);
    assert!(e.contains("set.json") && e.contains("No such file"), "{e}");
}

#[test]
fn invalid_json_names_line_and_column() {
    let d = valid("bad-json");
    fs::write(
        d.join("set.json"),
        "{\n  \"format\": \"vistaf-frames/1\",\n  oops\n}",
    )
    .unwrap();
    let e = refused(&d);
    assert!(e.contains("set.json") && e.contains("line 3"), "{e}");
}

#[test]
fn missing_required_key() {
    let d = valid("no-period");
    edit_manifest(&d, |v| {
        v.as_object_mut().unwrap().remove("grating_period_mm");
    });
    let e = refused(&d);
    assert!(e.contains("grating_period_mm"), "{e}");
}

#[test]
fn wrong_format_tag() {
    let d = valid("format");
    edit_manifest(&d, |v| v["format"] = "vistaf-frames/2".into());
    let e = refused(&d);
    assert!(
        e.contains("vistaf-frames/2") && e.contains("expected"),
        "{e}"
    );
}

#[test]
fn non_positive_period() {
    let d = valid("period");
    edit_manifest(&d, |v| v["grating_period_mm"] = 0.0.into());
    let e = refused(&d);
    assert!(
        e.contains("grating_period_mm") && e.contains("above 0"),
        "{e}"
    );
    let d = valid("period-huge");
    edit_manifest(&d, |v| v["grating_period_mm"] = 1e300.into());
    let e = refused(&d);
    assert!(e.contains("grating_period_mm = 1e300"), "{e}");
}

#[test]
fn negative_label() {
    let d = valid("neg");
    edit_manifest(&d, |v| v["frames"][1]["force_n"] = (-1.0).into());
    let e = refused(&d);
    assert!(
        e.contains("frames[1].force_n") && e.contains("0 to 10 000 N"),
        "{e}"
    );
    // Absurdly large labels and times are refused as surely as negative ones.
    for (key, v) in [("force_n", 1e300), ("depth_mm", 1e300), ("t_ms", 1e15)] {
        let d = valid(&format!("huge-{key}"));
        edit_manifest(&d, |m| m["frames"][1][key] = v.into());
        let e = refused(&d);
        assert!(e.contains(&format!("frames[1].{key} = {v:e}")), "{e}");
    }
}

#[test]
fn absurd_temperature() {
    let d = valid("temp");
    edit_manifest(&d, |v| v["frames"][0]["temperature_c"] = 900.0.into());
    let e = refused(&d);
    assert!(e.contains("frames[0].temperature_c"), "{e}");
}

#[test]
fn parent_and_absolute_paths_are_refused() {
    for (name, bad) in [
        ("dotdot", "../outside.png"),
        ("abs", "/etc/passwd"),
        ("empty", ""),
    ] {
        let d = valid(name);
        edit_manifest(&d, |v| v["frames"][0]["file"] = bad.into());
        let e = refused(&d);
        assert!(
            e.contains("frames[0].file") && e.contains("leaves the set"),
            "{bad}: {e}"
        );
    }
    let d = valid("ref-dotdot");
    edit_manifest(&d, |v| v["reference"] = "../r.png".into());
    assert!(refused(&d).contains("reference"));
}

#[test]
fn symlink_out_of_the_set_is_refused() {
    let d = valid("symlink");
    let outside = tmp("outside.png");
    fs::copy(d.join("f0000.png"), &outside).unwrap();
    fs::remove_file(d.join("f0000.png")).unwrap();
    std::os::unix::fs::symlink(&outside, d.join("f0000.png")).unwrap();
    let e = refused(&d);
    fs::remove_file(outside).unwrap();
    assert!(e.contains("outside the set"), "{e}");
}

#[test]
fn missing_frame_file() {
    let d = valid("missing");
    fs::remove_file(d.join("f0001.png")).unwrap();
    let e = refused(&d);
    assert!(e.contains("f0001.png") && e.contains("missing"), "{e}");
}

#[test]
fn not_a_png() {
    let d = valid("notpng");
    fs::write(d.join("f0000.png"), b"GIF89a not really").unwrap();
    let e = refused(&d);
    assert!(e.contains("f0000.png") && e.contains("not a PNG"), "{e}");
}

#[test]
fn truncated_png_names_the_file_on_load() {
    let d = valid("trunc");
    let bytes = fs::read(d.join("f0000.png")).unwrap();
    fs::write(d.join("f0000.png"), &bytes[..bytes.len() - 20]).unwrap();
    let set = FrameSet::open(&d).unwrap();
    let e = set.load_frame(0).unwrap_err().to_string();
    fs::remove_dir_all(&d).unwrap();
    assert!(e.contains("f0000.png"), "{e}");
}

#[test]
fn size_mismatch() {
    let d = valid("size");
    image::RgbImage::new(9, 6)
        .save(d.join("f0001.png"))
        .unwrap();
    let e = refused(&d);
    assert!(
        e.contains("f0001.png") && e.contains("9×6") && e.contains("8×6"),
        "{e}"
    );
}

#[test]
fn sixteen_bit_frames_are_refused_and_gray_and_rgba_accepted() {
    let d = valid("pixtypes");
    image::GrayImage::from_pixel(8, 6, image::Luma([7]))
        .save(d.join("f0000.png"))
        .unwrap();
    image::RgbaImage::from_pixel(8, 6, image::Rgba([1, 2, 3, 0]))
        .save(d.join("f0001.png"))
        .unwrap();
    let set = FrameSet::open(&d).unwrap();
    assert_eq!(set.load_frame(0).unwrap().get_pixel(0, 0).0, [7, 7, 7]);
    assert_eq!(set.load_frame(1).unwrap().get_pixel(0, 0).0, [1, 2, 3]);
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(8, 6)
        .save(d.join("f0000.png"))
        .unwrap();
    let e = set.load_frame(0).unwrap_err().to_string();
    fs::remove_dir_all(&d).unwrap();
    assert!(e.contains("f0000.png") && e.contains("not accepted"), "{e}");
}

#[test]
fn unknown_keys_are_kept_on_rewrite() {
    let d = valid("extra");
    edit_manifest(&d, |v| {
        v["lab"] = "bench 3".into();
        v["frames"][0]["indenter"] = "sphere-10".into();
    });
    let set = FrameSet::open(&d).unwrap();
    let c = tmp("extra-copy");
    let copy = copy_set(&set, &c).unwrap();
    assert_eq!(copy.manifest.extra["lab"], "bench 3");
    assert_eq!(copy.manifest.frames[0].extra["indenter"], "sphere-10");
    fs::remove_dir_all(d).unwrap();
    fs::remove_dir_all(c).unwrap();
}

#[test]
fn replay_delivers_every_frame_in_order_and_loops() {
    let d = tmp("replay");
    let set = sample_set(&d);
    let want: Vec<_> = (0..set.len()).map(|i| set.load_frame(i).unwrap()).collect();
    let mut src = SetReplay::new(set, Pacing::AsFastAsPossible, true);
    assert_eq!(src.format().width, 96);
    for round in 0..2 {
        for (i, w) in want.iter().enumerate() {
            let f = src.next_frame().unwrap().unwrap();
            assert_eq!(f.seq as usize, round * want.len() + i);
            assert_eq!(&f.to_rgb().unwrap(), w);
        }
    }
    let mut once = SetReplay::open(&d, Pacing::Recorded, false).unwrap();
    for _ in 0..want.len() {
        assert!(once.next_frame().unwrap().is_some());
    }
    assert!(once.next_frame().unwrap().is_none());
    fs::remove_dir_all(d).unwrap();
}
