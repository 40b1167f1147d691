//! The host side of the demo: the standard readout (live view and recording), and the
//! maps at the strongest press, asked for whenever the force passes its maximum so far.

use std::path::Path;
use std::time::Duration;

use anyhow::{Context, Result};
use vistaf_host::client::{describe, Client, Received, DEFAULT_TIMEOUT};
use vistaf_host::monitor::Monitor;
use vistaf_host::multi::DeviceStats;
use vistaf_host::record::{Recorder, SummaryRecord};
use vistaf_host::stream::{stream, Consumer, Limits, Readout};
use vistaf_host::HostError;
use vistaf_protocol::{DeviceMsg, HostMsg, Map, MapKind};

use crate::device::{SimulatedSkin, FPS};

/// Force (mN) a press must pass before maps are asked for: below it there is nothing to
/// draw.
const FIRST_PEAK_MN: u32 = 500;

/// What the host saw.
#[derive(Debug, Default)]
pub struct Watched {
    /// Every summary, in order.
    pub summaries: Vec<SummaryRecord>,
    /// The force of the press the maps were asked at, mN.
    pub peak_mn: u32,
    /// Its depth map.
    pub depth: Option<Map>,
    /// Its temperature map.
    pub temperature: Option<Map>,
    /// Why the stream stopped early, if it did.
    pub failure: Option<HostError>,
}

/// The readout, plus the peak maps.
struct PeakWatch {
    readout: Readout,
    commander: Client,
    seen: Watched,
    threshold_mn: u32,
}

impl Consumer for PeakWatch {
    fn message(
        &mut self,
        device: usize,
        stats: &[DeviceStats],
        received: &Received,
    ) -> Result<(), HostError> {
        match &received.msg {
            DeviceMsg::Summary(s) => {
                self.seen.summaries.push(SummaryRecord::from(s));
                // Whenever the force passes its maximum so far by 10 %, both maps (they
                // come from the next frame); the last pair is kept.
                if s.force_mn > self.threshold_mn + self.threshold_mn / 10 {
                    self.threshold_mn = s.force_mn;
                    self.seen.peak_mn = s.force_mn;
                    for kind in [MapKind::Depth, MapKind::Temperature] {
                        if let Err(e) = self.commander.send(&HostMsg::RequestMap(kind)) {
                            eprintln!("requesting a map: {e}");
                        }
                    }
                }
            }
            DeviceMsg::Map(m) => match m.kind {
                MapKind::Depth => self.seen.depth = Some(m.clone()),
                MapKind::Temperature => self.seen.temperature = Some(m.clone()),
            },
            _ => {}
        }
        self.readout.message(device, stats, received)
    }
    fn ended(&mut self, device: usize, stats: &[DeviceStats]) {
        self.readout.ended(device, stats);
    }
    fn failed(&mut self, device: usize, stats: &[DeviceStats], error: &HostError) {
        self.readout.failed(device, stats, error);
    }
    fn tick(&mut self, stats: &[DeviceStats]) {
        self.readout.tick(stats);
    }
}

/// Reads the skin for `frames` summaries (or their duration and some), recording into
/// `out/summaries.jsonl` and drawing the peak maps into `out`.
pub fn watch(device: &SimulatedSkin, frames: usize, out: &Path) -> Result<Watched> {
    let (mut client, commander) = device.host_ends()?;
    let hello = client
        .handshake(DEFAULT_TIMEOUT)
        .context("the simulated skin did not say hello")?;
    eprintln!("{}: {}", client.name(), describe(&hello));
    let mut watch = PeakWatch {
        readout: Readout {
            recorder: Some(Recorder::create(&out.join("summaries.jsonl"))?),
            monitor: Monitor::new(1, true),
        },
        commander,
        seen: Watched::default(),
        threshold_mn: FIRST_PEAK_MN,
    };
    let limits = Limits {
        summaries: Some(frames as u64),
        duration: Some(Duration::from_secs_f64(
            frames as f64 / f64::from(FPS) + 20.0,
        )),
    };
    let outcome = stream(vec![client], &limits, &mut watch)?;
    watch.readout.finish(&outcome);
    for (name, map) in [
        ("depth_at_peak.png", &watch.seen.depth),
        ("temperature_at_peak.png", &watch.seen.temperature),
    ] {
        if let Some(m) = map {
            vistaf_firmware::maps::wire_map_png(m, &out.join(name))?;
        }
    }
    watch.seen.failure = outcome.failure;
    Ok(watch.seen)
}
