//! Servo and ESC pulses through the Linux sysfs PWM interface.
//!
//! The kernel exposes each PWM controller as `ROOT/pwmchipN` with the files
//! `npwm` (number of channels), `export` and `unexport`; writing a channel
//! number to `export` creates `pwmchipN/pwmM` with `period`, `duty_cycle`
//! (both in nanoseconds), `enable` and `polarity`
//! (Documentation/driver-api/pwm.rst). [`SysfsPwm`] drives a fixed list of
//! such channels at one period (20 ms = 50 Hz for hobby servos and ESCs).
//!
//! The root directory is a parameter so tests can point it at a fake tree of
//! plain files in a temporary directory; nothing here assumes the files are
//! special beyond what the kernel documents.
//!
//! Set-up order: the kernel rejects a duty cycle longer than the period and a
//! period shorter than the duty cycle, and most drivers change polarity only
//! while disabled. The writes that take a channel from whatever it holds (it
//! may still run from a previous process) to the wanted period, duty and
//! `enable = 1` are planned by a pure function ([`setup_writes`]) so that
//! every intermediate state is one the kernel accepts.
//!
//! Failure policy: every file error is a [`PwmError`] naming the file. A file
//! or directory that has disappeared (a USB or overlay PWM chip removed) is
//! [`PwmError::Vanished`]: the output is marked for set-up again and the next
//! [`SysfsPwm::set_pulse_us`] retries without blocking, so the caller can count
//! errors and carry on. Nothing panics on I/O. Health (attribute bytes
//! written, pulses written, file errors, whether every output is set up) is
//! kept in a [`SharedStatus`] for the status view.
//!
//! Files are opened for each write rather than kept open: a descriptor to a
//! removed device keeps "working" on some file systems, while opening by path
//! reports the removal at once, and the cost (a few syscalls per changed
//! pulse) is negligible at servo rates.

use std::fmt;
use std::fs::{self, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::thread;
use std::time::{Duration, Instant};

use crate::device::{self, DeviceStatus, SharedStatus};

/// Where the kernel mounts the PWM class.
pub const DEFAULT_ROOT: &str = "/sys/class/pwm";

/// 20 ms: the 50 Hz frame hobby servos and ESCs expect.
pub const DEFAULT_PERIOD_NS: u64 = 20_000_000;

/// How long [`SysfsPwm::open`] waits for an exported channel to become
/// writable. The kernel creates the directory during the `export` write, but
/// udev may fix its permissions a little later.
pub const DEFAULT_EXPORT_TIMEOUT: Duration = Duration::from_secs(1);

const EXPORT_POLL: Duration = Duration::from_millis(5);

/// ENODEV on Linux: what a write to a removed device returns.
const ENODEV: i32 = 19;

const NS_PER_US: u64 = 1_000;

/// One PWM channel to drive, and the pulse it is left at when the driver is
/// dropped (the channel's trim: centred steering, stopped throttle).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PwmOutput {
    /// N of `pwmchipN`.
    pub chip: u32,
    /// M of `pwmchipN/pwmM`.
    pub channel: u32,
    /// Pulse width written at open and on drop.
    pub trim_us: u16,
}

/// Where and how to drive the outputs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SysfsPwmConfig {
    /// The PWM class directory ([`DEFAULT_ROOT`], a temporary tree in tests).
    pub root: PathBuf,
    /// Frame period of every output, in nanoseconds.
    pub period_ns: u64,
    /// Longest wait for an exported channel at open.
    pub export_timeout: Duration,
}

impl Default for SysfsPwmConfig {
    fn default() -> Self {
        SysfsPwmConfig {
            root: PathBuf::from(DEFAULT_ROOT),
            period_ns: DEFAULT_PERIOD_NS,
            export_timeout: DEFAULT_EXPORT_TIMEOUT,
        }
    }
}

