//! The service's decisions, frame by frame, on a clock the test moves by hand (no test here
//! sleeps): the reference is taken once the image is stable, summaries follow the rate
//! limit, a drifting reference is flagged or renewed after a quiet spell, a camera outage
//! is reported and the state follows it, maps come with the next frame, and bad frames are
//! counted and skipped.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::sync::Arc;
use std::time::Duration;

use vistaf_firmware::service::{CameraEvent, ManualClock, ReferencePolicy, Service, Settings};
use vistaf_hardware::frame::Frame;
use vistaf_hardware::led::MemoryLedRing;
use vistaf_hardware::source::SourceFormat;
use vistaf_hardware::PixelFormat;
use vistaf_pipeline::Calibration;
use vistaf_protocol::{Command, DeviceMsg, ErrorCode, Flag, HostMsg, MapKind, RunState, Summary};
use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::{center_mm, states, ROOM_C, SPHERE_R_MM};
use vistaf_sim::{Renderer, SensorUnit, SkinState};

/// Frames per second of the simulated camera.
const FPS: f64 = 30.0;

fn unit() -> SensorUnit {
    SensorUnit::reference_sized(320, 240)
}

fn settings(reference: ReferencePolicy) -> Settings {
    Settings {
        serial: "VSK-TEST".into(),
        force_calibration: true,
        reference,
        ..Settings::new(Calibration::default_sim())
    }
}

/// What a service under test runs with: its settings, LED ring and clock.
struct Rig {
    settings: Settings,
    led: MemoryLedRing,
    clock: ManualClock,
}

impl Rig {
    fn new(settings: Settings) -> Rig {
        Rig {
            settings,
            led: MemoryLedRing::default(),
            clock: ManualClock::new(),
        }
    }

    /// A service on the rig, and a simulated camera on its clock.
    fn start(&mut self) -> (Service<'_, &ManualClock>, Camera<'_>) {
        let Rig {
            settings,
            led,
            clock,
        } = self;
        let svc = Service::new(settings, format(), led, Arc::default(), &*clock);
        (svc, Camera::new(clock))
    }
}

fn format() -> SourceFormat {
    let u = unit();
    SourceFormat {
        width: u.width_px,
        height: u.height_px,
        pixel: PixelFormat::Rgb8,
        interval: None,
    }
}

/// A simulated camera stepping the clock one frame interval per frame.
struct Camera<'c> {
    renderer: Renderer,
    clock: &'c ManualClock,
    seq: u64,
}

impl<'c> Camera<'c> {
    fn new(clock: &'c ManualClock) -> Camera<'c> {
        Camera {
            renderer: Renderer::new(unit()),
            clock,
            seq: 0,
        }
    }

    /// Time passes without a frame.
    fn wait(&self, d: Duration) {
        self.clock.advance(d);
    }

    fn frame(&mut self, s: &SkinState) -> Frame {
        self.clock.advance(Duration::from_secs_f64(1.0 / FPS));
        let (img, _) = self.renderer.render(s, 11 + self.seq);
        self.seq += 1;
        Frame::from_rgb(
            img,
            Duration::from_secs_f64(self.seq as f64 / FPS),
            self.seq,
        )
    }
}

fn press(depth_mm: f32) -> SkinState {
    let mut s = SkinState::idle(ROOM_C);
    s.contacts.push(Contact {
        indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
        center_mm: center_mm(&unit()),
        depth_mm,
    });
    s
}

fn summaries(msgs: &[DeviceMsg]) -> Vec<Summary> {
    msgs.iter()
        .filter_map(|m| match m {
            DeviceMsg::Summary(s) => Some(*s),
            _ => None,
        })
        .collect()
}

fn states_of(msgs: &[DeviceMsg]) -> Vec<RunState> {
    msgs.iter()
        .filter_map(|m| match m {
            DeviceMsg::Status(s) => Some(s.state),
            _ => None,
        })
        .collect()
}

/// Feeds `scene` to the service, one frame each, collecting what it says.
fn feed<C: vistaf_firmware::service::Clock>(
    svc: &mut Service<'_, C>,
    cam: &mut Camera<'_>,
    scene: &[SkinState],
) -> Vec<DeviceMsg> {
    let mut out = Vec::new();
    for s in scene {
        out.extend(svc.on_frame(cam.frame(s)));
        out.extend(svc.on_tick());
    }
    out
}

#[test]
fn the_reference_waits_for_a_stable_image_then_summaries_follow() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    let hello = svc.start();
    assert!(matches!(&hello[..], [DeviceMsg::Hello(h)] if h.serial == "VSK-TEST"));
    let idle = SkinState::idle(ROOM_C);
    // The first frame has nothing to compare with; the second is as still as the first.
    assert!(svc.on_frame(cam.frame(&idle)).is_empty());
    let taken = svc.on_frame(cam.frame(&idle));
    assert_eq!(states_of(&taken), [RunState::Streaming]);
    let out = feed(&mut svc, &mut cam, &[idle.clone(), press(1.0)]);
    let s = summaries(&out);
    assert_eq!(s.len(), 2);
    assert_eq!((s[0].seq, s[1].seq), (0, 1));
    assert_eq!(s[0].force_mn, 0);
    let depth_mm = s[1].peak_depth_um as f32 / 1000.0;
    assert!((depth_mm - 1.0).abs() < 0.05, "{depth_mm}");
    assert_eq!(svc.counters().processed, 2);
    assert_eq!(svc.counters().references, 1);
    drop((svc, cam));
    assert!(rig.led.is_lit(), "the ring is lit at start");
}

