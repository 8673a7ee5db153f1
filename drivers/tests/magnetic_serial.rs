//! The magnetic guide sensor's serial frames: the parser on hand-made and
//! random streams, and the device thread on pseudo-terminals that are
//! unplugged and replugged under it.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use drivers::clock::{DeviceClock, ManualClock};

use drivers::magnetic_serial::{
    FRAME_LEN, FramerStats, MagneticFrame, MagneticFramer, MagneticSerial, crc8_smbus, encode_frame,
};
use proptest::prelude::*;
use serialport::{SerialPort, TTYPort};

fn frame(front_mask: u16, rear_mask: u16, seq: u8) -> MagneticFrame {
    MagneticFrame {
        front_mask,
        rear_mask,
        seq,
    }
}

// ---- format and parser ----

#[test]
fn crc_is_crc8_smbus() {
    // The catalogued check value of CRC-8/SMBUS.
    assert_eq!(crc8_smbus(b"123456789"), 0xF4);
    assert_eq!(crc8_smbus(&[]), 0x00);
}

#[test]
fn frame_layout_is_sync_masks_le_seq_crc() {
    let bytes = encode_frame(0x1234, 0xABCD, 0x7F);
    assert_eq!(bytes.len(), FRAME_LEN);
    assert_eq!(&bytes[..7], &[0xA5, 0x5A, 0x34, 0x12, 0xCD, 0xAB, 0x7F]);
    assert_eq!(bytes[7], crc8_smbus(&[0x34, 0x12, 0xCD, 0xAB, 0x7F]));
}

#[test]
fn a_frame_fed_byte_by_byte_comes_out_once_at_its_last_byte() {
    let mut framer = MagneticFramer::new();
    let bytes = encode_frame(0b0000_0001_1000_0000, 0xFFFF, 3);
    for &b in &bytes[..FRAME_LEN - 1] {
        assert!(framer.push(&[b]).is_empty());
    }
    assert_eq!(framer.push(&bytes[FRAME_LEN - 1..]), vec![frame(0x0180, 0xFFFF, 3)]);
    assert_eq!(framer.push(&[]), vec![]);
    assert_eq!(framer.stats().frames, 1);
}

#[test]
fn a_bad_checksum_is_dropped_counted_and_the_next_frame_survives() {
    let mut framer = MagneticFramer::new();
    let mut corrupt = encode_frame(0x00F0, 0x0F00, 1);
    corrupt[3] ^= 0x10;
    let mut stream = corrupt.to_vec();
    stream.extend_from_slice(&encode_frame(0x00F0, 0x0F00, 2));
    assert_eq!(framer.push(&stream), vec![frame(0x00F0, 0x0F00, 2)]);
    let stats = framer.stats();
    assert_eq!(stats.bad_checksums, 1);
    assert_eq!(stats.frames, 1);
    assert_eq!(stats.discarded_bytes, FRAME_LEN as u64);
}

#[test]
fn noise_and_false_syncs_before_a_frame_are_skipped() {
    let mut framer = MagneticFramer::new();
    // A false sync pair whose "frame" runs into the real one, a lone 0xA5 at
    // the end of a chunk, and masks that contain the sync bytes themselves.
    let mut stream = vec![0x00, 0xA5, 0x5A, 0x01, 0x13, 0xA5];
    stream.extend_from_slice(&encode_frame(0x5AA5, 0xA55A, 9));
    let (first, second) = stream.split_at(6);
    assert!(framer.push(first).is_empty());
    assert_eq!(framer.push(second), vec![frame(0x5AA5, 0xA55A, 9)]);
    assert_eq!(
        framer.push(&encode_frame(0x5AA5, 0xA55A, 10)),
        vec![frame(0x5AA5, 0xA55A, 10)]
    );
    // Every byte before the real frame is skipped; the false pair cost one
    // failed candidate.
    assert_eq!(framer.stats().discarded_bytes, 6);
    assert_eq!(framer.stats().bad_checksums, 1);
}

