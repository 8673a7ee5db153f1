//! The real vehicle's sensors, started from the configuration file: each
//! driver runs on its own thread (or as a task on the edge's runtime) and the
//! core's loop only polls them, so a device that blocks, vanishes or sends
//! garbage never delays a tick.

use std::time::{Duration, Instant};

use drivers::device::DeviceStatus;
use drivers::gnss::port::{GnssPort, GnssPortConfig, GnssSource};
use drivers::gnss::{FixQuality, GnssFix, GnssSample};
use drivers::magnetic_serial::MagneticSerial;
use drivers::ntrip::{NtripClient, gga_sentence};
use drivers::rtcm::RtcmReassembler;
use drivers::scanner::Scan;
use drivers::scanner::client::{ScannerClient, ScannerClientConfig};
use tokio::runtime::Handle;
use tokio::sync::mpsc;

use super::config::{GnssLink, HeadingSource, SerialLine, VehicleConfig};
use crate::vehicle::{Inputs, ScanInput};

/// How long a magnetic sensor may stay silent before it counts as lost.
const MAGNETIC_STALE: Duration = Duration::from_millis(200);
/// A scanner silent this long is reported lost (the core's own
/// `OA_SCAN_TMO` stops the vehicle much sooner).
const SCANNER_STALE: Duration = Duration::from_millis(500);
/// Scans queued per scanner between two ticks (50 Hz scans, 50 Hz ticks).
const SCAN_QUEUE: usize = 8;

/// One device's health as the status view and the announcements show it.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceReport {
    pub name: String,
    /// Where it is: a port or an address.
    pub place: String,
    pub connected: bool,
    /// No good data within its stale time.
    pub stale: bool,
    /// Good messages per second over the last report interval.
    pub rate_hz: f64,
    /// Seconds since the last good message (`None`: never).
    pub age_s: Option<f64>,
    pub errors: u64,
    pub connects: u64,
    /// Good messages since start (the rate is measured from it).
    pub messages: u64,
    pub last_error: Option<String>,
}

impl DeviceReport {
    /// The one line `furrow status` prints and STATUSTEXT carries.
    pub fn line(&self) -> String {
        let state = match (self.connected, self.stale) {
            (false, _) => "DOWN",
            (true, true) => "STALE",
            (true, false) => "OK",
        };
        let age = self.age_s.map_or("never".to_string(), |a| format!("{a:.2}s"));
        format!(
            "{} {state} {:.1}Hz age {age} err {} conn {}",
            self.name, self.rate_hz, self.errors, self.connects
        )
    }

    fn healthy(&self) -> bool {
        self.connected && !self.stale
    }
}

/// A rate from two readings of a message counter.
#[derive(Clone, Copy, Debug, Default)]
struct RateMeter {
    last: Option<(Duration, u64)>,
    rate_hz: f64,
}

impl RateMeter {
    fn update(&mut self, now: Duration, count: u64) -> f64 {
        match self.last {
            Some((t, c)) if now > t + Duration::from_millis(500) => {
                self.rate_hz = count.saturating_sub(c) as f64 / (now - t).as_secs_f64();
                self.last = Some((now, count));
            }
            None => self.last = Some((now, count)),
            _ => {}
        }
        self.rate_hz
    }
}

/// The scanners' CoLa-A clients are tasks on the edge's runtime; scans come
/// back through bounded channels the loop polls. Dropping the set drops the
/// receivers, which ends the tasks.
struct ScannerSet {
    receivers: Vec<mpsc::Receiver<Scan>>,
    stats: Vec<std::sync::Arc<drivers::scanner::client::ScannerStats>>,
    addresses: Vec<String>,
    last_scan: Vec<Option<Duration>>,
    _clients: Vec<ScannerClient>,
}

impl ScannerSet {
    fn start(addresses: Vec<String>, origin: Instant, runtime: &Handle) -> ScannerSet {
        let _context = runtime.enter();
        let mut clients = Vec::new();
        let mut receivers = Vec::new();
        let mut stats = Vec::new();
        for address in &addresses {
            let config = ScannerClientConfig {
                address: address.clone(),
                ..ScannerClientConfig::default()
            };
            let (client, rx) = ScannerClient::spawn(config, move || origin.elapsed(), SCAN_QUEUE);
            stats.push(std::sync::Arc::clone(client.stats()));
            receivers.push(rx);
            clients.push(client);
        }
        let n = addresses.len();
        ScannerSet {
            receivers,
            stats,
            addresses,
            last_scan: vec![None; n],
            _clients: clients,
        }
    }
}

