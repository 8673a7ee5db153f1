//! The GNSS device edge against real I/O: pseudo-terminals standing in for a
//! USB receiver (unplugged and replugged behind a symlink, as udev's
//! `/dev/serial/by-id` links behave) and a local TCP NMEA server that goes
//! away and comes back.
//!
//! The port runs on a [`ManualClock`]: backoff expiries, staleness and the
//! silence timeout happen when a test moves the clock. Bytes still travel
//! through a real pty or socket and the port's thread still has to run, so
//! tests wait for those with a bounded wall-time poll ([`DEADLINE`] is only
//! the limit before a failure is declared, never a timing decision).

use std::fs;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use drivers::clock::{DeviceClock, ManualClock};
use drivers::gnss::port::{GnssPort, GnssPortConfig, GnssSource};
use drivers::gnss::{FixQuality, GnssFix, GnssSample, HeadingReference};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serialport::{SerialPort, TTYPort};
use test_support::net::refusing_address;

const DEADLINE: Duration = Duration::from_secs(2);
const STALE_AFTER: Duration = Duration::from_millis(300);
const BACKOFF_MAX: Duration = Duration::from_millis(100);

// ---- NMEA built here, independently of the simulator's writer ----

fn sentence(body: &str) -> String {
    let checksum = body.bytes().fold(0u8, |acc, b| acc ^ b);
    format!("${body}*{checksum:02X}\r\n")
}

/// `ddmm.mmmmmmm,N` / `dddmm.mmmmmmm,E`.
fn coordinate(value_deg: f64, degree_digits: usize, hemispheres: [char; 2]) -> String {
    let hemisphere = if value_deg < 0.0 {
        hemispheres[1]
    } else {
        hemispheres[0]
    };
    let deg = value_deg.abs().trunc();
    let minutes = (value_deg.abs() - deg) * 60.0;
    format!("{:0degree_digits$}{minutes:010.7},{hemisphere}", deg as u32)
}

fn gga(lat_deg: f64, lon_deg: f64) -> String {
    sentence(&format!(
        "GNGGA,101500.00,{},{},4,17,0.7,545.432,M,46.9,M,1.0,0000",
        coordinate(lat_deg, 2, ['N', 'S']),
        coordinate(lon_deg, 3, ['E', 'W'])
    ))
}

/// 2.5 knots at 87.5° true.
fn rmc(lat_deg: f64, lon_deg: f64) -> String {
    sentence(&format!(
        "GNRMC,101500.00,A,{},{},2.500,87.500,211125,,,R",
        coordinate(lat_deg, 2, ['N', 'S']),
        coordinate(lon_deg, 3, ['E', 'W'])
    ))
}

/// 1 KiB of binary that a tty in cooked mode would mangle: NUL, LF, CR,
/// `$` (the NMEA start), XON/XOFF, DEL, and every other byte value.
fn rtcm_like_payload() -> Vec<u8> {
    let mut payload = vec![0xD3, 0x00, 0x0A, 0x0D, 0x0A, 0x24, 0x0D, 0x11, 0x13, 0x7F, 0x03, 0x04];
    payload.extend((0..=255u8).cycle().take(1024 - payload.len() - 4));
    payload.extend([0x0D, 0x0A, 0x00, 0x24]);
    assert_eq!(payload.len(), 1024);
    payload
}

// ---- polling with deadlines (wall time: for the port's thread and real I/O) ----

