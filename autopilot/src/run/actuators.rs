//! The servo outputs of the real vehicle: the core's pulse widths written
//! to sysfs PWM channels, with a watchdog that puts every output at its
//! trim (centred steering, stopped throttle) when the core stops feeding it
//! in time — a stalled or overrunning core must not leave the last throttle
//! on. Outputs also go to trim on drop (process exit) through the driver.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use drivers::device::DeviceStatus;
use drivers::pwm::{PwmOutput, SysfsPwm, SysfsPwmConfig};

use super::config::PwmSettings;

/// How often a driver that failed to open is tried again.
const REOPEN_EVERY: Duration = Duration::from_secs(1);

struct Shared {
    pwm: Option<SysfsPwm>,
    /// Output i carries the pulse of servo `servos[i]` (0-based).
    servos: Vec<usize>,
    outputs: Vec<PwmOutput>,
    config: SysfsPwmConfig,
    next_open: Instant,
    last_open_error: Option<String>,
    open_errors: u64,
}

impl Shared {
    fn ensure_open(&mut self, now: Instant) {
        if self.pwm.is_some() || now < self.next_open {
            return;
        }
        self.next_open = now + REOPEN_EVERY;
        match SysfsPwm::open(&self.config, &self.outputs) {
            Ok(pwm) => {
                tracing::info!("PWM outputs open: {} channels", self.outputs.len());
                self.pwm = Some(pwm);
            }
            Err(e) => {
                self.open_errors += 1;
                let text = e.to_string();
                if self.last_open_error.as_deref() != Some(text.as_str()) {
                    tracing::warn!("PWM outputs: {text}; retrying every {} s", REOPEN_EVERY.as_secs());
                }
                self.last_open_error = Some(text);
            }
        }
    }

    fn trim_all(&mut self) {
        if let Some(pwm) = &mut self.pwm
            && let Err(e) = pwm.set_all_to_trim()
        {
            tracing::warn!("PWM trim: {e}");
        }
    }
}

/// The sysfs outputs and their watchdog thread.
pub struct PwmActuators {
    shared: Arc<Mutex<Shared>>,
    /// Nanoseconds since `origin` of the last feed.
    fed_ns: Arc<AtomicU64>,
    tripped: Arc<AtomicBool>,
    trips: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    watchdog: Option<std::thread::JoinHandle<()>>,
    /// The watchdog's time base.
    origin: Instant,
}

impl PwmActuators {
    /// Drives `settings.outputs` with each servo's trim from `trims_us`
    /// (SERVOn_TRIM, indexed by servo − 1) until the core says otherwise.
    /// The watchdog trims everything when no feed came for `deadline`.
    pub fn start(settings: &PwmSettings, trims_us: &[u16; 16], deadline: Duration) -> PwmActuators {
        let outputs: Vec<PwmOutput> = settings
            .outputs
            .iter()
            .map(|o| PwmOutput {
                chip: o.chip,
                channel: o.channel,
                trim_us: trims_us[usize::from(o.servo.clamp(1, 16)) - 1],
            })
            .collect();
        let servos = settings
            .outputs
            .iter()
            .map(|o| usize::from(o.servo.clamp(1, 16)) - 1)
            .collect();
        let origin = Instant::now();
        let mut shared = Shared {
            pwm: None,
            servos,
            outputs,
            config: SysfsPwmConfig {
                root: settings.root.clone(),
                period_ns: u64::from(settings.period_us) * 1000,
                ..SysfsPwmConfig::default()
            },
            next_open: origin,
            last_open_error: None,
            open_errors: 0,
        };
        if !shared.outputs.is_empty() {
            shared.ensure_open(origin);
        }
        let shared = Arc::new(Mutex::new(shared));
        let fed_ns = Arc::new(AtomicU64::new(0));
        let tripped = Arc::new(AtomicBool::new(false));
        let trips = Arc::new(AtomicU64::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let watchdog = {
            let (shared, fed_ns, tripped, trips, stop) = (
                Arc::clone(&shared),
                Arc::clone(&fed_ns),
                Arc::clone(&tripped),
                Arc::clone(&trips),
                Arc::clone(&stop),
            );
            std::thread::Builder::new()
                .name("pwm-watchdog".into())
                .spawn(move || {
                    let poll = (deadline / 4).max(Duration::from_millis(1));
                    while !stop.load(Ordering::Relaxed) {
                        std::thread::sleep(poll);
                        let fed = Duration::from_nanos(fed_ns.load(Ordering::Relaxed));
                        let late = origin.elapsed().saturating_sub(fed) > deadline;
                        if late && !tripped.swap(true, Ordering::Relaxed) {
                            trips.fetch_add(1, Ordering::Relaxed);
                            tracing::warn!("core missed its output deadline: outputs to trim");
                            lock(&shared).trim_all();
                        }
                    }
                })
                .ok()
        };
        PwmActuators {
            shared,
            fed_ns,
            tripped,
            trips,
            stop,
            watchdog,
            origin,
        }
    }

    /// This tick's pulses (servo n at index n − 1; 0 = not driven: left at
    /// the output's trim). Feeds the watchdog.
    pub fn apply(&self, pulses_us: &[u16; 16]) {
        let mut shared = lock(&self.shared);
        shared.ensure_open(Instant::now());
        let Shared {
            pwm, servos, outputs, ..
        } = &mut *shared;
        if let Some(pwm) = pwm {
            for (output, (&servo, spec)) in servos.iter().zip(outputs.iter()).enumerate() {
                let pulse = match pulses_us[servo] {
                    0 => spec.trim_us,
                    p => p,
                };
                if let Err(e) = pwm.set_pulse_us(output, pulse) {
                    tracing::debug!("PWM output {output}: {e}");
                }
            }
        }
        drop(shared);
        self.tripped.store(false, Ordering::Relaxed);
        self.fed_ns
            .store(self.origin.elapsed().as_nanos() as u64, Ordering::Relaxed);
    }

    /// Every output to trim now (the core knows it is late).
    pub fn to_trim(&self) {
        lock(&self.shared).trim_all();
    }

    /// Times the watchdog put the outputs to trim.
    pub fn watchdog_trips(&self) -> u64 {
        self.trips.load(Ordering::Relaxed)
    }

    /// The outputs' health for the status view.
    pub fn status(&self) -> Option<DeviceStatus> {
        let shared = lock(&self.shared);
        if shared.outputs.is_empty() {
            return None;
        }
        Some(match &shared.pwm {
            Some(pwm) => pwm.status(),
            None => DeviceStatus {
                errors: shared.open_errors,
                last_error: shared.last_open_error.clone(),
                ..DeviceStatus::default()
            },
        })
    }
}

impl Drop for PwmActuators {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(w) = self.watchdog.take() {
            let _ = w.join();
        }
        // The driver's own drop writes every trim; done here explicitly so
        // it happens before anything else shuts down.
        lock(&self.shared).trim_all();
    }
}

fn lock(shared: &Mutex<Shared>) -> std::sync::MutexGuard<'_, Shared> {
    shared.lock().unwrap_or_else(|p| p.into_inner())
}
