//! What crosses the core's boundary in one step.

use drivers::gnss::GnssSample;
use drivers::magnetic::MagneticSample;
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion};
use vehicle_types::{ActuatorDemand, BatterySample};

/// One MAVLink link (a TCP client, the UDP peer, a serial port…), numbered by
/// the link layer in the order links appear.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LinkId(pub u16);

/// One ground station on a link, numbered by the link layer. A UDP link can
/// serve several (one per address that sent a valid frame); a TCP client or
/// a serial port is one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PeerId(pub u32);

/// A link came or went, or a ground station appeared on one. `stream_slot`
/// picks the `SRn_*` defaults a link starts with (TCP server 0, UDP 1,
/// extra endpoints 2, 3).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LinkEvent {
    Opened {
        link: LinkId,
        stream_slot: u8,
    },
    Closed {
        link: LinkId,
    },
    /// A ground station is there to be told what it missed: a new TCP
    /// client, the first valid frame from a new UDP address (or one silent
    /// for a while), a serial port heard from after opening or a silence,
    /// and a UDP link's configured destination when the link opens.
    PeerJoined {
        link: LinkId,
        peer: PeerId,
    },
}

/// A decoded message addressed to this vehicle (or broadcast).
#[derive(Clone, Debug)]
pub struct Inbound {
    pub link: LinkId,
    pub header: MavHeader,
    pub version: MavlinkVersion,
    pub message: MavMessage,
}

/// A MISSION_ITEM(_INT) whose command, frame or mission type the dialect
/// does not know: it cannot be decoded, but the upload it belongs to must
/// still be answered (UNSUPPORTED / UNSUPPORTED_FRAME).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UndecodableItem {
    pub link: LinkId,
    pub header: MavHeader,
    pub seq: u16,
    pub mission_type: u8,
    pub target_system: u8,
    pub target_component: u8,
    pub bad_frame: bool,
}

/// Where an outgoing message goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Destination {
    /// Every link (STATUSTEXT, PARAM_VALUE after a set, HOME_POSITION on change).
    AllLinks,
    /// One link: a reply to a request, or that link's telemetry stream.
    Link(LinkId),
    /// One ground station of a link (the notices it missed).
    Peer { link: LinkId, peer: PeerId },
}

#[derive(Clone, Debug)]
pub struct Outbound {
    pub dest: Destination,
    pub message: MavMessage,
}

/// Inputs of one core step. The caller clears and refills it every tick.
#[derive(Default)]
pub struct Inputs {
    pub link_events: Vec<LinkEvent>,
    pub messages: Vec<Inbound>,
    pub undecodable_items: Vec<UndecodableItem>,
    pub gnss: Vec<GnssSample>,
    pub battery: Option<BatterySample>,
    /// The magnetic-tape sensors, when the vehicle has them.
    pub magnetic: Option<MagneticSample>,
    /// Laser scans received since the last tick.
    pub scans: Vec<ScanInput>,
    /// Saves the edge finished (answers to [`Outputs::saves`]).
    pub saved: Vec<super::SaveDone>,
    /// The simulator's true pose, in SITL only: reported as SIMSTATE and
    /// beside a stop's estimated error, never used to drive.
    pub sim_truth: Option<SimTruth>,
    /// VDA 5050 payloads from the master control (order, instantActions).
    pub vda5050: Vec<(vda5050::Topic, Vec<u8>)>,
}

/// Where the simulated vehicle really is (its reference point, the rear
/// axle centre), as the simulator knows it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SimTruth {
    pub lat_deg: f64,
    pub lon_deg: f64,
    /// True heading: from true north, clockwise, in [-π, π).
    pub yaw_rad: f64,
    /// Clockwise positive.
    pub yaw_rate_rad_s: f64,
    /// Signed forward speed: negative in reverse.
    pub speed_mps: f64,
    /// Rate of change of the signed forward speed.
    pub accel_mps2: f64,
}

/// A scan and which scanner sent it (0 = SCAN1, 1 = SCAN2).
#[derive(Clone, Debug, PartialEq)]
pub struct ScanInput {
    pub scanner: usize,
    pub scan: drivers::scanner::Scan,
}

impl Inputs {
    pub fn clear(&mut self) {
        self.link_events.clear();
        self.messages.clear();
        self.undecodable_items.clear();
        self.gnss.clear();
        self.battery = None;
        self.magnetic = None;
        self.scans.clear();
        self.saved.clear();
        self.sim_truth = None;
        self.vda5050.clear();
    }
}

/// Outputs of one core step.
pub struct Outputs {
    /// What the drive train should do now (neutral when disarmed).
    pub actuators: ActuatorDemand,
    /// Servo channel pulse widths (µs), as SERVO_OUTPUT_RAW reports them.
    pub servo_pwm_us: [u16; 16],
    pub mavlink: Vec<Outbound>,
    /// Saves to do and report in [`Inputs::saved`] (see `Storage`).
    pub saves: Vec<super::SaveRequest>,
    /// For the onboard log's writer (records, files to open and close,
    /// ground stations' LOG_* requests).
    pub log: Vec<crate::logging::LogCommand>,
    /// VDA 5050 messages for the master control.
    pub vda5050: Vec<super::FleetMessage>,
    /// What mission downloads read, as of this step: the link layer answers
    /// download requests from it (docs/architecture.md §Mission downloads at
    /// the link). `None`: none published, the core answers them.
    pub mission_downloads: Option<std::sync::Arc<mission::Downloads>>,
}

impl Default for Outputs {
    fn default() -> Self {
        Outputs {
            actuators: ActuatorDemand::Ackermann {
                steering: 0.0,
                throttle: 0.0,
            },
            servo_pwm_us: [0; 16],
            mavlink: Vec::new(),
            saves: Vec::new(),
            log: Vec::new(),
            vda5050: Vec::new(),
            mission_downloads: None,
        }
    }
}