/// Why a PWM operation failed. File errors carry the path.
#[derive(Debug)]
pub enum PwmError {
    /// The file or its directory is gone (chip removed, wrong root). The
    /// output will be set up again on the next pulse: count and retry.
    Vanished { path: PathBuf },
    /// Reading or writing the file failed for another reason (permissions,
    /// the driver refused the value).
    Io { path: PathBuf, source: io::Error },
    /// The file held something other than the number the kernel writes.
    Unparsable { path: PathBuf, contents: String },
    /// The channel directory was not writable within the export timeout.
    ExportTimeout { path: PathBuf, waited: Duration },
    /// The chip has `npwm` channels, fewer than asked for (`path` is `npwm`).
    NoSuchChannel { path: PathBuf, channel: u32, npwm: u64 },
    /// No output with this index was opened.
    NoSuchOutput { output: usize, outputs: usize },
    /// The pulse does not fit in the period.
    PulseTooLong { pulse_us: u16, period_ns: u64 },
    /// A pulse of zero (no pulses at all: some ESCs treat it as a signal
    /// loss, servos go limp), never a command.
    ZeroPulse,
    /// A period of zero.
    InvalidPeriod { period_ns: u64 },
    /// The same chip and channel listed twice.
    DuplicateOutput { chip: u32, channel: u32 },
}

impl PwmError {
    /// The file or directory concerned, for errors about one.
    pub fn path(&self) -> Option<&Path> {
        match self {
            PwmError::Vanished { path }
            | PwmError::Io { path, .. }
            | PwmError::Unparsable { path, .. }
            | PwmError::ExportTimeout { path, .. }
            | PwmError::NoSuchChannel { path, .. } => Some(path),
            _ => None,
        }
    }

    /// The hardware went away (worth counting and retrying, not fatal).
    pub fn is_vanished(&self) -> bool {
        matches!(self, PwmError::Vanished { .. })
    }
}

impl fmt::Display for PwmError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PwmError::Vanished { path } => write!(f, "{}: no such file or device (PWM chip removed?)", path.display()),
            PwmError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            PwmError::Unparsable { path, contents } => {
                write!(f, "{}: expected a number, found {contents:?}", path.display())
            }
            PwmError::ExportTimeout { path, waited } => {
                write!(
                    f,
                    "{}: not writable {} ms after export",
                    path.display(),
                    waited.as_millis()
                )
            }
            PwmError::NoSuchChannel { path, channel, npwm } => {
                write!(
                    f,
                    "{}: chip has {npwm} channels, channel {channel} asked for",
                    path.display()
                )
            }
            PwmError::NoSuchOutput { output, outputs } => {
                write!(f, "PWM output {output} does not exist ({outputs} opened)")
            }
            PwmError::PulseTooLong { pulse_us, period_ns } => {
                write!(f, "pulse of {pulse_us} µs does not fit in a period of {period_ns} ns")
            }
            PwmError::ZeroPulse => write!(f, "a pulse of 0 µs is not a servo command"),
            PwmError::InvalidPeriod { period_ns } => write!(f, "invalid PWM period {period_ns} ns"),
            PwmError::DuplicateOutput { chip, channel } => {
                write!(f, "pwmchip{chip}/pwm{channel} listed twice")
            }
        }
    }
}

impl std::error::Error for PwmError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            PwmError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

fn file_error(path: &Path, e: io::Error) -> PwmError {
    if e.kind() == io::ErrorKind::NotFound || e.raw_os_error() == Some(ENODEV) {
        PwmError::Vanished { path: path.to_owned() }
    } else {
        PwmError::Io {
            path: path.to_owned(),
            source: e,
        }
    }
}

/// Writes one attribute in a single `write`, as sysfs requires, and returns
/// the bytes written. No `create`: a missing attribute must be an error,
/// never a new plain file.
fn write_attr(path: &Path, value: &str) -> Result<usize, PwmError> {
    let mut file = OpenOptions::new()
        .write(true)
        .truncate(true)
        .open(path)
        .map_err(|e| file_error(path, e))?;
    file.write_all(value.as_bytes()).map_err(|e| file_error(path, e))?;
    Ok(value.len())
}