#[test]
fn a_status_goes_out_once_a_second() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, cam) = rig.start();
    svc.start();
    assert!(svc.on_tick().is_none());
    cam.wait(Duration::from_millis(999));
    assert!(svc.on_tick().is_none());
    cam.wait(Duration::from_millis(1));
    match svc.on_tick() {
        Some(DeviceMsg::Status(s)) => {
            assert_eq!(s.state, RunState::Referencing);
            assert_eq!(s.uptime_ms, 1000);
        }
        other => panic!("{other:?}"),
    }
    cam.wait(Duration::from_millis(500));
    assert!(svc.on_tick().is_none());
    cam.wait(Duration::from_millis(500));
    assert!(svc.on_tick().is_some());
}

#[test]
fn summaries_follow_the_rate_limit() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    let idle = vec![SkinState::idle(ROOM_C); 2];
    feed(&mut svc, &mut cam, &idle);
    assert_eq!(
        svc.on_command(HostMsg::SetRate { max_rate_hz: 10 }),
        DeviceMsg::Ack(Command::SetRate)
    );
    let out = feed(&mut svc, &mut cam, &vec![SkinState::idle(ROOM_C); 30]);
    // One second of frames at 30 per second, summaries at 10 per second.
    assert_eq!(svc.counters().processed, 30);
    let n = summaries(&out).len();
    assert!((9..=11).contains(&n), "{n} summaries");
}

/// Idle frames for the reference, then the skin creeps and the light fades.
fn creeping() -> Vec<SkinState> {
    let mut s = vec![SkinState::idle(ROOM_C); 4];
    s.extend(states("creep", &unit(), 40).unwrap());
    s
}

#[test]
fn a_drifting_reference_is_flagged_stale_when_renewing_is_off() {
    let mut rig = Rig::new(settings(ReferencePolicy {
        auto_after_s: 0.0,
        ..Default::default()
    }));
    let (mut svc, mut cam) = rig.start();
    let out = feed(&mut svc, &mut cam, &creeping());
    assert_eq!(svc.counters().references, 1);
    let flags: Vec<bool> = summaries(&out)
        .iter()
        .map(|s| s.flags.contains(Flag::StaleReference))
        .collect();
    // Early frames are fresh; once the creep passes the limit every frame says so.
    assert!(!flags[0] && !flags[3], "{flags:?}");
    let first = flags.iter().position(|f| *f).unwrap();
    assert!(flags[first..].iter().all(|f| *f), "{flags:?}");
    assert!(first < flags.len() - 5, "{flags:?}");
    assert_eq!(svc.counters().stale as usize, flags.len() - first);
}

