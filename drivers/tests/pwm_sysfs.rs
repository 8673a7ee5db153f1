//! The sysfs PWM driver against a fake `/sys/class/pwm` of plain files in a
//! temporary directory. A small thread plays the kernel's part of `export`
//! (create `pwmM/` with its attributes); everything else the driver does is
//! plain file I/O, so the tests read back what a real chip would be sent.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use drivers::pwm::{PwmError, PwmOutput, SysfsPwm, SysfsPwmConfig};

const PERIOD_NS: u64 = 20_000_000;
const DEADLINE: Duration = Duration::from_secs(2);

/// A temporary PWM class directory and, optionally, a thread that answers
/// `export` writes the way the kernel does.
struct FakeSysfs {
    /// Removed on drop, after `Drop::drop` has stopped the kernel thread.
    _dir: tempfile::TempDir,
    root: PathBuf,
    stop: Arc<AtomicBool>,
    kernel: Option<JoinHandle<()>>,
}

impl FakeSysfs {
    fn new(with_kernel: bool) -> FakeSysfs {
        let dir = tempfile::Builder::new()
            .prefix("furrow-pwm-")
            .tempdir()
            .expect("temp root");
        let root = dir.path().to_path_buf();
        let stop = Arc::new(AtomicBool::new(false));
        let kernel = with_kernel.then(|| {
            let (root, stop) = (root.clone(), stop.clone());
            thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    serve_exports(&root);
                    thread::sleep(Duration::from_millis(1));
                }
            })
        });
        FakeSysfs {
            _dir: dir,
            root,
            stop,
            kernel,
        }
    }

    fn config(&self) -> SysfsPwmConfig {
        SysfsPwmConfig {
            root: self.root.clone(),
            period_ns: PERIOD_NS,
            export_timeout: Duration::from_millis(500),
        }
    }

    fn chip_dir(&self, chip: u32) -> PathBuf {
        self.root.join(format!("pwmchip{chip}"))
    }

    /// A chip appears with all its files at once (rename), as a probe does.
    fn add_chip(&self, chip: u32, npwm: u32) {
        let staging = self.root.join(format!(".pwmchip{chip}.new"));
        fs::create_dir_all(&staging).expect("staging dir");
        fs::write(staging.join("npwm"), format!("{npwm}\n")).expect("npwm");
        fs::write(staging.join("export"), "").expect("export");
        fs::write(staging.join("unexport"), "").expect("unexport");
        fs::rename(&staging, self.chip_dir(chip)).expect("chip appears");
    }

    fn remove_chip(&self, chip: u32) {
        fs::remove_dir_all(self.chip_dir(chip)).expect("chip removed");
    }

    /// A channel already exported by someone else (a previous process).
    fn preexport(&self, chip: u32, channel: u32, period_ns: u64, duty_ns: u64, enable: &str, polarity: &str) {
        create_channel(&self.chip_dir(chip), channel, period_ns, duty_ns, enable, polarity).expect("pre-export");
    }

    fn attr(&self, chip: u32, channel: u32, name: &str) -> String {
        let path = self.chip_dir(chip).join(format!("pwm{channel}")).join(name);
        fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
            .trim()
            .to_owned()
    }

    fn set_attr(&self, chip: u32, channel: u32, name: &str, value: &str) {
        fs::write(self.chip_dir(chip).join(format!("pwm{channel}")).join(name), value).expect("attribute write");
    }
}

impl Drop for FakeSysfs {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(kernel) = self.kernel.take() {
            let _ = kernel.join();
        }
    }
}

/// One pass of the fake kernel: every chip whose `export` holds a valid
/// channel number gets `pwmM/` (built aside and renamed in, so the driver
/// never sees a half-made channel); `export` is emptied again. Chips may
/// vanish under it at any time: every error is ignored.
fn serve_exports(root: &Path) {
    let Ok(entries) = fs::read_dir(root) else { return };
    for entry in entries.flatten() {
        let chip_dir = entry.path();
        if !entry.file_name().to_string_lossy().starts_with("pwmchip") {
            continue;
        }
        let Ok(request) = fs::read_to_string(chip_dir.join("export")) else {
            continue;
        };
        let Ok(channel) = request.trim().parse::<u32>() else {
            continue;
        };
        let _ = fs::write(chip_dir.join("export"), "");
        let npwm = fs::read_to_string(chip_dir.join("npwm"))
            .ok()
            .and_then(|n| n.trim().parse::<u32>().ok())
            .unwrap_or(0);
        if channel < npwm && !chip_dir.join(format!("pwm{channel}")).exists() {
            // A freshly exported channel: period 0, duty 0, disabled.
            let _ = create_channel(&chip_dir, channel, 0, 0, "0", "normal");
        }
    }
}