fn read_attr(path: &Path) -> Result<String, PwmError> {
    fs::read_to_string(path)
        .map(|s| s.trim().to_owned())
        .map_err(|e| file_error(path, e))
}

fn read_number(path: &Path) -> Result<u64, PwmError> {
    let contents = read_attr(path)?;
    contents.parse().map_err(|_| PwmError::Unparsable {
        path: path.to_owned(),
        contents,
    })
}

/// Waits (bounded) until `file` can be opened for writing.
fn wait_writable(dir: &Path, file: &Path, timeout: Duration) -> Result<(), PwmError> {
    let start = Instant::now();
    loop {
        match OpenOptions::new().write(true).open(file) {
            Ok(_) => return Ok(()),
            Err(e) if matches!(e.kind(), io::ErrorKind::NotFound | io::ErrorKind::PermissionDenied) => {
                let waited = start.elapsed();
                if waited >= timeout {
                    return Err(PwmError::ExportTimeout {
                        path: dir.to_owned(),
                        waited,
                    });
                }
                thread::sleep(EXPORT_POLL.min(timeout - waited));
            }
            Err(e) => return Err(file_error(file, e)),
        }
    }
}

/// The attributes of an exported channel that set-up writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelAttr {
    Period,
    DutyCycle,
    Enable,
    Polarity,
}

impl ChannelAttr {
    /// The attribute's file name in `pwmchipN/pwmM`.
    pub fn file_name(self) -> &'static str {
        match self {
            ChannelAttr::Period => "period",
            ChannelAttr::DutyCycle => "duty_cycle",
            ChannelAttr::Enable => "enable",
            ChannelAttr::Polarity => "polarity",
        }
    }
}

/// What an exported channel holds, as read from its files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelState {
    pub period_ns: u64,
    pub duty_ns: u64,
    pub enabled: bool,
    /// `polarity` reads `normal` (not `inversed`).
    pub polarity_normal: bool,
}

/// One attribute write of a set-up, in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AttrWrite {
    pub attr: ChannelAttr,
    pub value: String,
}

impl AttrWrite {
    fn new(attr: ChannelAttr, value: impl ToString) -> AttrWrite {
        AttrWrite {
            attr,
            value: value.to_string(),
        }
    }
}

/// The writes that take a channel from `current` to `period_ns`, `duty_ns`
/// (≤ `period_ns`), normal polarity and enabled, in an order where the duty
/// never exceeds the period and polarity changes only while disabled.
/// Attributes that already hold the wanted value are not written. There is
/// no detour through a zero duty: a running channel keeps pulsing.
pub fn setup_writes(current: &ChannelState, period_ns: u64, duty_ns: u64) -> Vec<AttrWrite> {
    let mut writes = Vec::new();
    if current.duty_ns > period_ns {
        // duty_ns <= period_ns < current.duty_ns <= current.period_ns: the
        // new duty fits the old period, and then the new period fits it.
        writes.push(AttrWrite::new(ChannelAttr::DutyCycle, duty_ns));
        writes.push(AttrWrite::new(ChannelAttr::Period, period_ns));
    } else {
        // The new period holds the current duty; then the new duty fits.
        if current.period_ns != period_ns {
            writes.push(AttrWrite::new(ChannelAttr::Period, period_ns));
        }
        if current.duty_ns != duty_ns {
            writes.push(AttrWrite::new(ChannelAttr::DutyCycle, duty_ns));
        }
    }
    let mut enabled = current.enabled;
    if !current.polarity_normal {
        if enabled {
            writes.push(AttrWrite::new(ChannelAttr::Enable, 0));
            enabled = false;
        }
        writes.push(AttrWrite::new(ChannelAttr::Polarity, "normal"));
    }
    if !enabled {
        writes.push(AttrWrite::new(ChannelAttr::Enable, 1));
    }
    writes
}

struct OutputState {
    spec: PwmOutput,
    chip_dir: PathBuf,
    channel_dir: PathBuf,
    duty_path: PathBuf,
    /// What the file holds as far as this driver knows; `None` after a
    /// failed write, so the next pulse is written whatever its value.
    last_duty_ns: Option<u64>,
    /// Export/period/enable still to do (at open, after a vanished file).
    needs_setup: bool,
}