fn wait_until(timeout: Duration, mut condition: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + timeout;
    loop {
        if condition() {
            return true;
        }
        if Instant::now() > deadline {
            return false;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Moves the port's clock past the longest backoff between looks until
/// `condition` holds: each look gives a waiting thread its next attempt.
fn retry_until(clock: &ManualClock, mut condition: impl FnMut() -> bool) -> bool {
    wait_until(DEADLINE, || {
        if condition() {
            return true;
        }
        clock.advance(BACKOFF_MAX);
        false
    })
}

/// Drains the port into `seen` until `done(seen)` or the deadline.
fn collect_until(port: &GnssPort, seen: &mut Vec<GnssSample>, done: impl Fn(&[GnssSample]) -> bool) -> bool {
    wait_until(DEADLINE, || {
        port.drain_samples(seen);
        done(seen)
    })
}

fn fixes(samples: &[GnssSample]) -> Vec<GnssFix> {
    samples
        .iter()
        .filter_map(|s| match s {
            GnssSample::Fix(fix) => Some(*fix),
            _ => None,
        })
        .collect()
}

fn has_fix_at(samples: &[GnssSample], lat_deg: f64, lon_deg: f64) -> bool {
    fixes(samples)
        .iter()
        .any(|f| (f.lat_deg - lat_deg).abs() < 1e-8 && (f.lon_deg - lon_deg).abs() < 1e-8)
}

fn read_exactly(source: &mut impl Read, len: usize) -> Vec<u8> {
    let deadline = Instant::now() + DEADLINE;
    let mut got = vec![0u8; len];
    let mut filled = 0;
    while filled < len && Instant::now() < deadline {
        match source.read(&mut got[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => {}
            Err(e) => panic!("read: {e}"),
        }
    }
    got.truncate(filled);
    got
}

fn spawn(config: GnssPortConfig, clock: &Arc<ManualClock>) -> GnssPort {
    GnssPort::spawn_with_clock(config, Arc::clone(clock) as Arc<dyn DeviceClock>)
}

fn fast_config(source: GnssSource) -> GnssPortConfig {
    GnssPortConfig {
        stale_after: STALE_AFTER,
        backoff_initial: Duration::from_millis(20),
        backoff_max: BACKOFF_MAX,
        // Tests move the clock by whole backoffs while waiting on a thread;
        // only the silence test wants this timeout to trip.
        reconnect_after_silence: Duration::from_secs(3600),
        ..GnssPortConfig::new(source)
    }
}

// ---- a receiver on a pseudo-terminal behind a symlink ----

/// A temp dir with `gnss0`, a symlink to the slave side of a pty pair,
/// like udev's stable link to a USB receiver.
struct FakeSerialReceiver {
    dir: tempfile::TempDir,
    link: PathBuf,
    /// (master: the receiver's side, slave: held open so the pty lives).
    pair: Option<(TTYPort, TTYPort)>,
}

impl FakeSerialReceiver {
    fn new(tag: &str) -> Self {
        let dir = tempfile::Builder::new()
            .prefix(&format!("furrow-gnss-port-{tag}-"))
            .tempdir()
            .expect("temp dir");
        let link = dir.path().join("gnss0");
        FakeSerialReceiver { dir, link, pair: None }
    }

    fn path(&self) -> String {
        self.link.to_string_lossy().into_owned()
    }

    fn source(&self) -> GnssSource {
        GnssSource::Serial {
            path: self.path(),
            baud: 115_200,
        }
    }

    /// A new pty, and the link re-pointed to it in one rename.
    fn plug(&mut self) {
        let (mut master, slave) = TTYPort::pair().expect("pty pair");
        master.set_timeout(Duration::from_millis(50)).expect("timeout");
        let target = slave.name().expect("slave name");
        let staging = self.dir.path().join("gnss0.new");
        let _ = fs::remove_file(&staging);
        std::os::unix::fs::symlink(&target, &staging).expect("symlink");
        fs::rename(&staging, &self.link).expect("rename");
        self.pair = Some((master, slave));
    }

    /// The link goes first (as udev removes it), so the port cannot open a
    /// pty number that another test reuses; then the pty closes.
    fn unplug(&mut self) {
        fs::remove_file(&self.link).expect("remove link");
        self.pair = None;
    }

    fn master(&mut self) -> &mut TTYPort {
        &mut self.pair.as_mut().expect("plugged").0
    }
}

#[test]
fn serial_fixes_rtcm_unplug_and_replug() {
    let clock = ManualClock::new();
    let mut receiver = FakeSerialReceiver::new("replug");
    receiver.plug();
    let port = spawn(fast_config(receiver.source()), &clock);
    assert!(port.is_stale(clock.now()), "stale before any sentence");
    assert!(wait_until(DEADLINE, || port.status().connected), "{:?}", port.status());

    let (lat, lon) = (48.117_301_5, -11.516_666_7);
    let nmea = gga(lat, lon) + &rmc(lat, lon);
    receiver.master().write_all(nmea.as_bytes()).unwrap();
    let mut seen = Vec::new();
    assert!(
        collect_until(&port, &mut seen, |s| s.len() >= 3),
        "samples: {seen:?}, stats {:?}",
        port.nmea_stats()
    );
    let fix = fixes(&seen)[0];
    assert!(
        (fix.lat_deg - lat).abs() < 1e-8 && (fix.lon_deg - lon).abs() < 1e-8,
        "{fix:?}"
    );
    assert_eq!((fix.quality, fix.satellites), (FixQuality::RtkFixed, 17));
    let velocity = seen.iter().find_map(|s| match s {
        GnssSample::Velocity(v) => Some(*v),
        _ => None,
    });
    let velocity = velocity.expect("RMC velocity");
    assert!((velocity.speed_mps - 2.5 * 1852.0 / 3600.0).abs() < 1e-9);
    assert_eq!(velocity.course_deg, Some(87.5));
    // Stamped on the caller's clock, after the port started and before now.
    assert!(fix.t <= clock.now());
    assert!(!port.is_stale(clock.now()));
    let status = port.status();
    assert_eq!((status.connects, status.messages, status.errors), (1, 2, 0));
    assert_eq!(status.bytes_in, nmea.len() as u64);

    // Corrections come out of the receiver's side byte for byte, with no
    // line-end translation and no echo of the NMEA the receiver sent.
    let payload = rtcm_like_payload();
    assert!(port.send_to_receiver(payload.clone()));
    assert_eq!(read_exactly(receiver.master(), payload.len()), payload);
    let mut extra = [0u8; 64];
    match receiver.master().read(&mut extra) {
        Err(e) if e.kind() == io::ErrorKind::TimedOut => {}
        other => panic!("bytes beyond the payload: {other:?}"),
    }
    assert!(wait_until(DEADLINE, || port.status().bytes_out == 1024));

    // Unplugged: disconnected, then stale once stale_after has passed since
    // the last sentence, and reopen attempts keep failing (and counting).
    receiver.unplug();
    assert!(wait_until(DEADLINE, || !port.status().connected));
    let lost = port.status();
    assert!(lost.errors >= 1 && lost.last_error.is_some(), "{lost:?}");
    let last_message = port.status().last_message.expect("had sentences");
    clock.advance((last_message + STALE_AFTER).saturating_sub(clock.now()));
    assert!(!port.is_stale(clock.now()), "stale at exactly stale_after");
    clock.advance(Duration::from_millis(1));
    assert!(port.is_stale(clock.now()));
    assert!(retry_until(&clock, || port.status().errors >= lost.errors + 2));
    let retrying = port.status();
    assert!(
        retrying
            .last_error
            .as_deref()
            .unwrap_or_default()
            .contains(&receiver.path()),
        "{retrying:?}"
    );
    assert_eq!(retrying.connects, 1);

    // Replugged (a new pty behind the same link): a second connection,
    // and fixes from it.
    receiver.plug();
    assert!(
        retry_until(&clock, || port.status().connects == 2),
        "{:?}",
        port.status()
    );
    let (lat2, lon2) = (-33.856_784_3, 151.215_297_1);
    receiver.master().write_all(gga(lat2, lon2).as_bytes()).unwrap();
    let mut seen = Vec::new();
    assert!(
        collect_until(&port, &mut seen, |s| has_fix_at(s, lat2, lon2)),
        "{seen:?}"
    );
    assert!(!port.is_stale(clock.now()));
    let status = port.status();
    assert!(status.connected);
    assert_eq!(status.connects, 2);
    assert_eq!(port.nmea_stats().sentences, 3);
}

#[test]
fn serial_device_missing_at_start_is_retried_until_it_appears() {
    let clock = ManualClock::new();
    let mut receiver = FakeSerialReceiver::new("late");
    let port = spawn(fast_config(receiver.source()), &clock);
    assert!(wait_until(DEADLINE, || port.status().errors == 1));
    assert!(retry_until(&clock, || port.status().errors >= 3));
    let status = port.status();
    assert!(!status.connected);
    assert_eq!(status.connects, 0);
    assert!(status.last_error.unwrap_or_default().contains("gnss0"));
    // Corrections sent while nothing is connected are dropped, not kept
    // for a device that may be a different one.
    assert!(port.send_to_receiver(vec![0xD3, 0x00, 0x01, 0x00]));
    assert!(wait_until(DEADLINE, || port.frames_dropped() == 1));

    receiver.plug();
    assert!(retry_until(&clock, || port.status().connected));
    receiver.master().write_all(gga(1.5, 2.25).as_bytes()).unwrap();
    let mut seen = Vec::new();
    assert!(
        collect_until(&port, &mut seen, |s| has_fix_at(s, 1.5, 2.25)),
        "{seen:?}"
    );
    assert_eq!(port.status().connects, 1);
    // The dropped frame never reached the device.
    let mut stray = [0u8; 16];
    assert!(matches!(receiver.master().read(&mut stray), Err(e) if e.kind() == io::ErrorKind::TimedOut));
}

#[test]
fn serial_noise_between_sentences_is_counted_and_survived() {
    let clock = ManualClock::new();
    let mut receiver = FakeSerialReceiver::new("noise");
    receiver.plug();
    let port = spawn(fast_config(receiver.source()), &clock);
    assert!(wait_until(DEADLINE, || port.status().connected));

    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let count: u32 = 60;
    let mut stream = Vec::new();
    let mut expected = Vec::new();
    for i in 0..count {
        let noise_len = rng.random_range(0..300);
        stream.extend((0..noise_len).map(|_| rng.random::<u8>()));
        let (lat, lon) = (10.0 + f64::from(i) * 0.001, -70.0 - f64::from(i) * 0.002);
        expected.push((lat, lon));
        stream.extend_from_slice(gga(lat, lon).as_bytes());
    }
    // A noise tail that ends a line so everything before it is counted.
    stream.extend_from_slice(b"\xff\xfe$GNGGA,12*\r\n");
    receiver.master().write_all(&stream).unwrap();

    let mut seen = Vec::new();
    let total = stream.len() as u64;
    assert!(
        wait_until(DEADLINE, || port.status().bytes_in == total),
        "{:?}",
        port.status()
    );
    assert!(collect_until(&port, &mut seen, |s| fixes(s).len() >= count as usize));
    let got: Vec<(f64, f64)> = fixes(&seen).iter().map(|f| (f.lat_deg, f.lon_deg)).collect();
    assert_eq!(got.len(), expected.len());
    for (g, e) in got.iter().zip(&expected) {
        assert!((g.0 - e.0).abs() < 1e-8 && (g.1 - e.1).abs() < 1e-8, "{g:?} vs {e:?}");
    }
    let stats = port.nmea_stats();
    let bad = stats.checksum_errors + stats.malformed + stats.overlong;
    assert_eq!(stats.sentences, u64::from(count));
    assert!(bad >= 10, "{stats:?}");
    let status = port.status();
    assert_eq!((status.messages, status.errors), (stats.sentences, bad));
    assert_eq!(status.connects, 1);
    assert!(status.connected);
}

#[test]
fn serial_full_queue_drops_whole_frames_and_keeps_order() {
    let clock = ManualClock::new();
    let mut receiver = FakeSerialReceiver::new("queue");
    receiver.plug();
    let config = GnssPortConfig {
        write_queue: 4,
        ..fast_config(receiver.source())
    };
    let port = spawn(config, &clock);
    assert!(wait_until(DEADLINE, || port.status().connected));

    // Nobody reads the receiver's side while 256 KiB are offered: far more
    // than a pty buffers, so the queue must fill.
    let frame = |i: u16| -> Vec<u8> {
        let mut bytes = vec![0xD3, (i >> 8) as u8, i as u8, 0x0A, 0x0D];
        bytes.extend((0..1019u32).map(|k| (k as u16).wrapping_mul(31).wrapping_add(i) as u8));
        bytes
    };
    let mut accepted = Vec::new();
    let mut rejected = 0u64;
    for i in 0..256u16 {
        // Paced so the port's thread fills the pty's buffer too, not only
        // its queue: frames then wait half-written for room.
        if i % 8 == 0 {
            std::thread::sleep(Duration::from_millis(4));
        }
        if port.send_to_receiver(frame(i)) {
            accepted.push(i);
        } else {
            rejected += 1;
        }
    }
    assert!(rejected > 0, "the queue never filled");
    assert!(accepted.len() > 8, "only {} frames accepted", accepted.len());
    assert_eq!(port.frames_dropped(), rejected);

    let expected: Vec<u8> = accepted.iter().flat_map(|&i| frame(i)).collect();
    let got = read_exactly(receiver.master(), expected.len());
    assert_eq!(got.len(), expected.len(), "accepted {} frames", accepted.len());
    assert!(got == expected, "bytes differ from the accepted frames in order");
    assert!(wait_until(DEADLINE, || port.status().bytes_out == expected.len() as u64));
    assert_eq!(port.frames_dropped(), rejected);
    assert!(port.status().connected);
}

// ---- a TCP NMEA server ----

/// The port's connection, moving its clock on so a backoff it waits out
/// ends.
fn accept(listener: &TcpListener, clock: &ManualClock) -> TcpStream {
    listener.set_nonblocking(true).unwrap();
    let deadline = Instant::now() + DEADLINE;
    loop {
        match listener.accept() {
            Ok((stream, _)) => {
                stream.set_nonblocking(false).unwrap();
                stream.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
                return stream;
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock && Instant::now() < deadline => {
                clock.advance(BACKOFF_MAX);
                std::thread::sleep(Duration::from_millis(2));
            }
            Err(e) => panic!("no connection from the port: {e}"),
        }
    }
}

fn bind_again(addr: SocketAddr) -> TcpListener {
    let deadline = Instant::now() + DEADLINE;
    loop {
        match TcpListener::bind(addr) {
            Ok(listener) => return listener,
            Err(e) if Instant::now() < deadline => {
                let _ = e;
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(e) => panic!("rebind {addr}: {e}"),
        }
    }
}

#[test]
fn tcp_source_reconnects_after_the_server_restarts() {
    let clock = ManualClock::new();
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let port = spawn(
        fast_config(GnssSource::Tcp {
            address: addr.to_string(),
        }),
        &clock,
    );
    let mut server = accept(&listener, &clock);
    assert!(wait_until(DEADLINE, || port.status().connected));

    let (lat, lon) = (52.520_008_1, 13.404_954_2);
    server.write_all((gga(lat, lon) + &rmc(lat, lon)).as_bytes()).unwrap();
    let mut seen = Vec::new();
    assert!(collect_until(&port, &mut seen, |s| has_fix_at(s, lat, lon)), "{seen:?}");

    let payload = rtcm_like_payload();
    assert!(port.send_to_receiver(payload.clone()));
    assert_eq!(read_exactly(&mut server, payload.len()), payload);

    // The server goes away entirely: end of stream, then refused reconnects.
    drop(server);
    drop(listener);
    assert!(wait_until(DEADLINE, || !port.status().connected));
    let lost = port.status();
    assert!(
        lost.last_error.as_deref().unwrap_or_default().contains("end of stream"),
        "{lost:?}"
    );
    assert!(retry_until(&clock, || port.status().errors >= lost.errors + 2));
    assert!(port.status().last_error.unwrap_or_default().contains("cannot open"));
    assert_eq!(port.status().connects, 1);

    // Back on the same port, now also as a compass (HDM).
    let listener = bind_again(addr);
    let mut server = accept(&listener, &clock);
    assert!(
        wait_until(DEADLINE, || port.status().connects == 2),
        "{:?}",
        port.status()
    );
    let (lat2, lon2) = (52.521_5, 13.41);
    server
        .write_all((gga(lat2, lon2) + &sentence("HCHDM,238.5,M")).as_bytes())
        .unwrap();
    let mut seen = Vec::new();
    assert!(collect_until(&port, &mut seen, |s| has_fix_at(s, lat2, lon2) && s.len() >= 2));
    let heading = seen.iter().find_map(|s| match s {
        GnssSample::Heading(h) => Some(*h),
        _ => None,
    });
    let heading = heading.expect("HDM heading");
    assert_eq!(
        (heading.heading_deg, heading.reference),
        (238.5, HeadingReference::Magnetic)
    );
    assert!(port.status().connected);

    // Dropping the port ends the connection promptly: the server sees EOF.
    let started = Instant::now();
    drop(port);
    let mut buf = [0u8; 16];
    let eof = wait_until(Duration::from_secs(1), || matches!(server.read(&mut buf), Ok(0)));
    assert!(eof, "the connection outlived the port");
    assert!(
        started.elapsed() < Duration::from_millis(500),
        "took {:?}",
        started.elapsed()
    );
}

#[test]
fn tcp_nothing_listening_counts_errors_and_stays_stale() {
    // A port held but never listened on: connects are refused.
    let (_held, addr) = refusing_address();
    let clock = ManualClock::new();
    let port = spawn(
        fast_config(GnssSource::Tcp {
            address: addr.to_string(),
        }),
        &clock,
    );
    assert!(wait_until(DEADLINE, || port.status().errors == 1));
    assert!(retry_until(&clock, || port.status().errors >= 3));
    let status = port.status();
    assert_eq!((status.connected, status.connects, status.messages), (false, 0, 0));
    assert!(port.is_stale(clock.now()));
    let started = Instant::now();
    drop(port);
    assert!(
        started.elapsed() < Duration::from_millis(150),
        "took {:?}",
        started.elapsed()
    );
}

#[test]
fn tcp_silent_connection_is_reopened_after_reconnect_after_silence() {
    let clock = ManualClock::new();
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let silence = Duration::from_secs(5);
    let config = GnssPortConfig {
        reconnect_after_silence: silence,
        ..fast_config(GnssSource::Tcp {
            address: listener.local_addr().unwrap().to_string(),
        })
    };
    let port = spawn(config, &clock);
    let mut server = accept(&listener, &clock);
    assert!(wait_until(DEADLINE, || port.status().connected));
    server.write_all(gga(1.0, 2.0).as_bytes()).unwrap();
    let mut seen = Vec::new();
    assert!(collect_until(&port, &mut seen, |s| has_fix_at(s, 1.0, 2.0)));

    // Exactly the allowance of silence is tolerated (the thread gets several
    // read timeouts to look at the clock); a millisecond more is not.
    clock.advance(silence);
    // A bounded look for something that must not happen: five read timeouts.
    assert!(!wait_until(Duration::from_millis(50), || !port.status().connected));
    assert_eq!(port.status().connects, 1);
    clock.advance(Duration::from_millis(1));
    assert!(wait_until(DEADLINE, || !port.status().connected));
    let lost = port.status();
    assert!(
        lost.last_error.as_deref().unwrap_or_default().contains("no bytes for"),
        "{lost:?}"
    );
    // The server is still there: the port comes back once its backoff ends.
    let _server = accept(&listener, &clock);
    assert!(
        wait_until(DEADLINE, || port.status().connects == 2),
        "{:?}",
        port.status()
    );
}