#[test]
fn sequence_gaps_are_counted_and_wrap_is_not_a_gap() {
    let mut framer = MagneticFramer::new();
    let mut stream = Vec::new();
    for seq in [254u8, 255, 0, 1, 5, 6, 6, 7] {
        stream.extend_from_slice(&encode_frame(1, 2, seq));
    }
    assert_eq!(framer.push(&stream).len(), 8);
    // 1 → 5 (lost frames) and 6 → 6 (repeat).
    assert_eq!(framer.stats().sequence_gaps, 2);
    // After a resync (reconnect) the first frame is no gap.
    framer.resync();
    framer.push(&encode_frame(1, 2, 100));
    assert_eq!(framer.stats().sequence_gaps, 2);
}

#[test]
fn garbage_never_yields_a_frame_with_a_wrong_checksum() {
    let mut framer = MagneticFramer::new();
    let garbage: Vec<u8> = (0..20_000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    for frame in framer.push(&garbage) {
        let bytes = encode_frame(frame.front_mask, frame.rear_mask, frame.seq);
        assert!(garbage.windows(FRAME_LEN).any(|w| w == bytes));
    }
    // Every byte is accounted for: in a frame, discarded, or (fewer than a
    // frame's worth) still pending.
    let stats = framer.stats();
    let accounted = stats.discarded_bytes + stats.frames * FRAME_LEN as u64;
    assert!(
        accounted <= garbage.len() as u64 && accounted + FRAME_LEN as u64 > garbage.len() as u64,
        "{stats:?}"
    );
}

/// Noise without 0xA5: a false sync pair in noise followed by bytes whose
/// CRC happens to match would be indistinguishable from a frame (1 in 256
/// per false pair), which no 8-bit check can rule out.
fn noise() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(any::<u8>().prop_filter("no sync start", |b| *b != 0xA5), 0..20)
}

proptest! {
    #[test]
    fn every_good_frame_survives_noise_and_any_chunking(
        frames in prop::collection::vec((any::<u16>(), any::<u16>()), 1..40),
        noises in prop::collection::vec(noise(), 41),
        cuts in prop::collection::vec(1usize..30, 1..200),
        first_seq in any::<u8>(),
    ) {
        let mut stream = Vec::new();
        let mut expected = Vec::new();
        let mut noise_bytes = 0;
        for (i, &(front, rear)) in frames.iter().enumerate() {
            stream.extend_from_slice(&noises[i]);
            noise_bytes += noises[i].len();
            let seq = first_seq.wrapping_add(i as u8);
            stream.extend_from_slice(&encode_frame(front, rear, seq));
            expected.push(frame(front, rear, seq));
        }
        stream.extend_from_slice(&noises[frames.len()]);
        noise_bytes += noises[frames.len()].len();

        let mut framer = MagneticFramer::new();
        let mut got = Vec::new();
        let mut rest = &stream[..];
        for cut in cuts.iter().cycle() {
            if rest.is_empty() {
                break;
            }
            let (chunk, tail) = rest.split_at((*cut).min(rest.len()));
            got.extend(framer.push(chunk));
            rest = tail;
        }
        prop_assert_eq!(got, expected);
        prop_assert_eq!(
            framer.stats(),
            FramerStats {
                frames: frames.len() as u64,
                bad_checksums: 0,
                discarded_bytes: noise_bytes as u64,
                sequence_gaps: 0,
            }
        );
    }

    #[test]
    fn dropped_frames_are_counted_as_gaps(
        keep in prop::collection::vec(any::<bool>(), 2..60),
    ) {
        let mut framer = MagneticFramer::new();
        let sent: Vec<u8> = keep.iter().enumerate().filter(|(_, k)| **k).map(|(i, _)| i as u8).collect();
        let mut stream = Vec::new();
        for &seq in &sent {
            stream.extend_from_slice(&encode_frame(0, 0, seq));
        }
        prop_assert_eq!(framer.push(&stream).len(), sent.len());
        let gaps = sent.windows(2).filter(|w| w[1] != w[0] + 1).count() as u64;
        prop_assert_eq!(framer.stats().sequence_gaps, gaps);
    }
}

