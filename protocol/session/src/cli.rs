//! A session as both command lines take it (`vistaf-host calibrate`, `vistaf-skin
//! calibrate --guided`): the same options, the same plan, the same guide.

use std::path::PathBuf;
use std::time::Duration;

use crate::guide::{Guide, Scripted, Terminal, WithScale};
use crate::plan::{Activate, Plan};
use crate::scale::SerialScale;

/// How long a scale may take to give one reading (a few lines of a streaming indicator).
pub const SCALE_TIMEOUT: Duration = Duration::from_secs(5);

/// The session's options.
#[derive(clap::Args, Debug)]
pub struct SessionArgs {
    /// Run the steps of this plan without asking (see docs/calibration.md); without it,
    /// the default kit, each step asked for at the terminal.
    #[arg(long)]
    pub plan: Option<PathBuf>,
    /// When to put the fit in use [default: the plan's, else pass].
    #[arg(long, value_enum)]
    pub activate: Option<Activate>,
    /// The load cell's indicator on a serial port (serial:PATH@BAUD, or a path at 9600
    /// baud): each force step's value is read from it [default: the plan's].
    #[arg(long)]
    pub scale: Option<String>,
}

impl SessionArgs {
    /// Whether any option was given.
    pub fn given(&self) -> bool {
        self.plan.is_some() || self.activate.is_some() || self.scale.is_some()
    }

    /// The plan (the file's, else the default kit, with the options over it) and who
    /// answers its steps: the plan's script, or a person at this terminal; a scale, when
    /// one is named, answers the force steps. The scale is opened here, so a wrong path is
    /// said before any step.
    pub fn open(&self) -> Result<(Plan, Box<dyn Guide>), String> {
        let mut plan = match &self.plan {
            Some(p) => Plan::load(p)?,
            None => Plan::default(),
        };
        if let Some(a) = self.activate {
            plan.activate = a;
        }
        if self.scale.is_some() {
            plan.scale.clone_from(&self.scale);
        }
        let scale = match &plan.scale {
            Some(spec) => Some(SerialScale::open(spec, SCALE_TIMEOUT)?),
            None => None,
        };
        let guide: Box<dyn Guide> = if self.plan.is_some() {
            Box::new(Scripted::new(std::io::stdout()))
        } else {
            Box::new(Terminal::new(std::io::stdin().lock(), std::io::stdout()))
        };
        let guide: Box<dyn Guide> = match scale {
            Some(s) => Box::new(WithScale::new(guide, Box::new(s))),
            None => guide,
        };
        Ok((plan, guide))
    }
}
