//! The scanner client against a fake LMS1xx on loopback. The fake writes its
//! telegrams field by field from SICK's published `LMDscandata` layout (not
//! with `drivers::scanner::cola::encode_lmd_scandata`), so these tests check
//! the client and parser against the format rather than against themselves.

use std::fmt::Write as _;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use drivers::scanner::Scan;
use drivers::scanner::client::{ScannerClient, ScannerClientConfig, ScannerExit, ScannerStats, run_scanner};
use test_support::net::refusing_address;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpSocket, TcpStream};
use tokio::sync::{mpsc, watch};
use tokio::time::{sleep, timeout};

const BEAMS: usize = 541;
const SCAN_PERIOD: Duration = Duration::from_millis(20);

/// Range of `beam` in `scan`, mm; every 50th beam (from 7) has no echo.
fn published_range_mm(scan_counter: u32, beam: usize) -> u32 {
    if beam % 50 == 7 {
        0
    } else {
        1000 + 10 * beam as u32 + scan_counter % 100
    }
}

/// An LMS1xx at 50 Hz, 0.5°, −45°…225° (SICK angles), DIST1 only.
fn published_scan_telegram(command_type: &str, scan_counter: u32) -> Vec<u8> {
    let start_angle_1e4deg: i32 = -450_000;
    let mut s = format!(
        "\x02{command_type} LMDscandata {version:X} {device:X} {serial:X} 0 0 {telegram:X} {scan:X} {up:X} {tx:X} \
         0 0 0 0 0 {freq:X} {meas:X} 0 1 DIST1 3F800000 00000000 {start:X} {step:X} {n:X}",
        version = 1,
        device = 1,
        serial = 0x0123_4567,
        telegram = scan_counter.wrapping_add(7),
        scan = scan_counter,
        up = 1_000_000 + 20_000 * scan_counter,
        tx = 1_000_500 + 20_000 * scan_counter,
        freq = 5000,
        meas = 360,
        start = start_angle_1e4deg as u32,
        step = 5000,
        n = BEAMS,
    );
    for beam in 0..BEAMS {
        write!(s, " {:X}", published_range_mm(scan_counter, beam)).unwrap();
    }
    // No 8-bit channels; position, name, comment, time, event: absent.
    s.push_str(" 0 0 0 0 0 0\x03");
    s.into_bytes()
}

fn assert_published_scan(scan: &Scan) {
    let deg = f64::to_radians;
    assert!(
        (scan.start_angle_rad - deg(135.0)).abs() < 1e-9,
        "{}",
        scan.start_angle_rad
    );
    assert!((scan.step_rad - deg(-0.5)).abs() < 1e-9, "{}", scan.step_rad);
    assert!(
        (scan.angle_rad(270) - 0.0).abs() < 1e-9,
        "beam 270 looks straight ahead"
    );
    assert_eq!(scan.ranges_m.len(), BEAMS);
    for (beam, &range) in scan.ranges_m.iter().enumerate() {
        let mm = published_range_mm(scan.scan_counter, beam);
        if mm == 0 {
            assert!(range.is_nan(), "beam {beam}: {range}");
        } else {
            assert!(
                (f64::from(range) - f64::from(mm) / 1000.0).abs() < 1e-6,
                "beam {beam}: {range} vs {mm} mm"
            );
        }
    }
}

#[derive(Clone, Copy)]
struct Plan {
    first_counter: u32,
    /// Stop (close the connection) after this many streamed scans.
    scans: Option<u32>,
    /// Replace the streamed scan with this counter by a malformed telegram.
    malformed_at: Option<u32>,
    /// Acknowledge the subscription, then say nothing.
    silent: bool,
}

impl Plan {
    fn streaming(first_counter: u32) -> Self {
        Self {
            first_counter,
            scans: None,
            malformed_at: None,
            silent: false,
        }
    }
}