/// Every sensor of the vehicle, and the corrections on their way to the
/// receiver.
pub struct Devices {
    gnss: GnssPort,
    gnss_place: String,
    compass: Option<(GnssPort, String)>,
    /// The inertial unit: VectorNav lines through an NMEA port of its own.
    imu: Option<(GnssPort, String)>,
    /// The client, its caster for the status view, the GGA interval and
    /// how long the caster may stay silent.
    ntrip: Option<(NtripClient, String, Duration, Duration)>,
    magnetic: Option<MagneticSerial>,
    scanners: Option<ScannerSet>,
    rtcm: RtcmReassembler,
    accept_mavlink_rtcm: bool,
    rtcm_dropped: u64,
    last_fix: Option<GnssFix>,
    next_gga: Duration,
    rates: Vec<RateMeter>,
    /// Health at the last check, per device name, for announcements.
    announced: Vec<(String, bool)>,
}

impl Devices {
    /// Starts every configured device (the async ones on `runtime`).
    /// Starting never fails: a missing or unreachable device is retried in
    /// the background and shows as not connected in the status view.
    pub fn start(config: &VehicleConfig, origin: Instant, runtime: &Handle) -> Devices {
        let (source, gnss_place) = gnss_source(&config.gnss.link);
        let gnss = GnssPort::spawn(
            GnssPortConfig {
                stale_after: config.gnss.stale_after(),
                ..GnssPortConfig::new(source)
            },
            origin,
        );
        let compass = match &config.heading {
            HeadingSource::Compass(line) => Some((
                GnssPort::spawn(GnssPortConfig::new(serial_source(line)), origin),
                serial_place(line),
            )),
            HeadingSource::Gnss | HeadingSource::None => None,
        };
        let imu = config.imu.as_ref().map(|line| {
            let port = GnssPortConfig {
                stale_after: crate::estimation::IMU_STALE_AFTER,
                ..GnssPortConfig::new(serial_source(line))
            };
            (GnssPort::spawn(port, origin), serial_place(line))
        });
        let ntrip = config.corrections.ntrip.as_ref().map(|n| {
            let client = NtripClient::spawn(n.clone(), origin, runtime);
            (
                client,
                format!("{}:{}/{}", n.host, n.port, n.mountpoint),
                n.gga_interval,
                n.stale_after,
            )
        });
        let magnetic = config.magnetic.as_ref().map(|line| {
            MagneticSerial::spawn(
                line.path.to_string_lossy().into_owned(),
                line.baud,
                MAGNETIC_STALE,
                origin,
            )
        });
        let scanners = if config.scanners.is_empty() {
            None
        } else {
            let addresses = config
                .scanners
                .iter()
                .map(|s| format!("{}:{}", s.host, s.port))
                .collect();
            Some(ScannerSet::start(addresses, origin, runtime))
        };
        Devices {
            gnss,
            gnss_place,
            compass,
            imu,
            ntrip,
            magnetic,
            scanners,
            rtcm: RtcmReassembler::new(),
            accept_mavlink_rtcm: config.corrections.mavlink,
            rtcm_dropped: 0,
            last_fix: None,
            next_gga: Duration::ZERO,
            rates: Vec::new(),
            announced: Vec::new(),
        }
    }

    /// Everything the devices delivered since the last tick, into `inputs`.
    pub fn poll(&mut self, now: Duration, inputs: &mut Inputs) {
        let first = inputs.gnss.len();
        self.gnss.drain_samples(&mut inputs.gnss);
        for sample in &inputs.gnss[first..] {
            if let GnssSample::Fix(fix) = sample
                && fix.quality != FixQuality::NoFix
            {
                self.last_fix = Some(*fix);
            }
        }
        if let Some((compass, _)) = &self.compass {
            compass.drain_samples(&mut inputs.gnss);
        }
        if let Some((imu, _)) = &self.imu {
            imu.drain_samples(&mut inputs.gnss);
        }
        if let Some(magnetic) = &self.magnetic {
            inputs.magnetic = magnetic.latest();
        }
        if let Some(set) = &mut self.scanners {
            for (index, rx) in set.receivers.iter_mut().enumerate() {
                while let Ok(scan) = rx.try_recv() {
                    set.last_scan[index] = Some(scan.t);
                    inputs.scans.push(ScanInput { scanner: index, scan });
                }
            }
        }
        self.pump_ntrip(now);
    }

    /// Corrections from the caster go to the receiver; the caster gets our
    /// position every GGA interval (a VRS caster needs it to pick a base).
    fn pump_ntrip(&mut self, now: Duration) {
        let Some((client, _, gga_interval, _)) = &self.ntrip else {
            return;
        };
        let mut chunks = Vec::new();
        client.drain_corrections(&mut chunks);
        for chunk in chunks {
            if !self.gnss.send_to_receiver(chunk) {
                self.rtcm_dropped += 1;
            }
        }
        if !gga_interval.is_zero()
            && now >= self.next_gga
            && let Some(fix) = self.last_fix
        {
            self.next_gga = now + *gga_interval;
            let utc = crate::time::duration_from_secs(fix.utc_time_of_day_s.unwrap_or(0.0).max(0.0));
            client.set_gga(gga_sentence(
                fix.lat_deg,
                fix.lon_deg,
                fix.alt_msl_m,
                fix.quality.gga_digit(),
                fix.satellites,
                f64::from(fix.hdop),
                utc,
            ));
        }
    }

