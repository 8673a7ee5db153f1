//! The NTRIP client against fake casters on loopback: request and headers
//! as the casters see them, v1 and v2 (chunked) streams delivered byte
//! exact, GGA upstream, reconnects, refusals and shutdown.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, mpsc};
use std::thread;
use std::time::{Duration, Instant};

use drivers::ntrip::{NtripClient, NtripConfig, NtripVersion, REFUSED_RETRY, gga_sentence};
use drivers::rtcm::crc24q;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::runtime::Handle;

const IO_TIMEOUT: Duration = Duration::from_secs(2);
/// RFC 7617's example credentials and their published encoding.
const USER: &str = "Aladdin";
const PASSWORD: &str = "open sesame";
const EXPECTED_AUTH: &str = "Authorization: Basic QWxhZGRpbjpvcGVuIHNlc2FtZQ==";

/// The runtime the client's task runs on (the edge's, in furrow).
fn edge_runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .expect("runtime")
}

fn listen() -> (TcpListener, u16) {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    listener.set_nonblocking(true).expect("nonblocking");
    let port = listener.local_addr().expect("addr").port();
    (listener, port)
}

fn accept_within(listener: &TcpListener, limit: Duration) -> Option<TcpStream> {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        match listener.accept() {
            Ok((stream, _)) => {
                stream.set_nonblocking(false).expect("blocking");
                stream.set_read_timeout(Some(IO_TIMEOUT)).expect("timeout");
                return Some(stream);
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => thread::sleep(Duration::from_millis(5)),
            Err(e) => panic!("accept: {e}"),
        }
    }
    None
}

/// Reads up to and including `end`, byte by byte so nothing after it is
/// consumed.
fn read_until(stream: &mut TcpStream, end: &[u8]) -> String {
    let mut got = Vec::new();
    let mut byte = [0u8; 1];
    while !got.ends_with(end) {
        match stream.read(&mut byte) {
            Ok(1) => got.push(byte[0]),
            other => panic!(
                "caster read ended with {other:?} after {:?}",
                String::from_utf8_lossy(&got)
            ),
        }
    }
    String::from_utf8(got).expect("ASCII from the client")
}

fn config(port: u16, mountpoint: &str, version: NtripVersion) -> NtripConfig {
    NtripConfig {
        host: "127.0.0.1".to_string(),
        port,
        mountpoint: mountpoint.to_string(),
        user: Some(USER.to_string()),
        password: Some(PASSWORD.to_string()),
        version,
        gga_interval: Duration::from_secs(10),
        stale_after: Duration::from_secs(2),
        backoff_initial: Duration::from_millis(50),
        backoff_max: Duration::from_millis(200),
    }
}

/// An RTCM 3 frame whose payload holds the awkward bytes: CR, LF, NUL and
/// preamble look-alikes.
fn rtcm_frame(seed: u8, payload_len: usize) -> Vec<u8> {
    let payload: Vec<u8> = (0..payload_len)
        .map(|i| match i % 7 {
            0 => b'\r',
            1 => b'\n',
            2 => 0x00,
            3 => 0xD3,
            _ => seed.wrapping_mul(31).wrapping_add(i as u8),
        })
        .collect();
    let mut frame = vec![0xD3, (payload_len >> 8) as u8, payload_len as u8];
    frame.extend_from_slice(&payload);
    let crc = crc24q(&frame);
    frame.extend_from_slice(&[(crc >> 16) as u8, (crc >> 8) as u8, crc as u8]);
    frame
}

/// Drains corrections until `want` bytes have arrived or the deadline.
fn collect_corrections(client: &NtripClient, want: usize, limit: Duration) -> Vec<u8> {
    let deadline = Instant::now() + limit;
    let mut bytes = Vec::new();
    let mut chunks = Vec::new();
    while bytes.len() < want && Instant::now() < deadline {
        client.drain_corrections(&mut chunks);
        for chunk in chunks.drain(..) {
            bytes.extend_from_slice(&chunk);
        }
        thread::sleep(Duration::from_millis(5));
    }
    bytes
}