/// Waits for `sRN LMDscandata` then `sEN LMDscandata 1`, answers them as an
/// LMS1xx does, then streams scans every 20 ms.
async fn serve(mut stream: TcpStream, plan: Plan) -> std::io::Result<()> {
    let mut received = Vec::new();
    let mut buf = [0u8; 256];
    let poll = b"\x02sRN LMDscandata\x03";
    let subscription = b"\x02sEN LMDscandata 1\x03";
    loop {
        let n = stream.read(&mut buf).await?;
        if n == 0 {
            return Ok(());
        }
        received.extend_from_slice(&buf[..n]);
        if find(&received, subscription).is_some() {
            break;
        }
    }
    let poll_at = find(&received, poll).expect("client polls a scan first");
    assert!(poll_at < find(&received, subscription).unwrap_or(0), "sRN before sEN");

    stream
        .write_all(&published_scan_telegram("sRA", plan.first_counter))
        .await?;
    stream.write_all(b"\x02sEA LMDscandata 1\x03").await?;
    if plan.silent {
        // Keep the socket open and quiet until the client gives up on it.
        while stream.read(&mut buf).await? > 0 {}
        return Ok(());
    }
    let mut counter = plan.first_counter;
    let mut sent = 0;
    while plan.scans.is_none_or(|max| sent < max) {
        sleep(SCAN_PERIOD).await;
        counter += 1;
        sent += 1;
        if plan.malformed_at == Some(counter) {
            // Line noise first, then a telegram whose DIST1 announces more
            // data than it carries.
            stream.write_all(b"noise").await?;
            stream
                .write_all(b"\x02sSN LMDscandata 1 1 0 0 0 1 1 0 0 0 0 0 0 0 1388 168 0 1 DIST1 3F800000 00000000 FFF92230 1388 FFFF 1 2 3\x03")
                .await?;
            continue;
        }
        stream.write_all(&published_scan_telegram("sSN", counter)).await?;
    }
    Ok(())
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

/// A listener that can be re-bound to the same port right after closing.
fn listen(addr: SocketAddr) -> TcpListener {
    let socket = TcpSocket::new_v4().unwrap();
    socket.set_reuseaddr(true).unwrap();
    socket.bind(addr).unwrap();
    socket.listen(16).unwrap()
}

fn local_any() -> SocketAddr {
    "127.0.0.1:0".parse().unwrap()
}

fn config(addr: SocketAddr) -> ScannerClientConfig {
    ScannerClientConfig {
        address: addr.to_string(),
        connect_timeout: Duration::from_millis(500),
        stale_after: Duration::from_millis(300),
        backoff_initial: Duration::from_millis(50),
        backoff_max: Duration::from_millis(200),
        ..ScannerClientConfig::default()
    }
}

fn test_clock() -> impl Fn() -> Duration + Send + 'static {
    let start = Instant::now();
    move || start.elapsed()
}

async fn recv(rx: &mut mpsc::Receiver<Scan>) -> Scan {
    timeout(Duration::from_secs(3), rx.recv())
        .await
        .expect("a scan within 3 s")
        .expect("client running")
}