/// A fixed set of sysfs PWM outputs at one period.
///
/// Outputs are addressed by their index in the list given to
/// [`SysfsPwm::open`]. Dropping the driver writes every output's trim pulse
/// and leaves the channels exported and enabled, so servos hold centre and
/// ESCs see neutral instead of a line that went quiet (which some ESCs
/// treat as "keep the last command").
pub struct SysfsPwm {
    period_ns: u64,
    outputs: Vec<OutputState>,
    /// Set by [`SysfsPwm::close`] so `Drop` does not write trim twice.
    closed: bool,
    status: SharedStatus,
    /// The caller's clock origin for `last_message`.
    origin: Instant,
}

impl fmt::Debug for SysfsPwm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SysfsPwm")
            .field("period_ns", &self.period_ns)
            .field("outputs", &self.outputs.iter().map(|o| o.spec).collect::<Vec<_>>())
            .finish()
    }
}

impl SysfsPwm {
    /// Exports (if needed), configures and enables every output at its trim
    /// pulse. Blocks at most `export_timeout` per exported channel. Status
    /// times count from this call.
    pub fn open(config: &SysfsPwmConfig, outputs: &[PwmOutput]) -> Result<SysfsPwm, PwmError> {
        SysfsPwm::open_with_origin(config, outputs, Instant::now())
    }

    /// [`SysfsPwm::open`] with status times counted from `origin` (the
    /// process start, like every other device's).
    pub fn open_with_origin(
        config: &SysfsPwmConfig,
        outputs: &[PwmOutput],
        origin: Instant,
    ) -> Result<SysfsPwm, PwmError> {
        if config.period_ns == 0 {
            return Err(PwmError::InvalidPeriod {
                period_ns: config.period_ns,
            });
        }
        for (i, o) in outputs.iter().enumerate() {
            if outputs[..i].iter().any(|p| p.chip == o.chip && p.channel == o.channel) {
                return Err(PwmError::DuplicateOutput {
                    chip: o.chip,
                    channel: o.channel,
                });
            }
            check_pulse(o.trim_us, config.period_ns)?;
        }
        let mut pwm = SysfsPwm {
            period_ns: config.period_ns,
            outputs: outputs
                .iter()
                .map(|&spec| {
                    let chip_dir = config.root.join(format!("pwmchip{}", spec.chip));
                    let channel_dir = chip_dir.join(format!("pwm{}", spec.channel));
                    OutputState {
                        spec,
                        duty_path: channel_dir.join("duty_cycle"),
                        chip_dir,
                        channel_dir,
                        last_duty_ns: None,
                        needs_setup: true,
                    }
                })
                .collect(),
            closed: false,
            status: device::shared_status(),
            origin,
        };
        // On an error the partly opened driver is dropped, which puts the
        // outputs already set up back to trim (where set-up left them).
        for i in 0..pwm.outputs.len() {
            let trim_ns = pulse_ns(pwm.outputs[i].spec.trim_us);
            pwm.setup(i, trim_ns, config.export_timeout)?;
        }
        pwm.refresh_connected();
        Ok(pwm)
    }

