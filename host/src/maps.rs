//! Maps as the host uses them: a coarse [`Map`] or the pieces of a full one
//! ([`MapChunk`]s, put together by an [`Assembler`]) as one [`WholeMap`], read in SI units;
//! one frame's maps with its summary ([`Snapshot`], collected by a [`Collector`]).

use std::collections::VecDeque;

use serde_json::{json, Value};
use vistaf_protocol::msg::MAP_NO_DATA;
use vistaf_protocol::{DeviceMsg, Map, MapChunk, MapKind, Summary};

/// A whole map: the cells in the wire's units, with their size and pitch.
#[derive(Debug, Clone, PartialEq)]
pub struct WholeMap {
    /// The frame it was taken from (a `Summary`'s `seq`).
    pub seq: u32,
    /// What the cells hold.
    pub kind: MapKind,
    /// Cells per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Side of one cell on the skin, mm.
    pub pitch_mm: f64,
    /// Row-major cells: µm, 0.01 °C or RGB 5-6-5 (see [`MapKind`]).
    pub cells: Vec<i16>,
}

/// A kind's name in outputs, its SI unit, and the factor from the wire's cells to it.
pub fn kind_si(kind: MapKind) -> (&'static str, &'static str, f64) {
    match kind {
        MapKind::Depth => ("depth", "mm", 1e-3),
        MapKind::Temperature => ("temperature", "°C", 1e-2),
        MapKind::Camera => ("camera", "RGB", 1.0),
    }
}

impl WholeMap {
    /// A coarse map as a whole one (`None` when its cells do not fill it).
    pub fn from_coarse(m: &Map) -> Option<WholeMap> {
        m.is_consistent().then(|| WholeMap {
            seq: m.seq,
            kind: m.kind,
            width: usize::from(m.width),
            height: usize::from(m.height),
            pitch_mm: f64::from(m.cell_pitch_centi_mm) / 100.0,
            cells: m.cells.to_vec(),
        })
    }

    /// The cells in SI units (depth mm, temperature °C), NaN where the device trusts no
    /// value; `None` for the camera image, which is colour ([`WholeMap::rgb`]).
    pub fn si(&self) -> Option<Vec<f32>> {
        let (_, _, k) = kind_si(self.kind);
        (self.kind != MapKind::Camera).then(|| {
            self.cells
                .iter()
                .map(|&c| {
                    if c == MAP_NO_DATA {
                        f32::NAN
                    } else {
                        (f64::from(c) * k) as f32
                    }
                })
                .collect()
        })
    }

    /// The camera image as 8-bit RGB, three bytes per cell; `None` for other kinds.
    pub fn rgb(&self) -> Option<Vec<u8>> {
        (self.kind == MapKind::Camera).then(|| self.cells.iter().flat_map(|&c| rgb565(c)).collect())
    }

    /// The map as JSON in SI units: cells in mm or °C (`null` where untrusted), the pitch
    /// in mm; the camera's cells as `[r, g, b]`.
    pub fn to_json(&self) -> Value {
        let (kind, unit, _) = kind_si(self.kind);
        json!({
            "seq": self.seq,
            "kind": kind,
            "unit": unit,
            "width": self.width,
            "height": self.height,
            "cell_pitch_mm": self.pitch_mm,
            "cells": cells_json(self.kind, &self.cells),
        })
    }
}

/// Cells of `kind` as JSON in SI units: numbers in mm or °C (`null` where untrusted), or
/// `[r, g, b]` for the camera.
pub fn cells_json(kind: MapKind, cells: &[i16]) -> Value {
    let (_, _, k) = kind_si(kind);
    match kind {
        MapKind::Camera => json!(cells.iter().map(|&c| rgb565(c)).collect::<Vec<_>>()),
        _ => json!(cells
            .iter()
            .map(|&c| (c != MAP_NO_DATA).then(|| f64::from(c) * k))
            .collect::<Vec<_>>()),
    }
}

/// An RGB 5-6-5 cell as 8-bit RGB, each field stretched to 0…255 (its top bits repeated
/// below).
pub fn rgb565(c: i16) -> [u8; 3] {
    let v = c as u16;
    let (r, g, b) = (v >> 11, (v >> 5) & 0x3f, v & 0x1f);
    [
        (r << 3) | (r >> 2),
        (g << 2) | (g >> 4),
        (b << 3) | (b >> 2),
    ]
    .map(|x| x as u8)
}

