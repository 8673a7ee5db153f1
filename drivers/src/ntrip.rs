//! NTRIP client: fetches RTK corrections from a caster over TCP and hands
//! the bytes to the core, which forwards them to the GNSS receiver.
//!
//! The protocol pieces (request, response head, chunked transfer coding,
//! GGA sentence) are pure functions and small state machines; [`NtripClient`]
//! is the thin I/O shell around them: a task on the tokio runtime the caller
//! gives (the edge's), with a handle a core that polls once per tick can own
//! without being async itself.
//!
//! Protocol notes (NTRIP 1.0 and 2.0, RTCM 10410.1 / 10410.0, as casters
//! such as BKG's and SNIP behave):
//! - v1 asks `GET /MOUNT HTTP/1.0` and the caster answers `ICY 200 OK`,
//!   sometimes followed by header lines and a blank line, then raw data.
//! - v2 asks `GET /MOUNT HTTP/1.1` with `Ntrip-Version: Ntrip/2.0` and gets
//!   `HTTP/1.1 200 OK` with a head ending in a blank line; the body is
//!   usually `Transfer-Encoding: chunked`, sometimes plain.
//! - A wrong mountpoint gets the source table instead (`SOURCETABLE 200 OK`
//!   in v1, `Content-Type: gnss/sourcetable` or 404 in v2); bad credentials
//!   get `401`.
//! - VRS casters need the rover position as an NMEA GGA line before they
//!   stream, and periodically after. It goes upstream raw, CRLF-terminated,
//!   in both versions (never chunk-coded).

use std::collections::VecDeque;
use std::fmt::Write as _;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::runtime::Handle;
use tokio::sync::watch;
use tokio::time::{sleep, sleep_until, timeout};

use crate::backoff::Backoff;
use crate::device::{DeviceStatus, SharedStatus, shared_status, snapshot, update};
use crate::rtcm::Rtcm3FrameCounter;

/// What the client calls itself; casters log it, some filter on `NTRIP`.
pub const USER_AGENT: &str = "NTRIP Furrow/0.1";
/// Longest response head accepted before the stream starts.
pub const MAX_RESPONSE_HEAD_LEN: usize = 8 * 1024;
/// Corrections kept for the core between polls. At the usual 0.5–1.5 kB/s
/// this is most of a minute; beyond it the oldest bytes go, since a GNSS
/// receiver has no use for stale corrections.
pub const CORRECTION_QUEUE_BYTES: usize = 64 * 1024;
/// Wait before retrying after the caster refused the credentials or the
/// mountpoint: retrying fast cannot fix configuration and some casters ban
/// clients that hammer them.
pub const REFUSED_RETRY: Duration = Duration::from_secs(10);

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NtripVersion {
    V1,
    #[default]
    V2,
}

/// Where the caster is and how to talk to it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NtripConfig {
    pub host: String,
    /// NTRIP casters listen on 2101 by convention.
    pub port: u16,
    /// Stream name, with or without the leading `/`.
    pub mountpoint: String,
    pub user: Option<String>,
    pub password: Option<String>,
    pub version: NtripVersion,
    /// How often to send the latest GGA upstream; zero = never.
    pub gga_interval: Duration,
    /// No bytes from the caster for this long: reconnect. Also bounds the
    /// connect and the wait for the response head.
    pub stale_after: Duration,
    /// First wait after a failure; doubles up to `backoff_max`, and returns
    /// to this once a connection has delivered data.
    pub backoff_initial: Duration,
    pub backoff_max: Duration,
}

impl Default for NtripConfig {
    fn default() -> Self {
        Self {
            host: String::new(),
            port: 2101,
            mountpoint: String::new(),
            user: None,
            password: None,
            version: NtripVersion::V2,
            gga_interval: Duration::from_secs(10),
            stale_after: Duration::from_secs(10),
            backoff_initial: Duration::from_millis(500),
            backoff_max: Duration::from_secs(30),
        }
    }
}

/// Why a connection to the caster did not (or no longer) deliver data.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum NtripError {
    /// The configuration cannot form a valid request.
    Config(String),
    /// 401: the caster refused the user/password.
    Unauthorized,
    /// The caster sent its source table: the mountpoint does not exist.
    NoSuchMountpoint(String),
    /// Any other refusal (status line as sent).
    Refused(String),
    /// The caster broke the protocol.
    Protocol(String),
    /// Connect, read or write failed, or the caster went quiet or away.
    Link(String),
}

impl std::fmt::Display for NtripError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Config(why) => write!(f, "NTRIP: bad configuration: {why}"),
            Self::Unauthorized => write!(f, "NTRIP: unauthorized (check user and password)"),
            Self::NoSuchMountpoint(mount) => {
                write!(
                    f,
                    "NTRIP: mountpoint '{mount}' not found (caster sent its source table)"
                )
            }
            Self::Refused(status) => write!(f, "NTRIP: caster refused: {status}"),
            Self::Protocol(why) => write!(f, "NTRIP: protocol error: {why}"),
            Self::Link(why) => write!(f, "NTRIP: {why}"),
        }
    }
}