// ---- the device thread on pseudo-terminals ----

/// Bounded waits for the reader thread and bytes over the pty; timing
/// decisions (staleness, backoff expiry) are made on a [`ManualClock`].
const DEADLINE: Duration = Duration::from_secs(2);
/// The longest reopen backoff (2 s): one step ends any backoff wait.
const RETRY_STEP: Duration = Duration::from_secs(2);

fn temp_dir() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("furrow-magnetic-")
        .tempdir()
        .expect("temp dir")
}

/// Points `link` at `target` atomically (a new link renamed over the old).
fn point_link(link: &Path, target: &Path) {
    let staging = link.with_extension("new");
    let _ = std::fs::remove_file(&staging);
    std::os::unix::fs::symlink(target, &staging).expect("symlink");
    std::fs::rename(&staging, link).expect("rename link");
}

/// A sensor on a pty: streams frames with its own masks at 100 Hz until
/// dropped. Dropping it closes both ends, like pulling the USB adapter.
struct FakeSensor {
    stop: Arc<AtomicBool>,
    writer: Option<JoinHandle<()>>,
    slave_path: PathBuf,
}

impl FakeSensor {
    fn plug(front_mask: u16, rear_mask: u16) -> FakeSensor {
        let (mut master, slave) = TTYPort::pair().expect("pty pair");
        let slave_path = PathBuf::from(slave.name().expect("slave name"));
        let stop = Arc::new(AtomicBool::new(false));
        let writer = {
            let stop = stop.clone();
            thread::spawn(move || {
                // Hold the slave so the pty stays whole while the driver
                // opens and closes it.
                let _slave = slave;
                let _ = master.set_timeout(Duration::from_millis(50));
                let mut seq = 0u8;
                while !stop.load(Ordering::Relaxed) {
                    // Nobody reading (driver backing off) may fill the pty:
                    // a failed write is simply a lost frame.
                    let _ = master.write_all(&encode_frame(front_mask, rear_mask, seq));
                    seq = seq.wrapping_add(1);
                    thread::sleep(Duration::from_millis(10));
                }
            })
        };
        FakeSensor {
            stop,
            writer: Some(writer),
            slave_path,
        }
    }
}

impl Drop for FakeSensor {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(writer) = self.writer.take() {
            let _ = writer.join();
        }
    }
}

fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + DEADLINE;
    while !done() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        thread::sleep(Duration::from_millis(5));
    }
}

/// Moves the clock past any backoff between looks until `done`.
fn retry_until(clock: &ManualClock, what: &str, mut done: impl FnMut() -> bool) {
    wait_for(what, || {
        let met = done();
        if !met {
            clock.advance(RETRY_STEP);
        }
        met
    });
}

fn spawn(link: &Path, baud: u32, stale_after: Duration, clock: &Arc<ManualClock>) -> MagneticSerial {
    let clock = Arc::clone(clock) as Arc<dyn DeviceClock>;
    MagneticSerial::spawn_with_clock(link.to_string_lossy().into_owned(), baud, stale_after, clock)
}

/// Waits for a sample from the device and returns it.
fn next_sample(sensor: &MagneticSerial) -> drivers::magnetic::MagneticSample {
    let mut sample = None;
    wait_for("a sample", || {
        sample = sensor.latest();
        sample.is_some()
    });
    sample.expect("waited for it")
}