    /// Number of outputs.
    pub fn len(&self) -> usize {
        self.outputs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.outputs.is_empty()
    }

    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// The outputs as opened (with their current trims).
    pub fn outputs(&self) -> impl Iterator<Item = PwmOutput> + '_ {
        self.outputs.iter().map(|o| o.spec)
    }

    /// The pulse last written to `output`, if the driver knows it.
    pub fn last_pulse_us(&self, output: usize) -> Option<u16> {
        let ns = self.outputs.get(output)?.last_duty_ns?;
        u16::try_from(ns / NS_PER_US).ok()
    }

    /// Whether `output` is configured (false after its files vanished,
    /// until a later pulse sets it up again).
    pub fn is_ready(&self, output: usize) -> bool {
        self.outputs.get(output).is_some_and(|o| !o.needs_setup)
    }

    /// A copy of the outputs' health: `connected` while every output is set
    /// up, `connects` counts (re)completions of that, `messages` pulses
    /// written, `bytes_out` attribute bytes written, `errors` file errors.
    pub fn status(&self) -> DeviceStatus {
        device::snapshot(&self.status)
    }

    /// The live status handle, for a status view that outlives borrows.
    pub fn shared_status(&self) -> SharedStatus {
        self.status.clone()
    }

    /// Sets the pulse width of `output`. Writes `duty_cycle` only when the
    /// value changed; after a vanished file, sets the channel up again first
    /// (without waiting: a channel still being exported fails this call and
    /// is retried by the next). A pulse of 0 or longer than the period is
    /// rejected before any file is touched.
    pub fn set_pulse_us(&mut self, output: usize, pulse_us: u16) -> Result<(), PwmError> {
        self.check_output(output)?;
        check_pulse(pulse_us, self.period_ns)?;
        let ns = pulse_ns(pulse_us);
        if self.outputs[output].needs_setup {
            let result = self.setup(output, ns, Duration::ZERO);
            self.refresh_connected();
            return result;
        }
        if self.outputs[output].last_duty_ns == Some(ns) {
            return Ok(());
        }
        let result = self.write_duty(output, ns);
        self.refresh_connected();
        result
    }

    /// Changes the pulse `output` is left at on drop (SERVOn_TRIM changed).
    pub fn set_trim_us(&mut self, output: usize, trim_us: u16) -> Result<(), PwmError> {
        self.check_output(output)?;
        check_pulse(trim_us, self.period_ns)?;
        self.outputs[output].spec.trim_us = trim_us;
        Ok(())
    }

    /// Sets every output to its trim pulse. Every output is attempted even
    /// when one fails (a vanished chip must not keep the others from going to
    /// trim); the first error is returned.
    pub fn set_all_to_trim(&mut self) -> Result<(), PwmError> {
        let mut first = None;
        for i in 0..self.outputs.len() {
            let trim = self.outputs[i].spec.trim_us;
            if let Err(e) = self.set_pulse_us(i, trim) {
                first.get_or_insert(e);
            }
        }
        first.map_or(Ok(()), Err)
    }

    /// Writes every output's trim (even where the driver believes it is
    /// there already) and reports the first failure, which `Drop` cannot.
    pub fn close(mut self) -> Result<(), PwmError> {
        self.closed = true;
        self.force_trim()
    }

    fn force_trim(&mut self) -> Result<(), PwmError> {
        let mut first = None;
        for i in 0..self.outputs.len() {
            if self.outputs[i].needs_setup {
                // Never configured or gone: writing a duty there could only
                // fail or, on a half-set-up channel, break the period rule.
                continue;
            }
            let trim_ns = pulse_ns(self.outputs[i].spec.trim_us);
            if let Err(e) = self.write_duty(i, trim_ns) {
                first.get_or_insert(e);
            }
        }
        first.map_or(Ok(()), Err)
    }

    fn check_output(&self, output: usize) -> Result<(), PwmError> {
        if output < self.outputs.len() {
            Ok(())
        } else {
            Err(PwmError::NoSuchOutput {
                output,
                outputs: self.outputs.len(),
            })
        }
    }

    fn write_duty(&mut self, output: usize, ns: u64) -> Result<(), PwmError> {
        let result = write_attr(&self.outputs[output].duty_path, &ns.to_string());
        let state = &mut self.outputs[output];
        match result {
            Ok(bytes) => {
                state.last_duty_ns = Some(ns);
                self.note_written(bytes, true);
                Ok(())
            }
            Err(e) => {
                state.last_duty_ns = None;
                if e.is_vanished() {
                    state.needs_setup = true;
                    tracing::warn!(error = %e, "PWM output lost; set up again on the next pulse");
                }
                self.note_error(&e);
                Err(e)
            }
        }
    }

    /// Exports `output` if its directory is missing, then sets period, duty
    /// (`duty_ns`), normal polarity and enable, writing only what differs.
    fn setup(&mut self, output: usize, duty_ns: u64, wait: Duration) -> Result<(), PwmError> {
        let period_ns = self.period_ns;
        let state = &mut self.outputs[output];
        state.last_duty_ns = None;
        let mut bytes = 0;
        let result = configure(state, period_ns, duty_ns, wait, &mut bytes);
        match &result {
            Ok(()) => {
                state.needs_setup = false;
                state.last_duty_ns = Some(duty_ns);
                tracing::info!(
                    chip = state.spec.chip,
                    channel = state.spec.channel,
                    "PWM output set up"
                );
            }
            Err(_) => state.needs_setup = true,
        }
        self.note_written(bytes, result.is_ok());
        if let Err(e) = &result {
            self.note_error(e);
        }
        result
    }

    fn note_written(&self, bytes: usize, pulse_written: bool) {
        let now = self.origin.elapsed();
        device::update(&self.status, |s| {
            s.bytes_out += bytes as u64;
            if pulse_written {
                s.messages += 1;
                s.last_message = Some(now);
            }
        });
    }

    fn note_error(&self, error: &PwmError) {
        device::update(&self.status, |s| {
            s.errors += 1;
            s.last_error = Some(error.to_string());
        });
    }

    fn refresh_connected(&self) {
        let all_ready = self.outputs.iter().all(|o| !o.needs_setup);
        device::update(&self.status, |s| {
            if all_ready && !s.connected {
                s.connects += 1;
            }
            s.connected = all_ready;
        });
    }
}