impl std::error::Error for NtripError {}

impl NtripError {
    /// Whether retrying soon could help.
    fn is_refusal(&self) -> bool {
        matches!(
            self,
            Self::Config(_) | Self::Unauthorized | Self::NoSuchMountpoint(_) | Self::Refused(_)
        )
    }
}

/// The mountpoint without its leading slash.
fn mount_name(config: &NtripConfig) -> &str {
    config.mountpoint.trim_start_matches('/')
}

/// The request that opens the stream. Fails on values that would break the
/// request line or headers (spaces, control characters).
pub fn ntrip_request(config: &NtripConfig) -> Result<Vec<u8>, NtripError> {
    let mount = mount_name(config);
    let visible = |s: &str| s.bytes().all(|b| b.is_ascii_graphic());
    if !visible(mount) && !mount.is_empty() {
        return Err(NtripError::Config(format!("mountpoint {mount:?}")));
    }
    if config.host.is_empty() || !visible(&config.host) {
        return Err(NtripError::Config(format!("host {:?}", config.host)));
    }
    let mut request = String::new();
    // Writing to a String cannot fail.
    let _ = match config.version {
        NtripVersion::V1 => write!(request, "GET /{mount} HTTP/1.0\r\nUser-Agent: {USER_AGENT}\r\n"),
        NtripVersion::V2 => {
            let host = if config.host.contains(':') {
                format!("[{}]", config.host)
            } else {
                config.host.clone()
            };
            write!(
                request,
                "GET /{mount} HTTP/1.1\r\nHost: {host}:{port}\r\nNtrip-Version: Ntrip/2.0\r\n\
                 User-Agent: {USER_AGENT}\r\nConnection: close\r\n",
                port = config.port
            )
        }
    };
    if config.user.is_some() || config.password.is_some() {
        let credentials = format!(
            "{}:{}",
            config.user.as_deref().unwrap_or_default(),
            config.password.as_deref().unwrap_or_default()
        );
        let _ = write!(request, "Authorization: Basic {}\r\n", base64(credentials.as_bytes()));
    }
    request.push_str("\r\n");
    Ok(request.into_bytes())
}