fn wait_for(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        if done() {
            return true;
        }
        thread::sleep(Duration::from_millis(5));
    }
    done()
}

/// How often the paused-time tests look at the client (on tokio's clock).
const LOOK: Duration = Duration::from_millis(5);

/// Looks every [`LOOK`] until `done`; a minute of paused time at most.
async fn wait_for_async(mut done: impl FnMut() -> bool) {
    let looking = async {
        while !done() {
            tokio::time::sleep(LOOK).await;
        }
    };
    tokio::time::timeout(Duration::from_secs(60), looking)
        .await
        .expect("condition within a minute of tokio time");
}

/// Reads a request head (up to the blank line) on an async socket.
async fn read_head_async(stream: &mut tokio::net::TcpStream) -> String {
    let mut got = Vec::new();
    while !got.ends_with(b"\r\n\r\n") {
        match stream.read_u8().await {
            Ok(byte) => got.push(byte),
            Err(e) => panic!("caster read: {e} after {:?}", String::from_utf8_lossy(&got)),
        }
    }
    String::from_utf8(got).expect("ASCII from the client")
}

fn parse_gga(line: &str) -> (f64, f64) {
    assert!(line.ends_with("\r\n"), "GGA line must end in CRLF: {line:?}");
    match nmea::parse_str(line.trim_end()) {
        Ok(nmea::ParseResult::GGA(gga)) => (gga.latitude.expect("latitude"), gga.longitude.expect("longitude")),
        other => panic!("not a GGA: {line:?} ({other:?})"),
    }
}

fn assert_near(got: (f64, f64), want: (f64, f64)) {
    assert!(
        (got.0 - want.0).abs() < 1e-6 && (got.1 - want.1).abs() < 1e-6,
        "GGA position {got:?}, expected {want:?}"
    );
}

fn gga_at(lat: f64, lon: f64) -> String {
    gga_sentence(lat, lon, 101.5, 4, 12, 0.8, Duration::from_secs(3600))
}

/// What the fake caster saw, for the test thread to check.
#[derive(Debug)]
enum Seen {
    Request(String),
    Gga(String),
}

#[test]
fn v1_stream_arrives_byte_exact_and_gga_goes_upstream() {
    let (listener, port) = listen();
    let frames: Vec<Vec<u8>> = (0..6).map(|k| rtcm_frame(k, 20 + 37 * usize::from(k))).collect();
    let stream_bytes = frames.concat();
    let (seen_tx, seen_rx) = mpsc::channel();
    let to_send = stream_bytes.clone();
    let caster = thread::spawn(move || {
        let mut s = accept_within(&listener, IO_TIMEOUT).expect("client connects");
        seen_tx.send(Seen::Request(read_until(&mut s, b"\r\n\r\n"))).unwrap();
        s.write_all(b"ICY 200 OK\r\n").unwrap();
        seen_tx.send(Seen::Gga(read_until(&mut s, b"\n"))).unwrap();
        // Writes that cut frames at odd places.
        for piece in to_send.chunks(29) {
            s.write_all(piece).unwrap();
            thread::sleep(Duration::from_millis(2));
        }
        // Keep the connection open until the client is dropped.
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
    });

    let runtime = edge_runtime();
    let client = NtripClient::spawn(
        config(port, "MOUNT1", NtripVersion::V1),
        Instant::now(),
        runtime.handle(),
    );
    client.set_gga(gga_at(48.117_3, 11.516_67));

    let Ok(Seen::Request(request)) = seen_rx.recv_timeout(IO_TIMEOUT) else {
        panic!("no request")
    };
    let mut lines = request.lines();
    assert_eq!(lines.next(), Some("GET /MOUNT1 HTTP/1.0"));
    let headers: Vec<&str> = lines.filter(|l| !l.is_empty()).collect();
    assert!(
        headers.iter().any(|h| h.starts_with("User-Agent: NTRIP ")),
        "{headers:?}"
    );
    assert!(headers.contains(&EXPECTED_AUTH), "{headers:?}");
    assert!(!request.contains("Ntrip-Version"), "v1 must not announce v2: {request}");

    let Ok(Seen::Gga(gga)) = seen_rx.recv_timeout(IO_TIMEOUT) else {
        panic!("no GGA")
    };
    assert_near(parse_gga(&gga), (48.117_3, 11.516_67));

    let received = collect_corrections(&client, stream_bytes.len(), IO_TIMEOUT);
    assert_eq!(received, stream_bytes);
    assert!(wait_for(Duration::from_millis(500), || client.status().messages == 6));
    let status = client.status();
    assert!(status.connected);
    assert_eq!(status.connects, 1);
    assert_eq!(status.errors, 0, "{status:?}");
    assert!(status.last_message.is_some());
    assert!(status.bytes_in >= stream_bytes.len() as u64 + 12);
    assert!(status.bytes_out as usize >= request.len() + gga.len());
    drop(client);
    caster.join().expect("caster");
}