    /// One GPS_RTCM_DATA from a ground station: reassembled, then written
    /// to the receiver whole. Returns false when corrections over MAVLink
    /// are off in the configuration.
    pub fn mavlink_rtcm(&mut self, flags: u8, data: &[u8]) -> bool {
        if !self.accept_mavlink_rtcm {
            return false;
        }
        let mut complete = Vec::new();
        self.rtcm.push(flags, data, &mut complete);
        for message in complete {
            if !self.gnss.send_to_receiver(message) {
                self.rtcm_dropped += 1;
            }
        }
        true
    }

    /// Every device's health now.
    pub fn reports(&mut self, now: Duration) -> Vec<DeviceReport> {
        let mut reports = Vec::new();
        let gnss_status = self.gnss.status();
        reports.push(report(
            "GNSS",
            &self.gnss_place,
            &gnss_status,
            self.gnss.is_stale(now),
            now,
        ));
        if let Some((compass, place)) = &self.compass {
            reports.push(report("Compass", place, &compass.status(), compass.is_stale(now), now));
        }
        if let Some((imu, place)) = &self.imu {
            reports.push(report("IMU", place, &imu.status(), imu.is_stale(now), now));
        }
        if let Some((client, place, _, stale_after)) = &self.ntrip {
            let status = client.status();
            let stale = drivers::gnss::port::is_stale(status.last_message, now, *stale_after);
            reports.push(report("NTRIP", place, &status, stale, now));
        }
        if let Some(magnetic) = &self.magnetic {
            reports.push(report(
                "Magnetic",
                magnetic.path(),
                &magnetic.status(),
                magnetic.is_stale(now),
                now,
            ));
        }
        if let Some(set) = &self.scanners {
            for (i, ((stats, address), last)) in set.stats.iter().zip(&set.addresses).zip(&set.last_scan).enumerate() {
                let s = stats.snapshot();
                let status = DeviceStatus {
                    connected: s.connects > s.disconnects,
                    connects: s.connects,
                    bytes_in: 0,
                    bytes_out: 0,
                    messages: s.scans,
                    errors: s.malformed + s.scanner_errors,
                    last_message: *last,
                    last_error: s.last_error,
                };
                let stale = drivers::gnss::port::is_stale(*last, now, SCANNER_STALE);
                reports.push(report(&format!("Scanner{}", i + 1), address, &status, stale, now));
            }
        }
        if self.rates.len() < reports.len() {
            self.rates.resize(reports.len(), RateMeter::default());
        }
        for (r, meter) in reports.iter_mut().zip(&mut self.rates) {
            r.rate_hz = meter.update(now, r.messages);
        }
        reports
    }

    /// The devices whose health changed since the last call: (report,
    /// healthy now). The first call reports only devices that are not
    /// healthy after `grace` (a receiver takes a moment to start talking).
    pub fn changes(&mut self, now: Duration, grace: Duration) -> Vec<(DeviceReport, bool)> {
        let mut changed = Vec::new();
        for r in self.reports(now) {
            let healthy = r.healthy();
            match self.announced.iter_mut().find(|(name, _)| *name == r.name) {
                Some((_, was)) if *was != healthy => {
                    *was = healthy;
                    changed.push((r, healthy));
                }
                Some(_) => {}
                None if healthy => self.announced.push((r.name.clone(), true)),
                None if now >= grace => {
                    self.announced.push((r.name.clone(), false));
                    changed.push((r, false));
                }
                None => {}
            }
        }
        changed
    }

    /// Corrections that could not be queued to the receiver.
    pub fn rtcm_dropped(&self) -> u64 {
        self.rtcm_dropped
    }
}

/// The GNSS port's source, and where it is as the status view names it.
fn gnss_source(link: &GnssLink) -> (GnssSource, String) {
    match link {
        GnssLink::Serial(line) => (serial_source(line), serial_place(line)),
        GnssLink::Tcp(hp) => {
            let address = format!("{}:{}", hp.host, hp.port);
            let place = format!("tcp {address}");
            (GnssSource::Tcp { address }, place)
        }
    }
}

/// A serial device's place in the status view: `PATH@BAUD`.
fn serial_place(line: &SerialLine) -> String {
    format!("{}@{}", line.path.display(), line.baud)
}

fn serial_source(line: &SerialLine) -> GnssSource {
    GnssSource::Serial {
        path: line.path.to_string_lossy().into_owned(),
        baud: line.baud,
    }
}

/// A report from a driver's status (rate filled in by the caller).
pub fn report(name: &str, place: &str, status: &DeviceStatus, stale: bool, now: Duration) -> DeviceReport {
    DeviceReport {
        name: name.to_string(),
        place: place.to_string(),
        connected: status.connected,
        stale,
        rate_hz: 0.0,
        age_s: status.last_message.map(|t| now.saturating_sub(t).as_secs_f64()),
        errors: status.errors,
        connects: status.connects,
        messages: status.messages,
        last_error: status.last_error.clone(),
    }
}