fn create_channel(
    chip_dir: &Path,
    channel: u32,
    period_ns: u64,
    duty_ns: u64,
    enable: &str,
    polarity: &str,
) -> std::io::Result<()> {
    let staging = chip_dir.join(format!(".pwm{channel}.new"));
    fs::create_dir_all(&staging)?;
    fs::write(staging.join("period"), format!("{period_ns}\n"))?;
    fs::write(staging.join("duty_cycle"), format!("{duty_ns}\n"))?;
    fs::write(staging.join("enable"), format!("{enable}\n"))?;
    fs::write(staging.join("polarity"), format!("{polarity}\n"))?;
    fs::rename(&staging, chip_dir.join(format!("pwm{channel}")))
}

fn output(chip: u32, channel: u32, trim_us: u16) -> PwmOutput {
    PwmOutput { chip, channel, trim_us }
}

#[test]
fn open_exports_and_sets_period_trim_and_enable() {
    let sysfs = FakeSysfs::new(true);
    sysfs.add_chip(0, 4);
    let pwm = SysfsPwm::open(&sysfs.config(), &[output(0, 0, 1500), output(0, 3, 1000)]).expect("open");

    for (channel, trim_ns) in [(0, "1500000"), (3, "1000000")] {
        assert_eq!(sysfs.attr(0, channel, "period"), PERIOD_NS.to_string());
        assert_eq!(sysfs.attr(0, channel, "duty_cycle"), trim_ns);
        assert_eq!(sysfs.attr(0, channel, "enable"), "1");
        assert_eq!(sysfs.attr(0, channel, "polarity"), "normal");
    }
    assert!(
        !sysfs.chip_dir(0).join("pwm1").exists(),
        "only the listed channels are exported"
    );
    assert!(pwm.is_ready(0) && pwm.is_ready(1));
    assert_eq!(pwm.last_pulse_us(0), Some(1500));
    let status = pwm.status();
    assert!(status.connected);
    assert_eq!(status.connects, 1);
    assert_eq!(status.messages, 2, "one pulse set per output");
    assert_eq!(status.errors, 0);
    assert!(status.bytes_out > 0);
}

#[test]
fn set_pulse_writes_exact_nanoseconds_and_only_on_change() {
    let sysfs = FakeSysfs::new(true);
    sysfs.add_chip(0, 2);
    let mut pwm = SysfsPwm::open(&sysfs.config(), &[output(0, 1, 1500)]).expect("open");

    for pulse_us in [1234u16, 1000, 2000, 987, 1501] {
        pwm.set_pulse_us(0, pulse_us).expect("set");
        assert_eq!(sysfs.attr(0, 1, "duty_cycle"), (u64::from(pulse_us) * 1000).to_string());
        assert_eq!(pwm.last_pulse_us(0), Some(pulse_us));
    }
    let written = pwm.status().messages;

    // Someone else scribbles on the file: an unchanged pulse is not written
    // again (the driver does not rewrite at loop rate)…
    sysfs.set_attr(0, 1, "duty_cycle", "777\n");
    pwm.set_pulse_us(0, 1501).expect("same pulse");
    assert_eq!(sysfs.attr(0, 1, "duty_cycle"), "777");
    assert_eq!(pwm.status().messages, written);
    // …and a changed one is.
    pwm.set_pulse_us(0, 1502).expect("new pulse");
    assert_eq!(sysfs.attr(0, 1, "duty_cycle"), "1502000");
    assert_eq!(pwm.status().messages, written + 1);
}

#[test]
fn invalid_pulses_and_outputs_are_rejected_without_writing() {
    let sysfs = FakeSysfs::new(true);
    sysfs.add_chip(0, 1);
    let mut pwm = SysfsPwm::open(&sysfs.config(), &[output(0, 0, 1500)]).expect("open");

    assert!(matches!(pwm.set_pulse_us(0, 0), Err(PwmError::ZeroPulse)));
    assert!(matches!(
        pwm.set_pulse_us(0, 20_001),
        Err(PwmError::PulseTooLong { pulse_us: 20_001, .. })
    ));
    assert!(matches!(
        pwm.set_pulse_us(1, 1500),
        Err(PwmError::NoSuchOutput { output: 1, outputs: 1 })
    ));
    assert!(matches!(pwm.set_trim_us(0, 0), Err(PwmError::ZeroPulse)));
    assert_eq!(sysfs.attr(0, 0, "duty_cycle"), "1500000");
    // A full-period pulse is legal (100 % duty).
    pwm.set_pulse_us(0, 20_000).expect("full period");
    assert_eq!(sysfs.attr(0, 0, "duty_cycle"), "20000000");

    let config = sysfs.config();
    assert!(matches!(
        SysfsPwm::open(&config, &[output(0, 0, 25_000)]),
        Err(PwmError::PulseTooLong { .. })
    ));
    assert!(matches!(
        SysfsPwm::open(&config, &[output(0, 0, 1500), output(0, 0, 1600)]),
        Err(PwmError::DuplicateOutput { chip: 0, channel: 0 })
    ));
}