/// Chunk-codes `data` with chunk sizes that ignore frame boundaries.
fn chunked(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    for (i, chunk) in data.chunks(53).enumerate() {
        // Vary the size-line form: extensions are legal and must be skipped.
        let ext = if i % 2 == 0 { ";x=y" } else { "" };
        out.extend_from_slice(format!("{:x}{ext}\r\n", chunk.len()).as_bytes());
        out.extend_from_slice(chunk);
        out.extend_from_slice(b"\r\n");
    }
    out
}

#[test]
fn v2_chunked_stream_arrives_byte_exact_and_gga_repeats() {
    let (listener, port) = listen();
    let frames: Vec<Vec<u8>> = (0..5).map(|k| rtcm_frame(k + 40, 60 + 50 * usize::from(k))).collect();
    let stream_bytes = frames.concat();
    let (seen_tx, seen_rx) = mpsc::channel();
    let encoded = chunked(&stream_bytes);
    let caster = thread::spawn(move || {
        let mut s = accept_within(&listener, IO_TIMEOUT).expect("client connects");
        seen_tx.send(Seen::Request(read_until(&mut s, b"\r\n\r\n"))).unwrap();
        s.write_all(b"HTTP/1.1 200 OK\r\nNtrip-Version: Ntrip/2.0\r\nTransfer-Encoding: chunked\r\n\r\n")
            .unwrap();
        // Pieces that split size lines, data and CRLFs.
        for piece in encoded.chunks(17) {
            s.write_all(piece).unwrap();
            thread::sleep(Duration::from_millis(1));
        }
        // The GGA comes raw on the upstream side, repeatedly.
        for _ in 0..3 {
            seen_tx.send(Seen::Gga(read_until(&mut s, b"\n"))).unwrap();
        }
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
    });

    let mut cfg = config(port, "/MOUNT2", NtripVersion::V2);
    // Short: the interval itself is checked on paused time; here only the repeat.
    cfg.gga_interval = Duration::from_millis(20);
    let runtime = edge_runtime();
    let client = NtripClient::spawn(cfg, Instant::now(), runtime.handle());
    client.set_gga(gga_at(-33.856_78, 151.215_3));

    let Ok(Seen::Request(request)) = seen_rx.recv_timeout(IO_TIMEOUT) else {
        panic!("no request")
    };
    let mut lines = request.lines();
    assert_eq!(lines.next(), Some("GET /MOUNT2 HTTP/1.1"));
    let headers: Vec<&str> = lines.filter(|l| !l.is_empty()).collect();
    let host = format!("Host: 127.0.0.1:{port}");
    for expected in [
        host.as_str(),
        "Ntrip-Version: Ntrip/2.0",
        "User-Agent: NTRIP Furrow/0.1",
        EXPECTED_AUTH,
    ] {
        assert!(headers.contains(&expected), "{expected:?} missing: {headers:?}");
    }

    let received = collect_corrections(&client, stream_bytes.len(), IO_TIMEOUT);
    assert_eq!(received, stream_bytes, "chunk framing must not leak into the data");

    // Repeated (the interval itself is checked on paused time below).
    for _ in 0..3 {
        let Ok(Seen::Gga(gga)) = seen_rx.recv_timeout(IO_TIMEOUT) else {
            panic!("GGA not repeated")
        };
        assert_near(parse_gga(&gga), (-33.856_78, 151.215_3));
    }
    assert!(wait_for(Duration::from_millis(500), || client.status().messages == 5));
    drop(client);
    caster.join().expect("caster");
}