/// A piece of a full map as JSON in SI units, where it goes in its map beside it.
pub fn chunk_json(c: &MapChunk) -> Value {
    let (kind, unit, _) = kind_si(c.kind);
    json!({
        "seq": c.seq,
        "kind": kind,
        "unit": unit,
        "width": c.width,
        "height": c.height,
        "cell_pitch_mm": f64::from(c.cell_pitch_nm) * 1e-6,
        "first_cell": c.first_cell,
        "cells": cells_json(c.kind, &c.cells),
    })
}

/// Puts the pieces of full maps together, one map per kind at a time.
///
/// Pieces come in order; a piece that does not continue the map in progress (a lost piece
/// on a lossy link, or the next frame's map) drops the unfinished one, which is counted, and
/// starts afresh when it is a first piece.
#[derive(Debug, Default)]
pub struct Assembler {
    partial: Vec<WholeMap>,
    dropped: u64,
}

impl Assembler {
    /// An assembler with nothing in progress.
    pub fn new() -> Assembler {
        Assembler::default()
    }

    /// Takes one piece; the whole map when it was the last.
    pub fn add(&mut self, c: &MapChunk) -> Option<WholeMap> {
        if !c.is_consistent() {
            return None;
        }
        let at = self.partial.iter().position(|m| m.kind == c.kind);
        let continues = at.is_some_and(|i| {
            let m = &self.partial[i];
            m.seq == c.seq
                && (m.width, m.height) == (usize::from(c.width), usize::from(c.height))
                && m.cells.len() == c.first_cell as usize
        });
        if !continues {
            if let Some(i) = at {
                self.partial.swap_remove(i);
                self.dropped += 1;
            }
            if c.first_cell != 0 {
                return None;
            }
            self.partial.push(WholeMap {
                seq: c.seq,
                kind: c.kind,
                width: usize::from(c.width),
                height: usize::from(c.height),
                pitch_mm: f64::from(c.cell_pitch_nm) * 1e-6,
                cells: Vec::with_capacity(c.total_cells()),
            });
        }
        let i = self.partial.iter().position(|m| m.kind == c.kind)?;
        self.partial[i].cells.extend(c.cells.iter().copied());
        (self.partial[i].cells.len() == c.total_cells()).then(|| self.partial.swap_remove(i))
    }

    /// Unfinished maps given up so far.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}

/// One frame's full maps and, when it was streamed, its summary.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// The frame's summary.
    pub summary: Option<Summary>,
    /// The maps, in the order asked for.
    pub maps: Vec<WholeMap>,
}

/// Summaries kept to find the one of a frame whose maps come after it.
const RECENT_SUMMARIES: usize = 16;

/// Collects one frame's full maps of the kinds asked for, with the frame's summary, from
/// the device's messages as they come: a [`Snapshot`] once every kind has come whole from
/// the same frame (a map of a newer frame starts the set afresh).
#[derive(Debug)]
pub struct Collector {
    kinds: Vec<MapKind>,
    assembler: Assembler,
    maps: Vec<WholeMap>,
    recent: VecDeque<Summary>,
}

impl Collector {
    /// A collector of the maps of `kinds`.
    pub fn new(kinds: &[MapKind]) -> Collector {
        Collector {
            kinds: kinds.to_vec(),
            assembler: Assembler::new(),
            maps: Vec::new(),
            recent: VecDeque::new(),
        }
    }