#[test]
fn samples_arrive_go_stale_on_unplug_and_resume_on_replug() {
    let dir = temp_dir();
    let link = dir.path().join("magnetic");
    let clock = ManualClock::new();
    let stale_after = Duration::from_millis(150);

    // Plugged after the start, so "no sample yet" is certain when checked
    // (the sensor streams at once, and samples are stamped on the same
    // clock that is read here).
    let sensor = spawn(&link, 115_200, stale_after, &clock);
    wait_for("a failed open", || sensor.status().errors >= 1);
    assert!(sensor.is_stale(clock.now()), "stale before any sample");
    let first = FakeSensor::plug(0x0180, 0x03C0);
    point_link(&link, &first.slave_path);
    retry_until(&clock, "the open", || sensor.status().connects == 1);

    let sample = next_sample(&sensor);
    assert_eq!((sample.front_mask, sample.rear_mask), (0x0180, 0x03C0));
    assert!(sample.t <= clock.now());
    // The last retry step may have come after the first samples; the sensor
    // streams, so one stamped after it follows.
    wait_for("a fresh sample", || !sensor.is_stale(clock.now()));
    // latest() hands out each sample once, then newer ones.
    let again = next_sample(&sensor);
    assert!(again.t >= sample.t);
    let status = sensor.status();
    assert!(status.connected);
    assert_eq!(status.connects, 1);
    assert!(
        status.messages >= 2 && status.bytes_in >= 2 * FRAME_LEN as u64,
        "{status:?}"
    );
    assert_eq!(sensor.framer_stats().bad_checksums, 0);

    // Unplug: the link now leads nowhere and the pty is gone.
    point_link(&link, &dir.path().join("unplugged"));
    drop(first);
    wait_for("disconnect", || !sensor.status().connected);
    let last_message = sensor.status().last_message.expect("had samples");
    clock.advance((last_message + stale_after).saturating_sub(clock.now()));
    assert!(!sensor.is_stale(clock.now()), "stale at exactly stale_after");
    clock.advance(Duration::from_millis(1));
    assert!(sensor.is_stale(clock.now()));
    let _ = sensor.latest();
    thread::sleep(Duration::from_millis(50));
    assert_eq!(sensor.latest(), None, "no samples while unplugged");
    let errors_while_unplugged = sensor.status().errors;
    assert!(errors_while_unplugged >= 1);
    assert!(sensor.status().last_error.is_some());

    // Replug a sensor with other masks on a new pty.
    let second = FakeSensor::plug(0x8001, 0x0002);
    point_link(&link, &second.slave_path);
    retry_until(&clock, "the reopen", || sensor.status().connects == 2);
    let mut masks = (0, 0);
    wait_for("samples from the replugged sensor", || {
        masks = sensor.latest().map_or(masks, |s| (s.front_mask, s.rear_mask));
        masks == (0x8001, 0x0002)
    });
    // The clock may have moved on between the reopen and this look; the
    // sensor streams, so a sample stamped after it follows.
    wait_for("a fresh sample", || !sensor.is_stale(clock.now()));
    let status = sensor.status();
    assert!(status.connected);
    assert_eq!(status.connects, 2);

    // Dropping the handle stops the thread promptly.
    let start = Instant::now();
    drop(sensor);
    assert!(
        start.elapsed() < Duration::from_millis(300),
        "drop took {:?}",
        start.elapsed()
    );
    drop(second);
}

#[test]
fn a_port_that_is_not_there_is_retried_and_drop_is_prompt() {
    let dir = temp_dir();
    let link = dir.path().join("magnetic");
    let clock = ManualClock::new();
    let sensor = spawn(&link, 9_600, Duration::from_millis(200), &clock);
    retry_until(&clock, "two failed opens", || sensor.status().errors >= 2);
    let status = sensor.status();
    assert!(!status.connected);
    assert_eq!(status.connects, 0);
    assert!(
        status.last_error.as_deref().is_some_and(|e| e.contains("magnetic")),
        "{status:?}"
    );
    assert!(sensor.is_stale(clock.now()));

    // The thread is in its backoff wait now (the clock stands still, so it
    // would never end); drop must not wait it out.
    let start = Instant::now();
    drop(sensor);
    assert!(
        start.elapsed() < Duration::from_millis(300),
        "drop took {:?}",
        start.elapsed()
    );
}