#[test]
fn dropped_connection_is_reopened_and_gga_resent() {
    let (listener, port) = listen();
    let first = rtcm_frame(1, 90);
    let second = rtcm_frame(2, 140);
    let (seen_tx, seen_rx) = mpsc::channel();
    let (first_out, second_out) = (first.clone(), second.clone());
    let (moved_tx, moved_rx) = mpsc::channel::<()>();
    let caster = thread::spawn(move || {
        let mut s = accept_within(&listener, IO_TIMEOUT).expect("first connection");
        read_until(&mut s, b"\r\n\r\n");
        s.write_all(b"ICY 200 OK\r\n").unwrap();
        seen_tx.send(Seen::Gga(read_until(&mut s, b"\n"))).unwrap();
        s.write_all(&first_out).unwrap();
        // Wait until the test has moved the vehicle, then hang up.
        moved_rx.recv_timeout(IO_TIMEOUT).expect("test moved on");
        drop(s);

        let mut s = accept_within(&listener, IO_TIMEOUT).expect("client reconnects");
        seen_tx.send(Seen::Request(read_until(&mut s, b"\r\n\r\n"))).unwrap();
        s.write_all(b"ICY 200 OK\r\n").unwrap();
        seen_tx.send(Seen::Gga(read_until(&mut s, b"\n"))).unwrap();
        s.write_all(&second_out).unwrap();
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
    });

    let runtime = edge_runtime();
    let client = NtripClient::spawn(config(port, "M", NtripVersion::V1), Instant::now(), runtime.handle());
    client.set_gga(gga_at(10.0, 20.0));
    let Ok(Seen::Gga(gga)) = seen_rx.recv_timeout(IO_TIMEOUT) else {
        panic!("no GGA")
    };
    assert_near(parse_gga(&gga), (10.0, 20.0));
    assert_eq!(collect_corrections(&client, first.len(), IO_TIMEOUT), first);

    // The vehicle moved; the new connection must report the new position.
    client.set_gga(gga_at(10.5, 20.5));
    moved_tx.send(()).unwrap();
    let Ok(Seen::Request(request)) = seen_rx.recv_timeout(IO_TIMEOUT) else {
        panic!("no second request")
    };
    assert!(request.starts_with("GET /M HTTP/1.0\r\n"), "{request}");
    let Ok(Seen::Gga(gga)) = seen_rx.recv_timeout(IO_TIMEOUT) else {
        panic!("no GGA after reconnect")
    };
    assert_near(parse_gga(&gga), (10.5, 20.5));
    assert_eq!(collect_corrections(&client, second.len(), IO_TIMEOUT), second);

    let status = client.status();
    assert_eq!(status.connects, 2, "{status:?}");
    assert!(status.connected);
    assert!(
        status.last_error.as_deref().is_some_and(|e| e.contains("closed")),
        "{status:?}"
    );
    drop(client);
    caster.join().expect("caster");
}