#[test]
fn drop_and_close_leave_every_output_at_trim() {
    let sysfs = FakeSysfs::new(true);
    sysfs.add_chip(0, 2);
    sysfs.add_chip(1, 1);
    let outputs = [output(0, 0, 1500), output(0, 1, 1100), output(1, 0, 1600)];

    let mut pwm = SysfsPwm::open(&sysfs.config(), &outputs).expect("open");
    pwm.set_pulse_us(0, 1900).expect("set");
    pwm.set_pulse_us(1, 1900).expect("set");
    pwm.set_pulse_us(2, 1900).expect("set");
    pwm.set_trim_us(2, 1550).expect("trim");
    drop(pwm);
    assert_eq!(sysfs.attr(0, 0, "duty_cycle"), "1500000");
    assert_eq!(sysfs.attr(0, 1, "duty_cycle"), "1100000");
    assert_eq!(sysfs.attr(1, 0, "duty_cycle"), "1550000");
    assert_eq!(sysfs.attr(1, 0, "enable"), "1", "left running at trim, not stopped");

    // close writes trim even where the driver believes it is already there.
    let mut pwm = SysfsPwm::open(&sysfs.config(), &outputs).expect("reopen");
    pwm.set_pulse_us(0, 1200).expect("set");
    sysfs.set_attr(0, 1, "duty_cycle", "1900000\n");
    pwm.close().expect("close");
    assert_eq!(sysfs.attr(0, 0, "duty_cycle"), "1500000");
    assert_eq!(sysfs.attr(0, 1, "duty_cycle"), "1100000");
    assert_eq!(sysfs.attr(1, 0, "duty_cycle"), "1600000");
}

#[test]
fn set_all_to_trim_moves_every_output() {
    let sysfs = FakeSysfs::new(true);
    sysfs.add_chip(0, 2);
    let mut pwm = SysfsPwm::open(&sysfs.config(), &[output(0, 0, 1500), output(0, 1, 1300)]).expect("open");
    pwm.set_pulse_us(0, 2000).expect("set");
    pwm.set_pulse_us(1, 1000).expect("set");
    pwm.set_all_to_trim().expect("trim");
    assert_eq!(sysfs.attr(0, 0, "duty_cycle"), "1500000");
    assert_eq!(sysfs.attr(0, 1, "duty_cycle"), "1300000");
}

#[test]
fn a_channel_left_running_by_another_process_is_taken_over() {
    let sysfs = FakeSysfs::new(true);
    sysfs.add_chip(0, 2);
    // A longer period and a duty longer than our whole period, inversed.
    sysfs.preexport(0, 0, 50_000_000, 30_000_000, "1", "inversed");
    sysfs.preexport(0, 1, 10_000_000, 1_000_000, "1", "normal");
    let _pwm = SysfsPwm::open(&sysfs.config(), &[output(0, 0, 1500), output(0, 1, 1400)]).expect("open");
    for (channel, duty) in [(0, "1500000"), (1, "1400000")] {
        assert_eq!(sysfs.attr(0, channel, "period"), PERIOD_NS.to_string());
        assert_eq!(sysfs.attr(0, channel, "duty_cycle"), duty);
        assert_eq!(sysfs.attr(0, channel, "enable"), "1");
        assert_eq!(sysfs.attr(0, channel, "polarity"), "normal");
    }
}

#[test]
fn a_channel_beyond_npwm_is_named() {
    let sysfs = FakeSysfs::new(true);
    sysfs.add_chip(0, 2);
    match SysfsPwm::open(&sysfs.config(), &[output(0, 2, 1500)]) {
        Err(PwmError::NoSuchChannel {
            path,
            channel: 2,
            npwm: 2,
        }) => {
            assert_eq!(path, sysfs.chip_dir(0).join("npwm"))
        }
        other => panic!("expected NoSuchChannel, got {other:?}"),
    }
}