#[test]
fn a_drifting_reference_is_renewed_after_a_quiet_spell() {
    let mut rig = Rig::new(settings(ReferencePolicy {
        auto_after_s: 0.5,
        ..Default::default()
    }));
    let (mut svc, mut cam) = rig.start();
    let out = feed(&mut svc, &mut cam, &creeping());
    assert!(svc.counters().references >= 2, "{:?}", svc.counters());
    let states = states_of(&out);
    let renewed = states
        .iter()
        .position(|s| *s == RunState::Referencing)
        .unwrap();
    assert!(
        states[renewed..].contains(&RunState::Streaming),
        "a new reference follows: {states:?}"
    );
    // The skin had been calm longer than the spell when the drift showed: renewed at
    // once, no frame before it flagged.
    let first_renewal = out
        .iter()
        .position(|m| matches!(m, DeviceMsg::Status(s) if s.state == RunState::Referencing))
        .unwrap();
    assert!(summaries(&out[..first_renewal])
        .iter()
        .all(|s| !s.flags.contains(Flag::StaleReference)));
}

/// A skin warming from room temperature to 37 °C changes the stripes' colours, and with
/// them the image's brightness: that is the reading, not a drifting reference.
#[test]
fn a_warming_skin_is_not_a_drifting_reference() {
    let mut rig = Rig::new(settings(ReferencePolicy {
        auto_after_s: 0.0,
        ..Default::default()
    }));
    let (mut svc, mut cam) = rig.start();
    let mut scene = vec![SkinState::idle(ROOM_C); 4];
    scene.extend((0..24).map(|i| SkinState::idle(ROOM_C + 12.0 * i as f32 / 23.0)));
    let s = summaries(&feed(&mut svc, &mut cam, &scene));
    let last = s.last().unwrap();
    assert!(
        (f32::from(last.temp_mean_centi_c) / 100.0 - (ROOM_C + 12.0)).abs() < 1.0,
        "the warming is read: {last:?}"
    );
    assert!(s.iter().all(|s| !s.flags.contains(Flag::StaleReference)));
    assert_eq!(svc.counters().stale, 0);
}

#[test]
fn a_lost_camera_is_reported_and_the_state_follows() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    feed(&mut svc, &mut cam, &vec![SkinState::idle(ROOM_C); 2]);
    match svc.on_camera(CameraEvent::Lost("/dev/video9: unplugged".into())) {
        Some(DeviceMsg::Error(e)) => {
            assert_eq!(e.code, ErrorCode::CameraLost);
            assert!(e.detail.contains("unplugged"));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        states_of(&Vec::from_iter(svc.on_tick())),
        [RunState::CameraLost]
    );
    assert_eq!(svc.on_camera(CameraEvent::Back), None);
    assert_eq!(
        states_of(&Vec::from_iter(svc.on_tick())),
        [RunState::Streaming]
    );
}

#[test]
fn maps_come_with_the_next_frame() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    feed(&mut svc, &mut cam, &vec![SkinState::idle(ROOM_C); 3]);
    for kind in [MapKind::Depth, MapKind::Temperature] {
        assert_eq!(
            svc.on_command(HostMsg::RequestMap(kind)),
            DeviceMsg::Ack(Command::RequestMap)
        );
    }
    let out = feed(&mut svc, &mut cam, &[press(1.5)]);
    let s = summaries(&out);
    let maps: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            DeviceMsg::Map(m) => Some(m),
            _ => None,
        })
        .collect();
    assert_eq!(maps.len(), 2);
    assert!(maps.iter().all(|m| m.seq == s[0].seq && m.is_consistent()));
    let deepest = maps[0].cells.iter().copied().max().unwrap();
    assert!(
        (f32::from(deepest) / 1000.0 - 1.5).abs() < 0.1,
        "{deepest} µm"
    );
    // Asked once, sent once.
    assert!(feed(&mut svc, &mut cam, &[press(1.5)])
        .iter()
        .all(|m| !matches!(m, DeviceMsg::Map(_))));
}

