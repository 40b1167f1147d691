//! A guided calibration end to end: the device service films a simulated unit that is not
//! the default one on a scripted bench, over a real pseudo-terminal; the host's session
//! runs a plan, the device captures the kit once each image settles, fits it, judges it and
//! activates it. The activated calibration then measures a press of that unit against the
//! bench's truth, and a rollback restores the calibration before it, on the device and in
//! its file.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use vistaf_firmware::service::persist::previous_path;
use vistaf_firmware::service::Settings;
use vistaf_hardware::bench::{SharedBench, Stimulus};
use vistaf_hardware::frameset::FrameSet;
use vistaf_host::calibrate::{self, Activate, Plan, Scripted};
use vistaf_host::client::{Client, Next, DEFAULT_TIMEOUT};
use vistaf_pipeline::calibration::Calibration;
use vistaf_protocol::{DeviceMsg, KitQuantity};
use vistaf_sim::{SensorUnit, SimSource};

/// A unit unlike the default calibration's (another grating period in pixels).
const UNIT_SEED: u64 = 3;

fn plan() -> Plan {
    Plan {
        depths_mm: vec![0.2, 0.5, 0.8, 1.1, 1.4, 1.7, 2.0, 2.3],
        forces_n: vec![1.0, 2.0, 4.0, 6.0, 10.0, 15.0, 20.0, 30.0],
        temperatures_c: vec![
            15.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0, 34.0, 38.0, 42.0, 46.0,
        ],
        repeats: 1,
        activate: Activate::Always,
        ..Plan::default()
    }
}

/// Peak depths of the summaries in the next `window`, mm.
fn peak_depths(client: &mut Client, window: Duration) -> Vec<f64> {
    let end = Instant::now() + window;
    let mut out = Vec::new();
    while let Ok(Next::Message(r)) = client.next(Some(end)) {
        if let DeviceMsg::Summary(s) = r.msg {
            out.push(f64::from(s.peak_depth_um) / 1000.0);
        }
    }
    out
}

/// The host's default plan is the kit the simulator renders (the host cannot depend on
/// the simulator, so the setpoints are written twice; this keeps them one).
#[test]
fn the_host_default_plan_is_the_simulated_kit() {
    use vistaf_sim::sets::{KIT_DEPTHS_MM, KIT_FORCES_N, KIT_TEMPS_C};
    let widen = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>();
    let p = Plan::default();
    let close = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6)
    };
    assert!(close(&p.depths_mm, &widen(&KIT_DEPTHS_MM)));
    assert!(close(&p.forces_n, &widen(&KIT_FORCES_N)));
    assert!(close(&p.temperatures_c, &widen(&KIT_TEMPS_C)));
}

#[test]
fn a_plan_calibrates_a_new_unit_activates_it_and_rolls_back() {
    let dir = std::env::temp_dir().join(format!("vistaf-calibrate-pty-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("calibration.json");
    let old = Calibration::default_sim();
    old.save(&path).unwrap();

    let unit = SensorUnit::from_seed(UNIT_SEED);
    let (source, bench) = SimSource::on_bench(unit, None, 11);
    let bench: SharedBench = Arc::new(Mutex::new(bench));
    let settings = Settings {
        serial: "VSK-CAL".into(),
        calibration_path: Some(path.clone()),
        kit_dir: dir.join("kit"),
        bench: Some(bench.clone()),
        ..Settings::new(old.clone())
    };
    let served = vistaf_tests::pty::serve(Box::new(source), settings);
    let (mut client, stop, device) = (served.client, served.stop, served.device);
    let hello = client.handshake(Duration::from_secs(10)).unwrap();
    assert_eq!(hello.calibration_id, old.id());

    let plan = plan();
    let mut log = Vec::new();
    let outcome = calibrate::run(&mut client, &plan, &mut Scripted::new(&mut log)).unwrap();
    let log = String::from_utf8(log).unwrap();

    // Every step captured, one frame each, into a kit kept on the device's disk.
    assert_eq!(outcome.captured, [1, 8, 8, 12], "{log}");
    let kit = std::fs::read_dir(dir.join("kit"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let depth = FrameSet::open(&kit.join("depth")).unwrap();
    let labels: Vec<f64> = depth
        .manifest
        .frames
        .iter()
        .filter_map(|f| f.depth_mm)
        .collect();
    assert_eq!(labels, plan.depths_mm);
    assert_eq!(FrameSet::open(&kit.join("temperature")).unwrap().len(), 12);

    // A verdict per model, and the fit activated under the id it was fitted as.
    let fitted = outcome.fitted.unwrap();
    let quantities: Vec<KitQuantity> = outcome.verdicts.iter().map(|v| v.quantity).collect();
    assert_eq!(
        quantities,
        [
            KitQuantity::Depth,
            KitQuantity::Force,
            KitQuantity::Temperature
        ],
        "{log}"
    );
    assert!(
        log.contains("held-out RMSE") && log.contains("activated calibration"),
        "{log}"
    );
    let active = outcome.activated.unwrap();
    assert_eq!(active.calibration_id, fitted.calibration_id);
    assert_ne!(active.calibration_id, old.id());
    assert_eq!(
        Calibration::load(&path).unwrap().id(),
        fitted.calibration_id
    );
    assert_eq!(
        Calibration::load(&previous_path(&path)).unwrap().id(),
        old.id()
    );

    // The new calibration measures this unit: a 1.2 mm press of the sphere, after the
    // device's new reference, reads 1.2 mm.
    std::thread::sleep(Duration::from_millis(500));
    bench
        .lock()
        .unwrap()
        .apply(Stimulus::SphereDepth { depth_mm: 1.2 })
        .unwrap();
    let _ = peak_depths(&mut client, Duration::from_millis(600));
    let depths = peak_depths(&mut client, Duration::from_secs(2));
    assert!(depths.len() >= 3, "summaries after activation: {depths:?}");
    let median = {
        let mut d = depths.clone();
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    assert!((median - 1.2).abs() < 0.06, "peak depths {depths:?}");

    // Rollback: the old calibration in use and in the file again.
    let back = client.roll_back_calibration(DEFAULT_TIMEOUT).unwrap();
    assert_eq!(back.calibration_id, old.id());
    assert_eq!(Calibration::load(&path).unwrap().id(), old.id());

    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    device.join().unwrap().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}