#[test]
fn a_missing_chip_or_an_export_that_never_appears_fails_open_in_bounded_time() {
    let sysfs = FakeSysfs::new(false);
    match SysfsPwm::open(&sysfs.config(), &[output(7, 0, 1500)]) {
        Err(e @ PwmError::Vanished { .. }) => {
            assert_eq!(e.path(), Some(sysfs.chip_dir(7).join("npwm").as_path()));
            assert!(e.to_string().contains("pwmchip7"), "{e}");
        }
        other => panic!("expected Vanished, got {other:?}"),
    }

    // No kernel behind `export`: the channel never appears.
    sysfs.add_chip(0, 1);
    let mut config = sysfs.config();
    config.export_timeout = Duration::from_millis(150);
    let start = Instant::now();
    let result = SysfsPwm::open(&config, &[output(0, 0, 1500)]);
    let took = start.elapsed();
    match result {
        Err(PwmError::ExportTimeout { path, waited }) => {
            assert_eq!(path, sysfs.chip_dir(0).join("pwm0"));
            assert!(waited >= Duration::from_millis(150));
        }
        other => panic!("expected ExportTimeout, got {other:?}"),
    }
    assert!(took < Duration::from_secs(1), "open waited {took:?}");
    assert_eq!(
        fs::read_to_string(sysfs.chip_dir(0).join("export"))
            .expect("export")
            .trim(),
        "0"
    );
}

#[test]
fn a_vanished_chip_is_an_error_without_blocking_and_recovers_when_it_returns() {
    let sysfs = FakeSysfs::new(true);
    sysfs.add_chip(0, 2);
    sysfs.add_chip(1, 1);
    let mut pwm = SysfsPwm::open(&sysfs.config(), &[output(0, 1, 1500), output(1, 0, 1500)]).expect("open");
    assert_eq!(pwm.status().connects, 1);

    sysfs.remove_chip(0);
    let start = Instant::now();
    let error = pwm.set_pulse_us(0, 1700).expect_err("chip is gone");
    assert!(
        start.elapsed() < Duration::from_millis(100),
        "took {:?}",
        start.elapsed()
    );
    assert!(error.is_vanished(), "{error:?}");
    let path = error.path().expect("names a file").to_owned();
    assert!(path.starts_with(sysfs.chip_dir(0)), "{}", path.display());
    assert!(!pwm.is_ready(0));
    let status = pwm.status();
    assert!(!status.connected);
    assert!(status.errors >= 1);
    assert!(
        status.last_error.as_deref().is_some_and(|e| e.contains("pwmchip0")),
        "{status:?}"
    );

    // The other chip is unaffected, and retries fail fast while 0 is gone.
    pwm.set_pulse_us(1, 1800).expect("other chip");
    assert_eq!(sysfs.attr(1, 0, "duty_cycle"), "1800000");
    for _ in 0..5 {
        let start = Instant::now();
        assert!(pwm.set_pulse_us(0, 1700).expect_err("still gone").is_vanished());
        assert!(start.elapsed() < Duration::from_millis(100));
    }
    let errors_while_gone = pwm.status().errors;
    assert!(
        errors_while_gone >= 6,
        "every failed write is counted: {errors_while_gone}"
    );

    // The chip returns unexported: the driver exports and configures it again
    // on a later pulse, each attempt without waiting for the export.
    sysfs.add_chip(0, 2);
    let deadline = Instant::now() + DEADLINE;
    loop {
        let start = Instant::now();
        let result = pwm.set_pulse_us(0, 1700);
        assert!(
            start.elapsed() < Duration::from_millis(100),
            "retry blocked {:?}",
            start.elapsed()
        );
        match result {
            Ok(()) => break,
            Err(e) if Instant::now() < deadline => {
                assert!(e.path().is_some_and(|p| p.starts_with(sysfs.chip_dir(0))), "{e:?}");
                thread::sleep(Duration::from_millis(5));
            }
            Err(e) => panic!("no recovery within {DEADLINE:?}: {e}"),
        }
    }
    assert_eq!(sysfs.attr(0, 1, "period"), PERIOD_NS.to_string());
    assert_eq!(sysfs.attr(0, 1, "duty_cycle"), "1700000");
    assert_eq!(sysfs.attr(0, 1, "enable"), "1");
    assert!(pwm.is_ready(0));
    let status = pwm.status();
    assert!(status.connected);
    assert_eq!(status.connects, 2);

    // And it is at trim again when the driver goes.
    drop(pwm);
    assert_eq!(sysfs.attr(0, 1, "duty_cycle"), "1500000");
}