/// A full map comes whole, in order, from the same frame as the coarse one, whose cells
/// are its block maxima; the camera is whole only.
#[test]
fn full_maps_come_whole_with_the_next_frame() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    feed(&mut svc, &mut cam, &vec![SkinState::idle(ROOM_C); 3]);
    assert!(matches!(
        svc.on_command(HostMsg::RequestMap(MapKind::Camera)),
        DeviceMsg::Error(e) if e.code == ErrorCode::UnsupportedCommand
    ));
    svc.on_command(HostMsg::RequestMap(MapKind::Depth));
    for kind in [MapKind::Depth, MapKind::Camera, MapKind::Depth] {
        assert_eq!(
            svc.on_command(HostMsg::RequestFullMap(kind)),
            DeviceMsg::Ack(Command::RequestFullMap)
        );
    }
    let out = feed(&mut svc, &mut cam, &[press(1.5)]);
    let seq = summaries(&out)[0].seq;
    let coarse = out
        .iter()
        .find_map(|m| match m {
            DeviceMsg::Map(m) => Some(m),
            _ => None,
        })
        .unwrap();
    let pieces = |kind: MapKind| -> Vec<&vistaf_protocol::MapChunk> {
        out.iter()
            .filter_map(|m| match m {
                DeviceMsg::MapChunk(c) if c.kind == kind => Some(c),
                _ => None,
            })
            .collect()
    };
    let depth = pieces(MapKind::Depth);
    let (w, h) = (usize::from(depth[0].width), usize::from(depth[0].height));
    let mut cells = Vec::new();
    for p in &depth {
        assert!(p.is_consistent() && p.seq == seq && p.first_cell as usize == cells.len());
        cells.extend(p.cells.iter().copied());
    }
    assert_eq!(cells.len(), w * h, "asked twice, sent once, whole");
    // The coarse tile's cells are block maxima of the full map (each coarse cell covers
    // `step × step` working pixels).
    let step = w.div_ceil(usize::from(coarse.width));
    for (i, &c) in coarse.cells.iter().enumerate() {
        let (tx, ty) = (i % usize::from(coarse.width), i / usize::from(coarse.width));
        let block = (ty * step..((ty + 1) * step).min(h))
            .flat_map(|y| (tx * step..((tx + 1) * step).min(w)).map(move |x| y * w + x))
            .map(|j| cells[j])
            .filter(|&v| v != vistaf_protocol::msg::MAP_NO_DATA);
        if c != vistaf_protocol::msg::MAP_NO_DATA {
            assert_eq!(block.max(), Some(c), "coarse cell {i}");
        }
    }
    let pitch_mm = f64::from(depth[0].cell_pitch_nm) * 1e-6;
    assert!((pitch_mm * step as f64 * 100.0 - f64::from(coarse.cell_pitch_centi_mm)).abs() <= 1.0);
    let camera = pieces(MapKind::Camera);
    assert_eq!(camera.iter().map(|p| p.cells.len()).sum::<usize>(), w * h);
    assert!(feed(&mut svc, &mut cam, &[press(1.5)])
        .iter()
        .all(|m| !matches!(m, DeviceMsg::MapChunk(_))));
}

#[test]
fn stop_silences_summaries_until_start() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    let idle = vec![SkinState::idle(ROOM_C); 3];
    assert_eq!(summaries(&feed(&mut svc, &mut cam, &idle)).len(), 1);
    assert_eq!(svc.on_command(HostMsg::Stop), DeviceMsg::Ack(Command::Stop));
    assert!(summaries(&feed(&mut svc, &mut cam, &idle)).is_empty());
    assert_eq!(
        svc.on_command(HostMsg::Start),
        DeviceMsg::Ack(Command::Start)
    );
    let s = summaries(&feed(&mut svc, &mut cam, &idle));
    assert_eq!(s.iter().map(|s| s.seq).collect::<Vec<_>>(), [1, 2, 3]);
    assert_eq!(svc.counters().processed, 7);
}

#[test]
fn a_frame_of_the_wrong_size_is_counted_and_skipped() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    feed(&mut svc, &mut cam, &vec![SkinState::idle(ROOM_C); 2]);
    let mut small = cam.frame(&SkinState::idle(ROOM_C));
    small.width /= 2;
    small.height /= 2;
    small.data.truncate(small.data.len() / 4);
    assert!(svc.on_frame(small).is_empty());
    let mut torn = cam.frame(&SkinState::idle(ROOM_C));
    torn.data.truncate(100);
    assert!(svc.on_frame(torn).is_empty());
    assert_eq!(svc.counters().bad, 2);
    assert_eq!(svc.counters().processed, 0);
}