// Paused time: REFUSED_RETRY (10 s) passes on tokio's clock, which jumps
// ahead whenever every task waits. The fake caster is a task on the same
// thread, and loopback delivers its bytes within its write, so no jump can
// overtake bytes in flight.
#[tokio::test(start_paused = true)]
async fn unauthorized_is_reported_and_retried_only_after_refused_retry() {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let port = listener.local_addr().expect("addr").port();
    let accepts = Arc::new(AtomicU32::new(0));
    let caster_accepts = Arc::clone(&accepts);
    tokio::spawn(async move {
        loop {
            let (mut s, _) = listener.accept().await.expect("accept");
            read_head_async(&mut s).await;
            s.write_all(b"HTTP/1.1 401 Unauthorized\r\nWWW-Authenticate: Basic realm=\"/M\"\r\n\r\n")
                .await
                .unwrap();
            caster_accepts.fetch_add(1, Ordering::Relaxed);
        }
    });

    let client = NtripClient::spawn(config(port, "M", NtripVersion::V2), Instant::now(), &Handle::current());
    let unauthorized = || {
        client
            .status()
            .last_error
            .is_some_and(|e| e.starts_with("NTRIP: unauthorized"))
    };
    wait_for_async(unauthorized).await;
    let refused_at = tokio::time::Instant::now();
    let status = client.status();
    assert!(!status.connected);
    assert_eq!(status.connects, 0);
    // Backoff here is 50–200 ms; a refusal waits REFUSED_RETRY instead
    // (the refusal was seen within one look, LOOK, after it happened).
    tokio::time::sleep_until(refused_at + REFUSED_RETRY - LOOK).await;
    assert_eq!(accepts.load(Ordering::Relaxed), 1, "retried a refused login early");
    wait_for_async(|| accepts.load(Ordering::Relaxed) == 2).await;
    assert!(refused_at.elapsed() <= REFUSED_RETRY, "{:?}", refused_at.elapsed());
}

#[test]
fn wrong_mountpoint_source_table_is_reported() {
    let (listener, port) = listen();
    let caster = thread::spawn(move || {
        let mut s = accept_within(&listener, IO_TIMEOUT).expect("client connects");
        read_until(&mut s, b"\r\n\r\n");
        s.write_all(b"SOURCETABLE 200 OK\r\nContent-Type: text/plain\r\n\r\nSTR;OTHER;x\r\nENDSOURCETABLE\r\n")
            .unwrap();
    });
    let runtime = edge_runtime();
    let client = NtripClient::spawn(config(port, "NOPE", NtripVersion::V1), Instant::now(), runtime.handle());
    assert!(
        wait_for(IO_TIMEOUT, || client
            .status()
            .last_error
            .is_some_and(|e| e.contains("mountpoint 'NOPE' not found"))),
        "{:?}",
        client.status()
    );
    let mut chunks = Vec::new();
    client.drain_corrections(&mut chunks);
    assert!(chunks.is_empty(), "source table must not reach the GNSS receiver");
    caster.join().expect("caster");
}

// Paused time (see above): the GGA interval on tokio's clock.
#[tokio::test(start_paused = true)]
async fn gga_is_sent_at_once_then_every_gga_interval() {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let port = listener.local_addr().expect("addr").port();
    let (gga_tx, mut gga_rx) = tokio::sync::mpsc::unbounded_channel();
    tokio::spawn(async move {
        let (mut s, _) = listener.accept().await.expect("accept");
        read_head_async(&mut s).await;
        s.write_all(b"ICY 200 OK\r\n").await.unwrap();
        let mut line = Vec::new();
        while let Ok(byte) = s.read_u8().await {
            line.push(byte);
            if byte == b'\n' {
                let _ = gga_tx.send((tokio::time::Instant::now(), String::from_utf8_lossy(&line).into_owned()));
                line.clear();
            }
        }
    });
    let mut cfg = config(port, "M", NtripVersion::V1);
    cfg.gga_interval = Duration::from_millis(150);
    let client = NtripClient::spawn(cfg, Instant::now(), &Handle::current());
    client.set_gga(gga_at(47.5, 8.25));
    let mut sent_at = Vec::new();
    for _ in 0..4 {
        let (at, line) = gga_rx.recv().await.expect("a GGA");
        assert_near(parse_gga(&line), (47.5, 8.25));
        sent_at.push(at);
    }
    let gaps: Vec<Duration> = sent_at.windows(2).map(|w| w[1] - w[0]).collect();
    // Timers fire on whole milliseconds of the paused clock.
    let on_interval = |gap: &Duration| (Duration::from_millis(150)..=Duration::from_millis(151)).contains(gap);
    assert!(gaps.iter().all(on_interval), "{gaps:?}");
    assert_eq!(client.status().connects, 1);
}