/// Standard base64 with padding (RFC 4648 §4), for Basic authentication.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for group in bytes.chunks(3) {
        let b = [group[0], *group.get(1).unwrap_or(&0), *group.get(2).unwrap_or(&0)];
        let n = u32::from(b[0]) << 16 | u32::from(b[1]) << 8 | u32::from(b[2]);
        for i in 0..4 {
            if i <= group.len() {
                out.push(char::from(ALPHABET[(n >> (18 - 6 * i)) as usize & 0x3F]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A caster's answer, once its head is understood.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamStart {
    /// Data follows the head; `chunked` = HTTP chunked transfer coding.
    Stream { chunked: bool },
}

/// Reads the response head at the start of `buf`. `Ok(None)`: need more
/// bytes. `Ok(Some((start, len)))`: the stream starts after `len` bytes.
///
/// `ICY 200 OK` has no required end of head: header lines (printable, with
/// a colon) and a blank line that are already in `buf` are taken as part of
/// it, anything else as data. RTCM 3 data starts with 0xD3, so it is never
/// mistaken for a header; a head split across reads may leak its tail into
/// the data, which GNSS receivers skip while looking for a preamble.
pub fn parse_response_head(buf: &[u8], mountpoint: &str) -> Result<Option<(StreamStart, usize)>, NtripError> {
    let Some(status_end) = find(buf, b"\n") else {
        return if buf.len() > MAX_RESPONSE_HEAD_LEN {
            Err(NtripError::Protocol("no status line".to_string()))
        } else {
            Ok(None)
        };
    };
    let status = String::from_utf8_lossy(trim_cr(&buf[..status_end])).trim().to_string();
    let mut words = status.split_ascii_whitespace();
    let first = words.next().unwrap_or_default();
    let code = words.next().unwrap_or_default();
    if first == "ICY" && code == "200" {
        return Ok(Some((
            StreamStart::Stream { chunked: false },
            icy_head_len(buf, status_end + 1),
        )));
    }
    if first == "SOURCETABLE" {
        return Err(NtripError::NoSuchMountpoint(mountpoint.to_string()));
    }
    if !first.starts_with("HTTP/1.") {
        let shown: String = status.chars().take(60).collect();
        return Err(NtripError::Protocol(format!("unexpected response {shown:?}")));
    }
    match code {
        "200" => {}
        "401" => return Err(NtripError::Unauthorized),
        "404" => return Err(NtripError::NoSuchMountpoint(mountpoint.to_string())),
        _ => return Err(NtripError::Refused(status)),
    }
    let Some(head_len) = http_head_len(buf) else {
        return if buf.len() > MAX_RESPONSE_HEAD_LEN {
            Err(NtripError::Protocol("response head too long".to_string()))
        } else {
            Ok(None)
        };
    };
    let mut chunked = false;
    for line in buf[status_end + 1..head_len].split(|&b| b == b'\n') {
        let line = String::from_utf8_lossy(trim_cr(line)).to_ascii_lowercase();
        let Some((name, value)) = line.split_once(':') else {
            continue;
        };
        match name.trim() {
            "transfer-encoding" => chunked = value.split(',').any(|coding| coding.trim() == "chunked"),
            "content-type" if value.trim().starts_with("gnss/sourcetable") => {
                return Err(NtripError::NoSuchMountpoint(mountpoint.to_string()));
            }
            _ => {}
        }
    }
    Ok(Some((StreamStart::Stream { chunked }, head_len)))
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn trim_cr(line: &[u8]) -> &[u8] {
    line.strip_suffix(b"\r").unwrap_or(line)
}

/// End of an HTTP head: after the first empty line (CRLF or bare LF).
fn http_head_len(buf: &[u8]) -> Option<usize> {
    let mut line_start = 0;
    for (i, &b) in buf.iter().enumerate() {
        if b == b'\n' {
            if trim_cr(&buf[line_start..i]).is_empty() {
                return Some(i + 1);
            }
            line_start = i + 1;
        }
    }
    None
}

/// Length of an `ICY 200 OK` head whose status line ends at `pos`.
fn icy_head_len(buf: &[u8], mut pos: usize) -> usize {
    loop {
        let rest = &buf[pos..];
        if rest.starts_with(b"\r\n") {
            return pos + 2;
        }
        let Some(end) = find(rest, b"\r\n") else {
            return pos;
        };
        let line = &rest[..end];
        let header_like = line.contains(&b':') && line.iter().all(|b| b.is_ascii_graphic() || *b == b' ');
        if !header_like {
            return pos;
        }
        pos += end + 2;
    }
}

/// Decoder for HTTP/1.1 chunked transfer coding (RFC 9112 §7.1), fed the
/// body in whatever pieces the socket delivers.
#[derive(Clone, Debug, Default)]
pub struct ChunkedDecoder {
    state: ChunkState,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ChunkState {
    Size {
        value: u64,
        digits: u8,
        extension: bool,
    },
    SizeLf {
        value: u64,
    },
    Data {
        remaining: u64,
    },
    DataCr,
    DataLf,
    /// Trailer section after the last chunk; `line_len` of the current line.
    Trailer {
        line_len: usize,
    },
    Done,
}

impl Default for ChunkState {
    fn default() -> Self {
        Self::Size {
            value: 0,
            digits: 0,
            extension: false,
        }
    }
}

impl ChunkedDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends the data carried by `input` to `out`. `Ok(true)` once the
    /// last chunk and trailer have been read (the caster ended the stream);
    /// bytes after that are ignored.
    pub fn decode(&mut self, input: &[u8], out: &mut Vec<u8>) -> Result<bool, NtripError> {
        let bad = |what: &str, b: u8| Err(NtripError::Protocol(format!("chunked coding: {what} (byte 0x{b:02X})")));
        let mut i = 0;
        while i < input.len() {
            let b = input[i];
            self.state = match self.state {
                ChunkState::Size {
                    value,
                    digits,
                    extension,
                } => match b {
                    b'\r' if digits > 0 => ChunkState::SizeLf { value },
                    b'\n' if digits > 0 => Self::after_size(value),
                    _ if extension => self.state,
                    b';' if digits > 0 => ChunkState::Size {
                        value,
                        digits,
                        extension: true,
                    },
                    b' ' | b'\t' if digits > 0 => self.state,
                    _ => match char::from(b).to_digit(16) {
                        // 15 hex digits bound a chunk to 2^60 bytes: no overflow.
                        Some(d) if digits < 15 => ChunkState::Size {
                            value: value << 4 | u64::from(d),
                            digits: digits + 1,
                            extension: false,
                        },
                        _ => return bad("bad chunk size", b),
                    },
                },
                ChunkState::SizeLf { value } => match b {
                    b'\n' => Self::after_size(value),
                    _ => return bad("expected LF after chunk size", b),
                },
                ChunkState::Data { remaining } => {
                    let available = input.len() - i;
                    let take = usize::try_from(remaining).map_or(available, |r| r.min(available));
                    out.extend_from_slice(&input[i..i + take]);
                    i += take;
                    let remaining = remaining - take as u64;
                    self.state = if remaining == 0 {
                        ChunkState::DataCr
                    } else {
                        ChunkState::Data { remaining }
                    };
                    continue;
                }
                ChunkState::DataCr => match b {
                    b'\r' => ChunkState::DataLf,
                    b'\n' => ChunkState::default(),
                    _ => return bad("expected CRLF after chunk data", b),
                },
                ChunkState::DataLf => match b {
                    b'\n' => ChunkState::default(),
                    _ => return bad("expected LF after chunk data", b),
                },
                ChunkState::Trailer { line_len } => match b {
                    b'\r' => self.state,
                    b'\n' if line_len == 0 => ChunkState::Done,
                    b'\n' => ChunkState::Trailer { line_len: 0 },
                    _ => ChunkState::Trailer { line_len: line_len + 1 },
                },
                ChunkState::Done => return Ok(true),
            };
            i += 1;
        }
        Ok(self.state == ChunkState::Done)
    }

    fn after_size(value: u64) -> ChunkState {
        if value == 0 {
            ChunkState::Trailer { line_len: 0 }
        } else {
            ChunkState::Data { remaining: value }
        }
    }
}

/// An NMEA GGA sentence (without line ending) for the caster: `$GPGGA`,
/// UTC time of day, position, `fix_quality_digit` (0 none, 1 single, 2 DGPS,
/// 4 RTK fixed, 5 RTK float), satellites, HDOP and altitude above mean sea
/// level; geoid separation left empty. Non-finite or out-of-range values
/// give empty fields rather than a wrong position.
pub fn gga_sentence(
    lat_deg: f64,
    lon_deg: f64,
    alt_m: f64,
    fix_quality_digit: u8,
    satellites: u8,
    hdop: f64,
    utc: Duration,
) -> String {
    let centis = (utc.as_millis() / 10) % (24 * 3600 * 100);
    let (h, m, s, cs) = (centis / 360_000, centis / 6000 % 60, centis / 100 % 60, centis % 100);
    let (lat, ns) = nmea_angle(lat_deg, 90.0, 2, ('N', 'S'));
    let (lon, ew) = nmea_angle(lon_deg, 180.0, 3, ('E', 'W'));
    let hdop = if hdop.is_finite() && hdop >= 0.0 {
        format!("{:.1}", hdop.min(99.9))
    } else {
        String::new()
    };
    let alt = if alt_m.is_finite() {
        format!("{alt_m:.1}")
    } else {
        String::new()
    };
    let body = format!(
        "GPGGA,{h:02}{m:02}{s:02}.{cs:02},{lat},{ns},{lon},{ew},{q},{sats:02},{hdop},{alt},M,,M,,",
        q = fix_quality_digit.min(9),
        sats = satellites.min(99),
    );
    let checksum = body.bytes().fold(0u8, |acc, b| acc ^ b);
    format!("${body}*{checksum:02X}")
}

/// `ddmm.mmmmm` (or `dddmm.mmmmm`) and hemisphere; 1e-5 minute ≈ 2 cm.
fn nmea_angle(deg: f64, limit: f64, deg_digits: usize, (pos, neg): (char, char)) -> (String, String) {
    if !deg.is_finite() || deg.abs() > limit {
        return (String::new(), String::new());
    }
    // Integer units so rounding carries into whole minutes and degrees.
    let units = (deg.abs() * 60.0 * 1e5).round() as u64;
    let (whole_deg, rem) = (units / 6_000_000, units % 6_000_000);
    let text = format!("{whole_deg:0deg_digits$}{:02}.{:05}", rem / 100_000, rem % 100_000);
    (text, if deg < 0.0 { neg } else { pos }.to_string())
}

/// The GGA as sent: trimmed, one CRLF. `None` for an empty sentence.
fn gga_line(sentence: &str) -> Option<Vec<u8>> {
    let trimmed = sentence.trim();
    (!trimmed.is_empty()).then(|| format!("{trimmed}\r\n").into_bytes())
}

/// Corrections waiting for the core, bounded in bytes (oldest dropped).
#[derive(Debug, Default)]
struct CorrectionQueue {
    chunks: VecDeque<Vec<u8>>,
    bytes: usize,
}

impl CorrectionQueue {
    /// Returns how many bytes were dropped to make room.
    fn push(&mut self, chunk: Vec<u8>) -> usize {
        let mut dropped = 0;
        self.bytes += chunk.len();
        self.chunks.push_back(chunk);
        while self.bytes > CORRECTION_QUEUE_BYTES {
            let Some(old) = self.chunks.pop_front() else { break };
            self.bytes -= old.len();
            dropped += old.len();
        }
        dropped
    }
}

/// State the I/O thread shares with the [`NtripClient`] handle.
#[derive(Clone)]
struct Shared {
    status: SharedStatus,
    corrections: Arc<Mutex<CorrectionQueue>>,
    origin: Instant,
}

impl Shared {
    fn error(&self, error: &NtripError) {
        tracing::warn!(%error, "ntrip");
        update(&self.status, |s| {
            s.errors += 1;
            s.last_error = Some(error.to_string());
        });
    }

    fn deliver(&self, chunk: Vec<u8>) {
        let dropped = self.corrections.lock().unwrap_or_else(|p| p.into_inner()).push(chunk);
        if dropped > 0 {
            self.error(&NtripError::Link(format!(
                "correction queue full, dropped {dropped} bytes (consumer too slow)"
            )));
        }
    }
}

/// A running NTRIP client. Dropping it closes the connection and ends its
/// task.
pub struct NtripClient {
    shared: Shared,
    gga: watch::Sender<Option<String>>,
    shutdown: watch::Sender<bool>,
}

impl NtripClient {
    /// Starts connecting at once, as a task on `runtime`; `origin` is the
    /// clock the status uses.
    pub fn spawn(config: NtripConfig, origin: Instant, runtime: &Handle) -> Self {
        let shared = Shared {
            status: shared_status(),
            corrections: Arc::new(Mutex::new(CorrectionQueue::default())),
            origin,
        };
        let (gga, gga_rx) = watch::channel(None);
        let (shutdown, shutdown_rx) = watch::channel(false);
        let task_shared = shared.clone();
        runtime.spawn(async move { run(config, &task_shared, gga_rx, shutdown_rx).await });
        Self { shared, gga, shutdown }
    }

    /// The position to report upstream (an NMEA GGA, e.g. from
    /// [`gga_sentence`]); sent now if none was sent on this connection yet,
    /// else at the next `gga_interval`.
    pub fn set_gga(&self, sentence: String) {
        self.gga.send_replace(Some(sentence));
    }

    /// Moves the correction bytes received since the last call, in order.
    pub fn drain_corrections(&self, out: &mut Vec<Vec<u8>>) {
        let mut queue = self.shared.corrections.lock().unwrap_or_else(|p| p.into_inner());
        queue.bytes = 0;
        out.extend(queue.chunks.drain(..));
    }

    /// `connected` means a stream is being received; `messages` counts
    /// RTCM 3 frames with good CRCs, `errors` bad frames and failures.
    pub fn status(&self) -> DeviceStatus {
        snapshot(&self.shared.status)
    }

    pub fn shared_status(&self) -> SharedStatus {
        Arc::clone(&self.shared.status)
    }
}

impl Drop for NtripClient {
    fn drop(&mut self) {
        // The task leaves at its next await on shutdown (a DNS lookup in
        // progress finishes on the runtime's blocking pool, unawaited).
        self.shutdown.send_replace(true);
    }
}

/// How one connection ended.
struct SessionEnd {
    error: NtripError,
    /// Correction data arrived: the next retry starts from `backoff_initial`.
    delivered: bool,
}

async fn run(
    config: NtripConfig,
    shared: &Shared,
    mut gga: watch::Receiver<Option<String>>,
    mut shutdown: watch::Receiver<bool>,
) {
    let mut backoff = Backoff::new(config.backoff_initial, config.backoff_max);
    loop {
        let end = tokio::select! {
            _ = shutdown.wait_for(|stop| *stop) => return,
            end = session(&config, shared, &mut gga) => end,
        };
        update(&shared.status, |s| s.connected = false);
        shared.error(&end.error);
        if end.delivered {
            backoff.reset();
        }
        let delay = backoff.next_delay();
        let wait = if end.error.is_refusal() {
            REFUSED_RETRY.max(config.backoff_max)
        } else {
            delay
        };
        tokio::select! {
            _ = shutdown.wait_for(|stop| *stop) => return,
            () = sleep(wait) => {}
        }
    }
}

/// `now + after`, saturating: a huge timeout means "never".
fn deadline_after(after: Duration) -> tokio::time::Instant {
    let now = tokio::time::Instant::now();
    now.checked_add(after)
        .unwrap_or_else(|| now + Duration::from_secs(365 * 24 * 3600))
}

async fn session(config: &NtripConfig, shared: &Shared, gga: &mut watch::Receiver<Option<String>>) -> SessionEnd {
    let address = format!("{}:{}", config.host, config.port);
    let mut buf = vec![0u8; 4096];
    let (mut stream, mut body) = match open_stream(config, shared, &address, &mut buf).await {
        Ok(opened) => opened,
        Err(end) => return end,
    };

    let mut gga_enabled = !config.gga_interval.is_zero();
    // Due now: a VRS caster waits for the position before it streams.
    let mut next_gga = gga_enabled.then(tokio::time::Instant::now);
    let mut stale_deadline = deadline_after(config.stale_after);
    let far = || deadline_after(Duration::from_secs(365 * 24 * 3600));
    loop {
        if let Some(due) = next_gga
            && due <= tokio::time::Instant::now()
        {
            let line = gga.borrow_and_update().as_deref().and_then(gga_line);
            next_gga = match line {
                Some(line) => {
                    if let Err(error) = write_counted(&mut stream, &line, config.stale_after, shared).await {
                        return SessionEnd {
                            error,
                            delivered: body.delivered,
                        };
                    }
                    Some(deadline_after(config.gga_interval))
                }
                // Nothing to send yet: wake when the core sets one.
                None => None,
            };
        }
        tokio::select! {
            read = stream.read(&mut buf) => {
                let n = match read {
                    Ok(0) => return body.end(NtripError::Link("caster closed the connection".into())),
                    Ok(n) => n,
                    Err(e) => return body.end(NtripError::Link(format!("read: {e}"))),
                };
                update(&shared.status, |s| s.bytes_in += n as u64);
                stale_deadline = deadline_after(config.stale_after);
                match body.take(&buf[..n], shared) {
                    Ok(true) => return body.end(NtripError::Link("caster ended the stream".into())),
                    Ok(false) => {}
                    Err(e) => return body.end(e),
                }
            }
            () = sleep_until(stale_deadline) => {
                return body.end(NtripError::Link(format!("no data for {:?}", config.stale_after)));
            }
            () = sleep_until(next_gga.unwrap_or_else(far)), if next_gga.is_some() => {}
            changed = gga.changed(), if gga_enabled && next_gga.is_none() => {
                match changed {
                    Ok(()) => next_gga = Some(tokio::time::Instant::now()),
                    // The client handle is gone and shutdown follows; stop
                    // watching, or this branch would be ready forever.
                    Err(_) => gga_enabled = false,
                }
            }
        }
    }
}

/// Connects, sends the request, reads the caster's answer and takes the
/// body bytes that came with it: the stream and its body, or how the
/// session ended.
async fn open_stream(
    config: &NtripConfig,
    shared: &Shared,
    address: &str,
    buf: &mut [u8],
) -> Result<(TcpStream, Body), SessionEnd> {
    let fail = |error: NtripError| SessionEnd {
        error,
        delivered: false,
    };
    let mut stream = connect_and_request(config, shared, address).await.map_err(fail)?;
    let (head, start, head_len) = read_response_head(&mut stream, config, shared, address, buf)
        .await
        .map_err(fail)?;
    let StreamStart::Stream { chunked } = start;
    tracing::info!(%address, mountpoint = mount_name(config), chunked, "ntrip stream started");
    update(&shared.status, |s| {
        s.connected = true;
        s.connects += 1;
    });

    let mut body = Body {
        chunked: chunked.then(ChunkedDecoder::new),
        frames: Rtcm3FrameCounter::new(),
        delivered: false,
    };
    if let Err(error) = body.take(&head[head_len..], shared) {
        return Err(SessionEnd {
            error,
            delivered: body.delivered,
        });
    }
    Ok((stream, body))
}

/// Connects to the caster and sends the NTRIP request.
async fn connect_and_request(config: &NtripConfig, shared: &Shared, address: &str) -> Result<TcpStream, NtripError> {
    let request = ntrip_request(config)?;
    let mut stream = match timeout(
        config.stale_after,
        TcpStream::connect((config.host.as_str(), config.port)),
    )
    .await
    {
        Ok(Ok(stream)) => stream,
        Ok(Err(e)) => return Err(NtripError::Link(format!("connect to {address}: {e}"))),
        Err(_) => return Err(NtripError::Link(format!("connect to {address}: timed out"))),
    };
    let _ = stream.set_nodelay(true);
    write_counted(&mut stream, &request, config.stale_after, shared).await?;
    Ok(stream)
}

/// Reads the response head: the bytes read, how the stream starts, and
/// where the head ends in them (whatever follows it in the same reads is
/// stream data).
async fn read_response_head(
    stream: &mut TcpStream,
    config: &NtripConfig,
    shared: &Shared,
    address: &str,
    buf: &mut [u8],
) -> Result<(Vec<u8>, StreamStart, usize), NtripError> {
    let mut head = Vec::new();
    let head_deadline = deadline_after(config.stale_after);
    loop {
        let n = match tokio::time::timeout_at(head_deadline, stream.read(buf)).await {
            Err(_) => return Err(NtripError::Link(format!("no answer from {address}"))),
            Ok(Err(e)) => return Err(NtripError::Link(format!("read: {e}"))),
            Ok(Ok(0)) => return Err(NtripError::Link("caster closed the connection before answering".into())),
            Ok(Ok(n)) => n,
        };
        update(&shared.status, |s| s.bytes_in += n as u64);
        head.extend_from_slice(&buf[..n]);
        if let Some((start, head_len)) = parse_response_head(&head, mount_name(config))? {
            return Ok((head, start, head_len));
        }
    }
}

/// The stream body of one connection.
struct Body {
    chunked: Option<ChunkedDecoder>,
    frames: Rtcm3FrameCounter,
    delivered: bool,
}

impl Body {
    /// Decodes and delivers `bytes`; `Ok(true)` when the caster ended the
    /// chunked stream.
    fn take(&mut self, bytes: &[u8], shared: &Shared) -> Result<bool, NtripError> {
        let (data, ended) = match &mut self.chunked {
            Some(decoder) => {
                let mut data = Vec::with_capacity(bytes.len());
                let ended = decoder.decode(bytes, &mut data)?;
                (data, ended)
            }
            None => (bytes.to_vec(), false),
        };
        if !data.is_empty() {
            self.delivered = true;
            let count = self.frames.push(&data);
            let now = shared.origin.elapsed();
            update(&shared.status, |s| {
                s.messages += count.frames;
                s.errors += count.bad_crc;
                if count.frames > 0 {
                    s.last_message = Some(now);
                }
            });
            shared.deliver(data);
        }
        Ok(ended)
    }

    fn end(&self, error: NtripError) -> SessionEnd {
        SessionEnd {
            error,
            delivered: self.delivered,
        }
    }
}

async fn write_counted(
    stream: &mut TcpStream,
    bytes: &[u8],
    limit: Duration,
    shared: &Shared,
) -> Result<(), NtripError> {
    match timeout(limit, stream.write_all(bytes)).await {
        Ok(Ok(())) => {
            update(&shared.status, |s| s.bytes_out += bytes.len() as u64);
            Ok(())
        }
        Ok(Err(e)) => Err(NtripError::Link(format!("write: {e}"))),
        Err(_) => Err(NtripError::Link("write: timed out".to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(version: NtripVersion) -> NtripConfig {
        NtripConfig {
            host: "caster.example".to_string(),
            port: 2101,
            mountpoint: "/RTCM3".to_string(),
            user: Some("Aladdin".to_string()),
            password: Some("open sesame".to_string()),
            version,
            ..NtripConfig::default()
        }
    }

    #[test]
    fn base64_matches_rfc4648_vectors() {
        let vectors = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, encoded) in vectors {
            assert_eq!(base64(plain.as_bytes()), encoded, "{plain:?}");
        }
    }

    #[test]
    fn v2_request_has_the_ntrip2_headers() {
        let request = String::from_utf8(ntrip_request(&config(NtripVersion::V2)).unwrap()).unwrap();
        assert!(request.starts_with("GET /RTCM3 HTTP/1.1\r\n"), "{request}");
        for header in [
            "Host: caster.example:2101\r\n",
            "Ntrip-Version: Ntrip/2.0\r\n",
            "User-Agent: NTRIP Furrow/0.1\r\n",
            // RFC 7617's example credentials.
            "Authorization: Basic QWxhZGRpbjpvcGVuIHNlc2FtZQ==\r\n",
        ] {
            assert!(request.contains(header), "{header:?} missing in {request}");
        }
        assert!(request.ends_with("\r\n\r\n"));
    }

    #[test]
    fn v1_request_is_http10_without_ntrip_version() {
        let mut c = config(NtripVersion::V1);
        c.user = None;
        c.password = None;
        let request = String::from_utf8(ntrip_request(&c).unwrap()).unwrap();
        assert_eq!(request, "GET /RTCM3 HTTP/1.0\r\nUser-Agent: NTRIP Furrow/0.1\r\n\r\n");
    }

    #[test]
    fn request_refuses_header_injection() {
        let mut c = config(NtripVersion::V2);
        c.mountpoint = "MOUNT HTTP/1.1\r\nX: y".to_string();
        assert!(matches!(ntrip_request(&c), Err(NtripError::Config(_))));
    }

    #[test]
    fn response_heads_are_classified() {
        let parse = |s: &[u8]| parse_response_head(s, "M");
        assert_eq!(
            parse(b"ICY 200 OK\r\n\xD3\x00\x13"),
            Ok(Some((StreamStart::Stream { chunked: false }, 12)))
        );
        assert_eq!(
            parse(b"ICY 200 OK\r\nServer: X 1.0\r\n\r\n\xD3"),
            Ok(Some((StreamStart::Stream { chunked: false }, 29)))
        );
        let v2 = b"HTTP/1.1 200 OK\r\nNtrip-Version: Ntrip/2.0\r\nTransfer-Encoding: chunked\r\n\r\n5\r\n";
        assert_eq!(
            parse(v2),
            Ok(Some((StreamStart::Stream { chunked: true }, v2.len() - 3)))
        );
        assert_eq!(parse(b"HTTP/1.1 200 OK\r\nContent-Ty"), Ok(None));
        assert_eq!(parse(b"ICY 20"), Ok(None));
        assert_eq!(parse(b"HTTP/1.1 401 Unauthorized\r\n"), Err(NtripError::Unauthorized));
        assert_eq!(
            parse(b"SOURCETABLE 200 OK\r\nServer: x\r\n"),
            Err(NtripError::NoSuchMountpoint("M".into()))
        );
        assert_eq!(
            parse(b"HTTP/1.1 200 OK\r\nContent-Type: gnss/sourcetable\r\n\r\nSTR;"),
            Err(NtripError::NoSuchMountpoint("M".into()))
        );
        assert!(matches!(parse(b"HTTP/1.0 503 Busy\r\n"), Err(NtripError::Refused(_))));
        assert!(matches!(parse(b"\xD3\x00\x13garbage\n"), Err(NtripError::Protocol(_))));
        assert!(NtripError::Unauthorized.to_string().starts_with("NTRIP: unauthorized"));
    }

    /// Chunk-codes `data` in pieces of the given sizes, with an extension
    /// and a trailer to exercise the parts a decoder must skip.
    fn chunk_encode(data: &[u8], sizes: &[usize]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut rest = data;
        for &size in sizes.iter().cycle() {
            if rest.is_empty() {
                break;
            }
            let (chunk, tail) = rest.split_at(size.min(rest.len()));
            out.extend_from_slice(format!("{:X};ext=1\r\n", chunk.len()).as_bytes());
            out.extend_from_slice(chunk);
            out.extend_from_slice(b"\r\n");
            rest = tail;
        }
        out.extend_from_slice(b"0\r\nX-Trailer: y\r\n\r\n");
        out
    }

    #[test]
    fn chunked_decoder_handles_any_split() {
        let data: Vec<u8> = (0..300u32).map(|i| (i * 31 % 256) as u8).collect();
        let encoded = chunk_encode(&data, &[1, 17, 0x1A0, 5]);
        for split in 0..=encoded.len() {
            let mut decoder = ChunkedDecoder::new();
            let mut out = Vec::new();
            let first = decoder.decode(&encoded[..split], &mut out).unwrap();
            let done = decoder.decode(&encoded[split..], &mut out).unwrap();
            assert_eq!(out, data, "split at {split}");
            assert!(done, "split at {split}");
            assert_eq!(first, split == encoded.len(), "split at {split}");
        }
    }

    #[test]
    fn chunked_decoder_rejects_garbage() {
        let mut out = Vec::new();
        assert!(ChunkedDecoder::new().decode(b"zz\r\n", &mut out).is_err());
        assert!(ChunkedDecoder::new().decode(b"2\r\nabX", &mut out).is_err());
        assert!(
            ChunkedDecoder::new()
                .decode(b"FFFFFFFFFFFFFFFFFF\r\n", &mut out)
                .is_err()
        );
    }

    #[test]
    fn gga_sentence_parses_back() {
        let utc = Duration::from_millis(((13 * 60 + 5) * 60 + 9) * 1000 + 870);
        let cases = [
            (52.123_456_789, 13.987_654_321, 35.2, 4u8, 14u8, 0.7),
            (-33.856_78, -70.000_01, 612.0, 5, 9, 1.3),
            (0.000_001, 179.999_999_9, -12.5, 1, 5, 12.0),
        ];
        for (lat, lon, alt, quality, sats, hdop) in cases {
            let sentence = gga_sentence(lat, lon, alt, quality, sats, hdop, utc);
            assert!(sentence.len() <= 80, "{sentence}");
            let parsed = nmea::parse_str(&sentence).unwrap_or_else(|e| panic!("{sentence}: {e:?}"));
            let nmea::ParseResult::GGA(gga) = parsed else {
                panic!("not a GGA: {sentence}");
            };
            // 1e-5 minute resolution.
            assert!((gga.latitude.unwrap() - lat).abs() < 2e-7, "{sentence}");
            assert!((gga.longitude.unwrap() - lon).abs() < 2e-7, "{sentence}");
            assert!((f64::from(gga.altitude.unwrap()) - alt).abs() < 0.06, "{sentence}");
            assert_eq!(gga.fix_satellites, Some(u32::from(sats)));
            assert!((f64::from(gga.hdop.unwrap()) - hdop).abs() < 0.06);
            let time = gga.fix_time.unwrap();
            assert_eq!(time.to_string(), "13:05:09.870");
            let expected_fix = match quality {
                1 => nmea::sentences::FixType::Gps,
                4 => nmea::sentences::FixType::Rtk,
                _ => nmea::sentences::FixType::FloatRtk,
            };
            assert_eq!(gga.fix_type, Some(expected_fix));
        }
    }

    #[test]
    fn gga_rounding_carries_into_degrees() {
        let sentence = gga_sentence(47.999_999_999_9, 8.0, 0.0, 1, 7, 1.0, Duration::ZERO);
        assert!(sentence.contains(",4800.00000,N,00800.00000,E,"), "{sentence}");
        let nowhere = gga_sentence(f64::NAN, 200.0, f64::NAN, 0, 0, f64::NAN, Duration::ZERO);
        assert!(nowhere.starts_with("$GPGGA,000000.00,,,,,0,00,,,M,,M,,*"), "{nowhere}");
    }
}