#[test]
fn a_new_reference_is_taken_when_the_host_asks() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    let idle = vec![SkinState::idle(ROOM_C); 3];
    feed(&mut svc, &mut cam, &idle);
    assert_eq!(
        svc.on_command(HostMsg::CaptureReference),
        DeviceMsg::Ack(Command::CaptureReference)
    );
    let out = feed(&mut svc, &mut cam, &idle);
    assert_eq!(states_of(&out), [RunState::Streaming]);
    assert_eq!(
        summaries(&out).len(),
        1,
        "two frames settle, the third is measured"
    );
    assert_eq!(svc.counters().references, 2);
}

#[test]
fn the_frame_limit_ends_the_run() {
    let mut rig = Rig::new(Settings {
        frames: Some(3),
        ..settings(Default::default())
    });
    let (mut svc, mut cam) = rig.start();
    feed(&mut svc, &mut cam, &vec![SkinState::idle(ROOM_C); 4]);
    assert!(!svc.done());
    feed(&mut svc, &mut cam, &[SkinState::idle(ROOM_C)]);
    assert!(svc.done());
    match svc.finish() {
        DeviceMsg::Status(s) => assert_eq!((s.state, s.frames_processed), (RunState::Stopped, 3)),
        other => panic!("{other:?}"),
    }
    drop((svc, cam));
    assert!(!rig.led.is_lit(), "the ring is off at the end");
}

#[test]
fn a_long_serial_is_cut_on_a_character_boundary() {
    let mut rig = Rig::new(Settings {
        serial: "Ä".repeat(13),
        ..settings(Default::default())
    });
    let (svc, _) = rig.start();
    match svc.hello() {
        DeviceMsg::Hello(h) => assert_eq!(h.serial.as_str(), "Ä".repeat(12)),
        other => panic!("{other:?}"),
    }
}

/// A camera that shows no grating at first (a lens cap, the light off): the service says so
/// and keeps trying, once a second, until it can take a reference; it never exits.
#[test]
fn a_reference_without_a_grating_is_reported_and_retried() {
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, mut cam) = rig.start();
    let blank = SkinState {
        contrast_scale: 0.0,
        ..SkinState::idle(ROOM_C)
    };
    // Two seconds of a blank skin at 30 frames/s.
    let out = feed(&mut svc, &mut cam, &vec![blank; 60]);
    let reports: Vec<_> = out
        .iter()
        .filter_map(|m| match m {
            DeviceMsg::Error(e) if e.code == ErrorCode::Reference => Some(e.detail.clone()),
            _ => None,
        })
        .collect();
    assert!(
        (2..=3).contains(&reports.len()),
        "once a second: {reports:?}"
    );
    assert!(reports[0].contains("no grating"), "{}", reports[0]);
    assert!(states_of(&out).iter().all(|s| *s == RunState::Referencing));
    // The grating appears: the next try takes the reference, and frames are measured.
    let out = feed(&mut svc, &mut cam, &vec![SkinState::idle(ROOM_C); 40]);
    assert!(states_of(&out).contains(&RunState::Streaming));
    assert!(!summaries(&out).is_empty());
    let c = svc.counters();
    assert_eq!(c.references, 1);
    assert_eq!(c.reference_failures as usize, reports.len());
    assert_eq!(
        c.referencing + c.processed,
        100,
        "every frame is accounted for: {c:?}"
    );
}

#[test]
fn a_clock_request_is_answered_on_the_device_clock_with_its_wait() {
    use vistaf_firmware::service::Clock;
    // The device's epoch is taken before anything is timed, as the service's runner does.
    vistaf_hardware::clock::epoch();
    let mut rig = Rig::new(settings(Default::default()));
    let (mut svc, cam) = rig.start();
    let received = cam.clock.now();
    // The request waited 7 ms for a frame to finish before it was answered.
    cam.wait(Duration::from_millis(7));
    let DeviceMsg::Clock(r) = svc.on_command_received(HostMsg::Clock { nonce: 9 }, received) else {
        panic!("not a clock reading");
    };
    assert_eq!(r.nonce, 9);
    assert_eq!(r.received_us, vistaf_hardware::clock::micros(received));
    assert_eq!(r.sent_us - r.received_us, 7_000);
}