// Paused time (see above): stale_after and the backoff pass on tokio's clock.
#[tokio::test(start_paused = true)]
async fn silent_caster_is_left_after_stale_after() {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
    let port = listener.local_addr().expect("addr").port();
    let (accepted_tx, mut accepted_rx) = tokio::sync::mpsc::unbounded_channel();
    tokio::spawn(async move {
        let mut held = Vec::new();
        loop {
            let (mut s, _) = listener.accept().await.expect("accept");
            read_head_async(&mut s).await;
            s.write_all(b"ICY 200 OK\r\n").await.unwrap();
            let _ = accepted_tx.send(tokio::time::Instant::now());
            // Say nothing more, but keep the socket open: closing it would
            // replace the error under test.
            held.push(s);
        }
    });
    let mut cfg = config(port, "M", NtripVersion::V1);
    cfg.stale_after = Duration::from_millis(300);
    let client = NtripClient::spawn(cfg, Instant::now(), &Handle::current());
    let first = accepted_rx.recv().await.expect("first connection");
    let second = accepted_rx.recv().await.expect("reconnect after silence");
    // stale_after from the response head, then the initial backoff (50 ms),
    // both on the paused clock (timers round up to whole milliseconds).
    let gap = second - first;
    assert!(
        gap >= Duration::from_millis(350) && gap <= Duration::from_millis(355),
        "{gap:?}"
    );
    let error = client.status().last_error.unwrap_or_default();
    assert!(error.contains("no data"), "{error}");
}

#[test]
fn drop_closes_the_connection_promptly() {
    let (listener, port) = listen();
    let (closed_tx, closed_rx) = mpsc::channel();
    let (ready_tx, ready_rx) = mpsc::channel();
    let caster = thread::spawn(move || {
        let mut s = accept_within(&listener, IO_TIMEOUT).expect("client connects");
        read_until(&mut s, b"\r\n\r\n");
        s.write_all(b"ICY 200 OK\r\n").unwrap();
        ready_tx.send(()).unwrap();
        let mut rest = Vec::new();
        // EOF (Ok) when the client closes; a timeout would be Err.
        closed_tx
            .send(s.read_to_end(&mut rest).map(|_| Instant::now()).ok())
            .unwrap();
    });
    let mut cfg = config(port, "M", NtripVersion::V1);
    cfg.gga_interval = Duration::ZERO;
    let runtime = edge_runtime();
    let client = NtripClient::spawn(cfg, Instant::now(), runtime.handle());
    ready_rx.recv_timeout(IO_TIMEOUT).expect("stream started");
    assert!(wait_for(IO_TIMEOUT, || client.status().connected));
    let dropped_at = Instant::now();
    drop(client);
    let drop_took = dropped_at.elapsed();
    assert!(drop_took < Duration::from_millis(500), "{drop_took:?}");
    let closed_at = closed_rx
        .recv_timeout(IO_TIMEOUT)
        .expect("caster finished")
        .expect("caster saw EOF, not a timeout");
    assert!(closed_at - dropped_at < Duration::from_millis(500));
    caster.join().expect("caster");
}