    /// Takes one message; the snapshot when it completed one.
    pub fn take(&mut self, msg: &DeviceMsg) -> Option<Snapshot> {
        match msg {
            DeviceMsg::Summary(s) => {
                if self.recent.len() == RECENT_SUMMARIES {
                    self.recent.pop_front();
                }
                self.recent.push_back(*s);
                None
            }
            DeviceMsg::MapChunk(c) if self.kinds.contains(&c.kind) => {
                let whole = self.assembler.add(c)?;
                self.maps
                    .retain(|m| m.seq == whole.seq && m.kind != whole.kind);
                self.maps.push(whole);
                if self.maps.len() < self.kinds.len() {
                    return None;
                }
                let mut maps = std::mem::take(&mut self.maps);
                maps.sort_by_key(|m| self.kinds.iter().position(|k| *k == m.kind));
                let seq = maps[0].seq;
                Some(Snapshot {
                    summary: self.recent.iter().rev().find(|s| s.seq == seq).copied(),
                    maps,
                })
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pieces(seq: u32, kind: MapKind, w: u16, h: u16, per: usize) -> Vec<MapChunk> {
        let cells: Vec<i16> = (0..i32::from(w) * i32::from(h)).map(|i| i as i16).collect();
        cells
            .chunks(per)
            .enumerate()
            .map(|(i, p)| MapChunk {
                seq,
                kind,
                width: w,
                height: h,
                cell_pitch_nm: 50_000,
                first_cell: (i * per) as u32,
                cells: p.iter().copied().collect(),
            })
            .collect()
    }

    #[test]
    fn interleaved_kinds_come_out_whole() {
        let mut a = Assembler::new();
        let d = pieces(3, MapKind::Depth, 40, 30, 500);
        let t = pieces(3, MapKind::Temperature, 10, 8, 30);
        let mut done = Vec::new();
        for i in 0..d.len().max(t.len()) {
            for p in [d.get(i), t.get(i)].into_iter().flatten() {
                done.extend(a.add(p));
            }
        }
        assert_eq!(done.len(), 2);
        let depth = done.iter().find(|m| m.kind == MapKind::Depth).unwrap();
        assert_eq!(depth.cells.len(), 1200);
        assert_eq!(depth.cells[1199], 1199);
        assert!((depth.pitch_mm - 0.05).abs() < 1e-12);
        assert_eq!(depth.si().unwrap()[1000], 1.0);
        assert_eq!(a.dropped(), 0);
    }

    #[test]
    fn a_lost_piece_drops_the_map_and_the_next_one_still_comes() {
        let mut a = Assembler::new();
        let first = pieces(1, MapKind::Depth, 40, 30, 500);
        let second = pieces(2, MapKind::Depth, 40, 30, 500);
        assert!(a.add(&first[0]).is_none());
        assert!(
            a.add(&first[2]).is_none(),
            "a gap is not filled by what follows it"
        );
        let whole: Vec<_> = second.iter().filter_map(|p| a.add(p)).collect();
        assert_eq!(whole.len(), 1);
        assert_eq!(whole[0].seq, 2);
        assert_eq!(a.dropped(), 1);
    }

    #[test]
    fn a_snapshot_is_one_frames_maps_with_its_summary() {
        let summary = |seq| {
            DeviceMsg::Summary(Summary {
                seq,
                capture_us: 0,
                latency_us: 0,
                force_mn: 1000 + seq,
                peak_depth_um: 0,
                contact_area_centi_mm2: 0,
                volume_milli_mm3: 0,
                centroid: None,
                temp_min_centi_c: 0,
                temp_mean_centi_c: 0,
                temp_max_centi_c: 0,
                contact_temp_centi_c: None,
                flags: vistaf_protocol::QualityFlags::default(),
            })
        };
        let mut c = Collector::new(&[MapKind::Camera, MapKind::Depth]);
        let mut got = Vec::new();
        // Frame 4's depth, then frame 5's summary and its maps: the camera first (with
        // frame 4's depth it would make a set of two frames), a temperature map not asked
        // for, then the depth.
        let mut feed = |m: DeviceMsg| got.extend(c.take(&m));
        let order = [
            (4, MapKind::Depth),
            (5, MapKind::Camera),
            (5, MapKind::Temperature),
            (5, MapKind::Depth),
        ];
        feed(summary(5));
        for (seq, kind) in order {
            for p in pieces(seq, kind, 40, 30, 768) {
                feed(DeviceMsg::MapChunk(p));
            }
        }
        assert_eq!(
            got.len(),
            1,
            "one whole set, not frame 4's depth with frame 5's camera"
        );
        let kinds: Vec<MapKind> = got[0].maps.iter().map(|m| m.kind).collect();
        assert_eq!(
            kinds,
            [MapKind::Camera, MapKind::Depth],
            "in the order asked for"
        );
        assert!(got[0].maps.iter().all(|m| m.seq == 5));
        assert_eq!(got[0].summary.map(|s| s.force_mn), Some(1005));
    }

    #[test]
    fn camera_cells_are_colour() {
        let m = WholeMap {
            seq: 0,
            kind: MapKind::Camera,
            width: 2,
            height: 1,
            pitch_mm: 0.1,
            cells: vec![0xf800u16 as i16, 0x07ff],
        };
        assert_eq!(m.rgb().unwrap(), vec![255, 0, 0, 0, 255, 255]);
        assert!(m.si().is_none());
        assert_eq!(m.to_json()["cells"][1], json!([0, 255, 255]));
    }
}
