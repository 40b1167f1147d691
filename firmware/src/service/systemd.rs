//! Telling systemd how the service is: ready once it runs, alive while the processing
//! loop turns (the unit's `WatchdogSec`: a loop that hangs is killed and restarted), and
//! stopping. Outside systemd (no `NOTIFY_SOCKET`) every call does nothing.

use std::time::{Duration, Instant};

use sd_notify::NotifyState;

/// The watchdog's half: pets go out at this fraction of its interval.
const PET_FRACTION: u32 = 2;

/// The service's side of systemd's notifications.
#[derive(Debug)]
pub struct Systemd {
    /// Time between pets (half the watchdog's interval), if systemd asked for them.
    pet_every: Option<Duration>,
    last_pet: Option<Instant>,
}

impl Systemd {
    /// From the environment systemd gave the service.
    pub fn from_env() -> Systemd {
        Systemd {
            pet_every: sd_notify::watchdog_enabled().map(|d| d / PET_FRACTION),
            last_pet: None,
        }
    }

    /// The service runs.
    pub fn ready(&self) {
        let _ = sd_notify::notify(&[NotifyState::Ready]);
    }

    /// The loop turned: a pet, when one is due.
    pub fn alive(&mut self, now: Instant) {
        let Some(every) = self.pet_every else { return };
        if self
            .last_pet
            .is_some_and(|t| now.saturating_duration_since(t) < every)
        {
            return;
        }
        self.last_pet = Some(now);
        let _ = sd_notify::notify(&[NotifyState::Watchdog]);
    }

    /// The service is stopping.
    pub fn stopping(&self) {
        let _ = sd_notify::notify(&[NotifyState::Stopping]);
    }
}