/// Exports (bounded wait) and applies [`setup_writes`] to one channel,
/// adding the bytes written to `bytes` (also when a later write fails).
fn configure(
    state: &OutputState,
    period_ns: u64,
    duty_ns: u64,
    wait: Duration,
    bytes: &mut usize,
) -> Result<(), PwmError> {
    let dir = &state.channel_dir;
    let period_path = dir.join(ChannelAttr::Period.file_name());
    if !dir.is_dir() {
        // Check npwm first: an out-of-range export fails with a bare EINVAL,
        // this names the actual problem.
        let npwm_path = state.chip_dir.join("npwm");
        let npwm = read_number(&npwm_path)?;
        if u64::from(state.spec.channel) >= npwm {
            return Err(PwmError::NoSuchChannel {
                path: npwm_path,
                channel: state.spec.channel,
                npwm,
            });
        }
        *bytes += write_attr(&state.chip_dir.join("export"), &state.spec.channel.to_string())?;
        wait_writable(dir, &period_path, wait)?;
    }
    let current = ChannelState {
        period_ns: read_number(&period_path)?,
        duty_ns: read_number(&state.duty_path)?,
        enabled: read_attr(&dir.join(ChannelAttr::Enable.file_name()))? == "1",
        polarity_normal: read_attr(&dir.join(ChannelAttr::Polarity.file_name()))? == "normal",
    };
    for write in setup_writes(&current, period_ns, duty_ns) {
        *bytes += write_attr(&dir.join(write.attr.file_name()), &write.value)?;
    }
    Ok(())
}

fn pulse_ns(pulse_us: u16) -> u64 {
    u64::from(pulse_us) * NS_PER_US
}

fn check_pulse(pulse_us: u16, period_ns: u64) -> Result<(), PwmError> {
    if pulse_us == 0 {
        Err(PwmError::ZeroPulse)
    } else if pulse_ns(pulse_us) <= period_ns {
        Ok(())
    } else {
        Err(PwmError::PulseTooLong { pulse_us, period_ns })
    }
}