async fn wait_until(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(5);
    while !done() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        sleep(Duration::from_millis(10)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scans_arrive_with_published_angles_ranges_and_counters() {
    let listener = listen(local_any());
    let addr = listener.local_addr().unwrap();
    tokio::spawn(async move {
        let (stream, _) = listener.accept().await.unwrap();
        let _ = serve(stream, Plan::streaming(100)).await;
    });
    let (client, mut rx) = ScannerClient::spawn(config(addr), test_clock(), 8);

    let mut last_t = Duration::ZERO;
    for expected_counter in 100..106 {
        let scan = recv(&mut rx).await;
        // 100 is the sRA answer to the poll, the rest the sSN stream.
        assert_eq!(scan.scan_counter, expected_counter);
        assert_published_scan(&scan);
        assert!(scan.t >= last_t && scan.t > Duration::ZERO);
        last_t = scan.t;
    }
    let stats = client.stats().snapshot();
    assert_eq!(stats.connects, 1);
    assert_eq!(stats.malformed, 0);
    assert!(stats.scans >= 6);
    assert_eq!(client.stop().await, ScannerExit::Shutdown);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_telegram_is_counted_and_later_scans_still_arrive() {
    let listener = listen(local_any());
    let addr = listener.local_addr().unwrap();
    tokio::spawn(async move {
        let (stream, _) = listener.accept().await.unwrap();
        let plan = Plan {
            malformed_at: Some(203),
            ..Plan::streaming(200)
        };
        let _ = serve(stream, plan).await;
    });
    let (client, mut rx) = ScannerClient::spawn(config(addr), test_clock(), 8);

    let mut counters = Vec::new();
    while counters.last().is_none_or(|&c| c < 206) {
        let scan = recv(&mut rx).await;
        assert_published_scan(&scan);
        counters.push(scan.scan_counter);
    }
    assert_eq!(counters, vec![200, 201, 202, 204, 205, 206]);
    let stats = client.stats().snapshot();
    assert_eq!(stats.malformed, 1);
    assert_eq!(stats.skipped_bytes, 5, "the line noise");
    assert_eq!(stats.connects, 1, "a bad telegram is not a reason to reconnect");
    assert!(stats.last_error.unwrap_or_default().contains("number of data"));
    client.stop().await;
}

// Paused time: the scanner's 400 ms off and the client's backoff pass on
// tokio's clock, which jumps ahead whenever every task waits. The fake
// scanner is a task on the same thread, and loopback delivers its bytes
// within its write, so no jump can overtake bytes in flight.
#[tokio::test(start_paused = true)]
async fn client_reconnects_when_the_scanner_comes_back() {
    let listener = listen(local_any());
    let addr = listener.local_addr().unwrap();
    let (unreachable_tx, unreachable_rx) = tokio::sync::oneshot::channel();
    tokio::spawn(async move {
        let (stream, _) = listener.accept().await.unwrap();
        let _ = serve(
            stream,
            Plan {
                scans: Some(4),
                ..Plan::streaming(300)
            },
        )
        .await;
        // Connection and listener gone: the scanner is off for a while.
        drop(listener);
        let _ = unreachable_tx.send(());
        sleep(Duration::from_millis(400)).await;
        let listener = listen(addr);
        let (stream, _) = listener.accept().await.unwrap();
        let _ = serve(stream, Plan::streaming(900)).await;
    });
    let stats = Arc::new(ScannerStats::default());
    let (tx, mut rx) = mpsc::channel(8);
    let (stop_tx, stop_rx) = watch::channel(false);
    let task = tokio::spawn(run_scanner(config(addr), test_clock(), tx, Arc::clone(&stats), stop_rx));

    let mut counters = Vec::new();
    while counters.last().is_none_or(|&c| c < 902) {
        counters.push(recv(&mut rx).await.scan_counter);
    }
    assert_eq!(counters, vec![300, 301, 302, 303, 304, 900, 901, 902]);
    unreachable_rx.await.unwrap();
    let s = stats.snapshot();
    assert_eq!(s.connects, 2);
    assert_eq!(s.disconnects, 1);
    assert!(s.last_error.is_some());
    stop_tx.send(true).unwrap();
    assert_eq!(
        timeout(Duration::from_secs(1), task).await.unwrap().unwrap(),
        ScannerExit::Shutdown
    );
}

// Paused time (see above): stale_after is measured on tokio's clock.
#[tokio::test(start_paused = true)]
async fn silent_scanner_is_declared_stale_and_redialled() {
    let listener = listen(local_any());
    let addr = listener.local_addr().unwrap();
    tokio::spawn(async move {
        loop {
            let Ok((stream, _)) = listener.accept().await else {
                return;
            };
            tokio::spawn(serve(
                stream,
                Plan {
                    silent: true,
                    ..Plan::streaming(1)
                },
            ));
        }
    });
    let (client, mut rx) = ScannerClient::spawn(config(addr), test_clock(), 8);
    let stats = Arc::clone(client.stats());
    let started = tokio::time::Instant::now();
    wait_until("a second connection", || stats.connects.load(Ordering::Relaxed) >= 2).await;
    // stale_after (300 ms) counts from the last telegram, the sEA ack; then
    // one initial backoff (50 ms), seen within one 10 ms look.
    let redialled_after = started.elapsed();
    assert!(
        redialled_after >= Duration::from_millis(350) && redialled_after <= Duration::from_millis(370),
        "{redialled_after:?}"
    );
    assert!(stats.last_error().unwrap_or_default().contains("no telegram"));
    assert_eq!(
        recv(&mut rx).await.scan_counter,
        1,
        "the polled scan of the first session"
    );
    client.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn full_channel_drops_scans_without_stalling_the_link() {
    let listener = listen(local_any());
    let addr = listener.local_addr().unwrap();
    tokio::spawn(async move {
        let (stream, _) = listener.accept().await.unwrap();
        let _ = serve(stream, Plan::streaming(0)).await;
    });
    let (client, mut rx) = ScannerClient::spawn(config(addr), test_clock(), 1);
    let stats = Arc::clone(client.stats());
    // Not reading for a while: only one scan fits, the rest are dropped.
    wait_until("dropped scans", || stats.dropped_full.load(Ordering::Relaxed) >= 10).await;
    let held = recv(&mut rx).await;
    assert_eq!(held.scan_counter, 0);
    // The next one is fresh, not a backlog.
    let next = recv(&mut rx).await;
    assert!(next.scan_counter >= 10, "{}", next.scan_counter);
    assert_eq!(stats.connects.load(Ordering::Relaxed), 1);
    client.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dropping_the_receiver_stops_the_client_even_while_disconnected() {
    // Nothing listens here: the client is in its backoff loop.
    let (_held, addr) = refusing_address();
    let stats = Arc::new(ScannerStats::default());
    let (tx, rx) = mpsc::channel(1);
    let (_stop_tx, stop_rx) = watch::channel(false);
    let task = tokio::spawn(run_scanner(config(addr), test_clock(), tx, Arc::clone(&stats), stop_rx));
    wait_until("a failed connect", || stats.last_error().is_some()).await;
    drop(rx);
    assert_eq!(
        timeout(Duration::from_secs(1), task).await.unwrap().unwrap(),
        ScannerExit::ReceiverDropped
    );
    assert_eq!(stats.connects.load(Ordering::Relaxed), 0);
}
