//! The host side of the demo: the standard readout (live view and recording), and the
//! figure of the strongest press: full maps asked for whenever the force passes its
//! maximum so far (they come from the next frame), the set of the strongest frame kept.

use std::path::Path;
use std::time::Duration;

use anyhow::{Context, Result};
use vistaf_host::client::{describe, Client, Received, DEFAULT_TIMEOUT};
use vistaf_host::maps::{Collector, Snapshot};
use vistaf_host::monitor::Monitor;
use vistaf_host::multi::DeviceStats;
use vistaf_host::record::{Recorder, SummaryRecord};
use vistaf_host::snapshot::FIGURE_MAPS;
use vistaf_host::stream::{stream, Consumer, Limits, Readout};
use vistaf_host::HostError;
use vistaf_protocol::{DeviceMsg, HostMsg, Summary};

use crate::device::{SimulatedSkin, FPS};

/// Force (mN) a press must pass before maps are asked for: below it there is nothing to
/// draw.
const FIRST_PEAK_MN: u32 = 500;

/// The figure of the strongest press, in the session folder.
pub const PEAK_FIGURE: &str = "peak.png";

/// What the host saw.
#[derive(Debug, Default)]
pub struct Watched {
    /// Every summary, in order.
    pub summaries: Vec<SummaryRecord>,
    /// The strongest frame whose maps all came whole, with its summary.
    pub peak: Option<Snapshot>,
    /// Why the stream stopped early, if it did.
    pub failure: Option<HostError>,
}

/// The readout, plus the peak maps.
struct PeakWatch {
    readout: Readout,
    commander: Client,
    seen: Watched,
    /// The strongest force asked for so far, mN.
    strongest_mn: u32,
    /// The maps of the frame after each new maximum.
    collector: Collector,
}

impl PeakWatch {
    /// Asks for the next frame's maps when `s` is the strongest press so far.
    fn summary(&mut self, s: &Summary) {
        self.seen.summaries.push(SummaryRecord::from(s));
        if s.force_mn > self.strongest_mn {
            self.strongest_mn = s.force_mn;
            for kind in FIGURE_MAPS {
                if let Err(e) = self.commander.send(&HostMsg::RequestFullMap(kind)) {
                    eprintln!("requesting a map: {e}");
                }
            }
        }
    }

    /// A frame's maps came whole: kept when it is the strongest frame so far.
    fn snapshot(&mut self, shot: Snapshot) {
        let force = |s: &Snapshot| s.summary.map_or(0, |s| s.force_mn);
        if self
            .seen
            .peak
            .as_ref()
            .is_none_or(|kept| force(&shot) >= force(kept))
        {
            self.seen.peak = Some(shot);
        }
    }
}

impl Consumer for PeakWatch {
    fn message(
        &mut self,
        device: usize,
        stats: &[DeviceStats],
        received: &Received,
    ) -> Result<(), HostError> {
        if let Some(shot) = self.collector.take(&received.msg) {
            self.snapshot(shot);
        }
        match &received.msg {
            DeviceMsg::Summary(s) => self.summary(s),
            // The pieces go into the figure, not into the session's record.
            DeviceMsg::MapChunk(_) => return Ok(()),
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
/// `out/summaries.jsonl` and drawing the strongest press into `out/peak.png`.
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
        strongest_mn: FIRST_PEAK_MN,
        collector: Collector::new(&FIGURE_MAPS),
    };
    let limits = Limits {
        summaries: Some(frames as u64),
        duration: Some(Duration::from_secs_f64(
            frames as f64 / f64::from(FPS) + 20.0,
        )),
    };
    let outcome = stream(vec![client], &limits, &mut watch)?;
    watch.readout.finish(&outcome);
    if let Some(peak) = &watch.seen.peak {
        let frame = vistaf_host::snapshot::frame(peak);
        let ranges = vistaf_figure::Ranges::covering([&frame]);
        vistaf_figure::write(&frame, &ranges, &out.join(PEAK_FIGURE))?;
    }
    watch.seen.failure = outcome.failure;
    Ok(watch.seen)
}