/// The guided calibration's commands out of order are refused with a reason, and nothing
/// changes: a label before the kit's reference, a fit without a kit, an activation of
/// nothing fitted or of another id, a rollback with nothing to go back to. A kit step
/// on a camera the device cannot drive waits for the settled image of frames after it.
#[test]
fn calibration_commands_out_of_order_are_refused_and_a_step_waits_for_settled_frames() {
    let kit_dir = std::env::temp_dir().join(format!("vistaf-service-kit-{}", std::process::id()));
    let mut rig = Rig::new(Settings {
        kit_dir: kit_dir.clone(),
        ..settings(Default::default())
    });
    let (mut svc, mut cam) = rig.start();
    feed(&mut svc, &mut cam, &vec![SkinState::idle(ROOM_C); 2]);
    let refused = |m: DeviceMsg, code: ErrorCode, words: &str| match m {
        DeviceMsg::Error(e) => {
            assert_eq!(e.code, code, "{e:?}");
            assert!(e.detail.contains(words), "{e:?}");
        }
        other => panic!("{other:?}"),
    };
    let step = |quantity, value_milli| {
        HostMsg::KitCapture(vistaf_protocol::KitStep {
            quantity,
            value_milli,
        })
    };
    use vistaf_protocol::KitQuantity::{Depth, Reference};
    refused(
        svc.on_command(step(Depth, 500)),
        ErrorCode::Calibration,
        "Reference step first",
    );
    refused(
        svc.on_command(HostMsg::KitFit),
        ErrorCode::Calibration,
        "no kit",
    );
    let id = Calibration::default_sim().id();
    refused(
        svc.on_command(HostMsg::CalibrationActivate { calibration_id: id }),
        ErrorCode::Calibration,
        "no fitted calibration",
    );
    refused(
        svc.on_command(HostMsg::CalibrationRollback),
        ErrorCode::Calibration,
        "no earlier",
    );
    let DeviceMsg::Hello(h) = svc.on_command(HostMsg::GetInfo) else {
        panic!("no hello")
    };
    assert_eq!(h.calibration_id, id, "nothing changed");

    // The reference step: acknowledged, then captured from the frames after it once two
    // frame pairs are calm.
    assert_eq!(
        svc.on_command(step(Reference, 25_000)),
        DeviceMsg::Ack(Command::KitCapture)
    );
    let captured = |out: &[DeviceMsg]| out.iter().any(|m| matches!(m, DeviceMsg::KitCaptured(_)));
    let f = cam.frame(&SkinState::idle(ROOM_C));
    assert!(!captured(&svc.on_frame(f)));
    let f = cam.frame(&SkinState::idle(ROOM_C));
    assert!(!captured(&svc.on_frame(f)));
    let f = cam.frame(&SkinState::idle(ROOM_C));
    let out = svc.on_frame(f);
    assert!(captured(&out), "{out:?}");
    assert!(
        std::fs::read_dir(&kit_dir).unwrap().count() == 1,
        "one kit folder"
    );
    std::fs::remove_dir_all(&kit_dir).unwrap();
}

/// The calibration an activation replaced, read back from its file at start, can be put
/// back after a restart; with none, a rollback is refused by name.
#[test]
fn a_rollback_after_a_restart_puts_the_previous_file_back() {
    let dir = std::env::temp_dir().join(format!("vistaf-rollback-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("calibration.json");
    let old = Calibration::default_sim();
    let mut new = old.clone();
    new.unit.period_px *= 1.01;
    new.save(&path).unwrap();
    old.save(&vistaf_firmware::service::persist::previous_path(&path))
        .unwrap();
    let mut rig = Rig::new(Settings {
        calibration_path: Some(path.clone()),
        previous: vistaf_firmware::service::persist::previous(&path),
        ..settings(ReferencePolicy::default())
    });
    rig.settings.calibration = new.clone();
    let (mut svc, _) = rig.start();
    match svc.on_command(HostMsg::CalibrationRollback) {
        DeviceMsg::Hello(h) => assert_eq!(h.calibration_id, old.id()),
        other => panic!("{other:?}"),
    }
    assert_eq!(Calibration::load(&path).unwrap().id(), old.id());
    drop(svc);
    let mut rig = Rig::new(settings(ReferencePolicy::default()));
    let (mut svc, _) = rig.start();
    match svc.on_command(HostMsg::CalibrationRollback) {
        DeviceMsg::Error(e) => assert!(e.detail.contains("no earlier calibration"), "{e:?}"),
        other => panic!("{other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}
