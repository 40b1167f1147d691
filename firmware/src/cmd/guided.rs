//! `vistaf-skin calibrate --guided`: the guided session of `vistaf-host calibrate`, run on
//! the board against its own camera. The service's state machine answers the session in
//! this process (`service::local`), so the kit, the fit, the verdicts and the activation
//! are the service's own; the running service must be stopped first, as the camera is
//! this command's for the session.

use std::path::Path;
use std::sync::Arc;

use anyhow::{bail, Result};
use vistaf_firmware::service::local::Local;
use vistaf_firmware::service::persist::previous_path;
use vistaf_firmware::service::{EdgeCounters, Service, SystemClock};
use vistaf_firmware::source_spec::SourceSpec;
use vistaf_pipeline::Implementation;
use vistaf_protocol::CalibrationId;
use vistaf_session::SessionArgs;

use super::run::{led_ring, open, Opened, ServiceArgs};

/// The guided session's options.
#[derive(clap::Args, Debug)]
#[command(next_help_heading = "Guided session (--guided)")]
pub struct GuidedArgs {
    /// The camera, the calibration file the fit is activated in, the kits.
    #[command(flatten)]
    pub service: ServiceArgs,
    /// The plan, when to activate, the scale.
    #[command(flatten)]
    pub session: SessionArgs,
}

impl GuidedArgs {
    /// Whether any of these options that has no default was given (they mean nothing
    /// without `--guided`).
    pub fn given(&self) -> bool {
        let s = &self.service;
        self.session.given()
            || s.config.is_some()
            || s.source.is_some()
            || s.calibration.is_some()
            || s.kit.is_some()
            || s.serial.is_some()
            || s.fps.is_some()
            || s.force_calibration
    }
}

/// Runs the session; the fit is fitted with `pipeline`.
pub fn run(a: &GuidedArgs, pipeline: Implementation) -> Result<()> {
    let (plan, mut guide) = a.session.open().map_err(anyhow::Error::msg)?;
    let Opened {
        source,
        settings,
        config,
    } = open(&a.service, Some(pipeline), true).map_err(|e| camera_hint(e, &a.service))?;
    let Some(path) = settings.calibration_path.clone() else {
        bail!(
            "--guided activates the fit in the calibration file: give it with --calibration PATH \
             or `calibration` in --config (a file not there yet is created)"
        );
    };
    if let Some(file) = &a.service.config {
        if config.calibration.as_ref() != Some(&path) {
            eprintln!(
                "vistaf-skin: {} names no `calibration = \"{}\"`: add it, or the service will \
                 not use this calibration",
                file.display(),
                path.display()
            );
        }
    }
    vistaf_hardware::clock::epoch();
    let format = source.format();
    let mut led = led_ring(&config.led)?;
    let service = Service::new(
        &settings,
        format,
        led.as_mut(),
        Arc::new(EdgeCounters::default()),
        SystemClock,
    );
    let name = source.name();
    let mut device = Local::new(service, source);
    println!(
        "{} on {name}, {}×{} px; calibration {} in use; {} steps; kit frames kept under {}",
        settings.serial,
        format.width,
        format.height,
        CalibrationId(settings.calibration.id()),
        plan.steps().len(),
        settings.kit_dir.display()
    );
    let outcome = vistaf_session::run(&mut device, &plan, guide.as_mut())?;
    drop(device); // the ring goes dark
    if outcome.activated.is_some() {
        say_activated(&path);
    }
    if outcome.fitted.is_some_and(|f| !f.pass) {
        bail!("the calibration misses a target (see the table above)");
    }
    Ok(())
}

/// Where the activated calibration went, and how the service takes it up.
fn say_activated(path: &Path) {
    let previous = previous_path(path);
    let kept = if previous.exists() {
        format!(
            " (the one it replaced is {}: `vistaf-host rollback` puts it back)",
            previous.display()
        )
    } else {
        String::new()
    };
    println!(
        "wrote {}{kept}; start the service again to use it: sudo systemctl start vistaf-skin",
        path.display()
    );
}

/// A camera that would not open is most often the running service's: say so.
fn camera_hint(e: anyhow::Error, a: &ServiceArgs) -> anyhow::Error {
    let camera = !matches!(a.source, Some(SourceSpec::Set(_) | SourceSpec::Sim(_)));
    if camera && format!("{e:#}").to_lowercase().contains("busy") {
        e.context(
            "the camera is in use, most likely by the running service: stop it first \
             (sudo systemctl stop vistaf-skin), or calibrate from the robot computer with \
             `vistaf-host calibrate`",
        )
    } else {
        e
    }
}