impl Drop for SysfsPwm {
    /// Outputs go to trim when the process exits normally or unwinds.
    fn drop(&mut self) {
        if !self.closed {
            // Nowhere to report from a destructor; `close` reports instead.
            let _ = self.force_trim();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The kernel's rules for the attributes set-up writes (pwm core
    /// `pwm_apply_might_sleep` and the sysfs store functions).
    fn kernel_apply(state: &mut ChannelState, write: &AttrWrite) -> Result<(), String> {
        let number = || write.value.parse::<u64>().map_err(|e| format!("{write:?}: {e}"));
        match write.attr {
            ChannelAttr::Period => {
                let period = number()?;
                if period < state.duty_ns {
                    return Err(format!("period {period} < duty {}", state.duty_ns));
                }
                state.period_ns = period;
            }
            ChannelAttr::DutyCycle => {
                let duty = number()?;
                if duty > state.period_ns {
                    return Err(format!("duty {duty} > period {}", state.period_ns));
                }
                state.duty_ns = duty;
            }
            ChannelAttr::Enable => match write.value.as_str() {
                "0" => state.enabled = false,
                "1" => state.enabled = true,
                other => return Err(format!("enable {other:?}")),
            },
            ChannelAttr::Polarity => {
                if state.enabled {
                    return Err("polarity changed while enabled".into());
                }
                match write.value.as_str() {
                    "normal" => state.polarity_normal = true,
                    "inversed" => state.polarity_normal = false,
                    other => return Err(format!("polarity {other:?}")),
                }
            }
        }
        Ok(())
    }

    fn channel_state() -> impl Strategy<Value = ChannelState> {
        (0u64..=60_000_000, any::<bool>(), any::<bool>(), 0.0f64..=1.0).prop_map(
            |(period_ns, enabled, polarity_normal, fraction)| ChannelState {
                period_ns,
                // The kernel keeps duty <= period.
                duty_ns: (period_ns as f64 * fraction) as u64,
                enabled,
                polarity_normal,
            },
        )
    }

    proptest! {
        #[test]
        fn setup_writes_reach_the_target_through_states_the_kernel_accepts(
            current in channel_state(),
            period_ns in 1u64..=60_000_000,
            fraction in 0.0f64..=1.0,
        ) {
            let duty_ns = (period_ns as f64 * fraction) as u64;
            let mut state = current;
            let writes = setup_writes(&current, period_ns, duty_ns);
            for write in &writes {
                if let Err(e) = kernel_apply(&mut state, write) {
                    return Err(TestCaseError::fail(format!("{current:?} → {writes:?}: {e}")));
                }
            }
            let wanted = ChannelState { period_ns, duty_ns, enabled: true, polarity_normal: true };
            prop_assert_eq!(state, wanted);
            // Nothing written twice.
            for (i, w) in writes.iter().enumerate() {
                prop_assert!(writes[i + 1..].iter().all(|v| v != w), "{:?} repeated in {:?}", w, writes);
            }
        }
    }

    #[test]
    fn a_longer_old_duty_is_shortened_before_the_period() {
        let current = ChannelState {
            period_ns: 50_000_000,
            duty_ns: 30_000_000,
            enabled: true,
            polarity_normal: true,
        };
        let writes = setup_writes(&current, 20_000_000, 1_500_000);
        assert_eq!(
            writes,
            vec![
                AttrWrite::new(ChannelAttr::DutyCycle, 1_500_000),
                AttrWrite::new(ChannelAttr::Period, 20_000_000),
            ]
        );
    }

    #[test]
    fn a_fresh_channel_gets_period_then_duty_then_enable() {
        let fresh = ChannelState {
            period_ns: 0,
            duty_ns: 0,
            enabled: false,
            polarity_normal: true,
        };
        let attrs: Vec<_> = setup_writes(&fresh, 20_000_000, 1_500_000)
            .iter()
            .map(|w| w.attr)
            .collect();
        assert_eq!(
            attrs,
            [ChannelAttr::Period, ChannelAttr::DutyCycle, ChannelAttr::Enable]
        );
    }

    #[test]
    fn pulses_outside_the_period_or_zero_are_rejected() {
        assert!(matches!(check_pulse(0, 20_000_000), Err(PwmError::ZeroPulse)));
        assert!(check_pulse(20_000, 20_000_000).is_ok());
        assert!(matches!(
            check_pulse(20_001, 20_000_000),
            Err(PwmError::PulseTooLong { pulse_us: 20_001, .. })
        ));
    }
}
