//! `furrow`: the Furrow autopilot binary.

use std::path::PathBuf;
use std::process::ExitCode;

use autopilot::edge::mqtt::{MqttConfig, parse_broker_url};
use autopilot::edge::mqtt_tls::{TlsFile, TlsFiles};
use autopilot::fleet::AgentConfig;
use autopilot::link::endpoint::Endpoint;
use autopilot::sitl::runner::{self, SitlOptions, Speedup};
use autopilot::sitl::simulation::{ModelKind, SimulationConfig};
use clap::{Parser, Subcommand, ValueEnum};
use vda5050::TopicPrefix;
use vehicle_types::GeoPoint;

#[derive(Parser)]
#[command(
    name = "furrow",
    version,
    about = "Furrow: a rover/AGV autopilot that speaks MAVLink"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a simulated rover that ground stations connect to (TCP 5760, UDP to 14550).
    Sitl(Box<SitlArgs>),
    /// Read and change the stored parameters offline; import and export .param/.params files.
    Params(autopilot::offline::params::ParamsArgs),
    /// The onboard logs (DataFlash .BIN): list a data directory's, summarise one, export CSV (plots: furrow-bench logs plot).
    Logs(autopilot::offline::logs::LogsArgs),
    /// Import, export and list the stored mission, fence and rally plans offline (.waypoints, .plan).
    Mission(autopilot::offline::mission::MissionArgs),
    /// Drive a real vehicle: devices, outputs and MAVLink endpoints from a configuration file.
    Run {
        /// The vehicle configuration (TOML; see autopilot/examples/).
        #[arg(long)]
        config: PathBuf,
    },
    /// Show the device table of a running furrow (rates, ages, errors) over MAVLink.
    Status(autopilot::run::status::StatusArgs),
    /// Check a vehicle configuration file (the one `furrow run --config` reads).
    Config {
        #[command(subcommand)]
        action: autopilot::offline::config::ConfigAction,
    },
}

#[derive(clap::Args)]
struct SitlArgs {
    /// Simulated seconds per wall second, or `max` for as fast as possible.
    #[arg(long, value_parser = parse_speedup)]
    speedup: Option<Speedup>,
    /// Start position and heading: LAT,LON,ALT,HDG (degrees, metres, degrees from north).
    #[arg(long, value_parser = parse_home, default_value = "29.1330,119.6400,40,0")]
    home: Home,
    /// Instance number: ports move by 10 per instance (TCP 5760+10·I, UDP 14550+10·I).
    #[arg(long, short = 'I', default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=5000))]
    instance: u16,
    /// Where parameters and missions are kept (default: furrow-data, or furrow-data-I for instance I).
    #[arg(long)]
    data_dir: Option<PathBuf>,
    /// Seed of the simulated sensor noise: the same seed and inputs give the same run.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Vehicle model.
    #[arg(long, value_enum, default_value_t = Model::Ackermann)]
    model: Model,
    /// No simulated inertial unit (by default a VectorNav-style IMU sends
    /// `$VNIMU` at 50 Hz): the vehicle then reports no gyro or accelerometer.
    #[arg(long)]
    no_imu: bool,
    /// Extra MAVLink endpoint: udp:HOST:PORT, udpin:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT, serial:DEV:BAUD (repeatable).
    #[arg(long, value_parser = parse_endpoint)]
    mavlink: Vec<Endpoint>,
    /// A secure MAVLink endpoint (same syntax; e.g. tcpin:127.0.0.1:0): accepts SETUP_SIGNING and unsigned packets (repeatable).
    #[arg(long, value_parser = parse_endpoint)]
    secure_mavlink: Vec<Endpoint>,
    /// Record all MAVLink traffic to this telemetry log (.tlog).
    #[arg(long)]
    tlog: Option<PathBuf>,
    /// Lay a magnetic tape (for MAGNETIC mode, 20) through the waypoints of this file (QGC WPL 110).
    #[arg(long)]
    tape: Option<PathBuf>,
    /// Radius of the tape's corner arcs, metres.
    #[arg(long, default_value_t = 15.0, value_parser = parse_tape_radius)]
    tape_radius: f64,
    /// A world file (TOML: static and moving obstacles, tape; see tests/data/worlds/README.md), reloaded when it changes.
    #[arg(long)]
    world: Option<PathBuf>,
    /// TCP server port instead of 5760+10·I (0: any free port, printed at start).
    #[arg(long)]
    tcp_port: Option<u16>,
    /// UDP destination port instead of 14550+10·I.
    #[arg(long)]
    udp_port: Option<u16>,
    /// Be a VDA 5050 2.1 AGV on this MQTT broker: mqtt://HOST:PORT, or mqtts://HOST:PORT for TLS.
    #[arg(long, value_name = "URL")]
    vda5050: Option<String>,
    /// mqtts://: the CA that signed the broker's certificate (PEM; default: the system's trust store).
    #[arg(long, value_name = "FILE", requires = "vda5050")]
    vda5050_ca: Option<PathBuf>,
    /// mqtts://: this vehicle's client certificate (PEM), with --vda5050-key.
    #[arg(long, value_name = "FILE", requires = "vda5050_key")]
    vda5050_cert: Option<PathBuf>,
    /// mqtts://: the client certificate's private key (PEM).
    #[arg(long, value_name = "FILE", requires = "vda5050_cert")]
    vda5050_key: Option<PathBuf>,
    /// The broker's user name, with --vda5050-password-file.
    #[arg(long, value_name = "NAME", requires = "vda5050_password_file")]
    vda5050_user: Option<String>,
    /// A file holding the broker password (its first line; kept off the command line).
    #[arg(long, value_name = "FILE", requires = "vda5050_user")]
    vda5050_password_file: Option<PathBuf>,
    /// VDA 5050 serial number (topic level; default furrow-I for instance I).
    #[arg(long, requires = "vda5050")]
    serial_number: Option<String>,
    /// VDA 5050 manufacturer (topic level).
    #[arg(long, default_value = "Furrow", requires = "vda5050")]
    manufacturer: String,
    /// VDA 5050 map id: orders on another map are refused.
    #[arg(long, default_value = "local", requires = "vda5050")]
    map_id: String,
    /// VDA 5050 map frame origin LAT,LON (degrees): the plant grid (GEO_FRAME, GEO_MAP_*) about this point, so every vehicle with the same one shares map coordinates (default: --home).
    #[arg(long, value_name = "LAT,LON", value_parser = parse_map_origin, requires = "vda5050")]
    map_origin: Option<(f64, f64)>,
    /// Run N vehicles in this process sharing one world (each sees the others with its scanners): instances I…I+N−1, data in DATA_DIR/vehicle-i, VDA 5050 serial SERIAL-i.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=250))]
    fleet: Option<u16>,
    /// Where the fleet's vehicles start: one line per vehicle, `NORTH_M EAST_M HEADING_DEG` from --home (default: side by side, 5 m apart).
    #[arg(long, value_name = "FILE", requires = "fleet")]
    fleet_homes: Option<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum)]
enum Model {
    Ackermann,
    Differential,
}

#[derive(Clone, Copy, Debug)]
struct Home {
    point: GeoPoint,
    heading_deg: f64,
}

fn parse_tape_radius(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1000.0 => Ok(v),
        _ => Err(format!("{s:?}: a radius in metres, more than 0 and at most 1000")),
    }
}

fn parse_speedup(s: &str) -> Result<Speedup, String> {
    if s.eq_ignore_ascii_case("max") {
        return Ok(Speedup::Max);
    }
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 100_000.0 => Ok(Speedup::Factor(v)),
        _ => Err(format!("{s:?} is not a speedup: give a number in (0, 100000] or `max`")),
    }
}

fn parse_home(s: &str) -> Result<Home, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 4 {
        return Err(format!("{s:?}: expected LAT,LON,ALT,HDG"));
    }
    let mut v = [0f64; 4];
    for (slot, (name, text)) in v.iter_mut().zip(["LAT", "LON", "ALT", "HDG"].iter().zip(&parts)) {
        *slot = text
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{s:?}: {name} {text:?} is not a number"))?;
    }
    if v[0].abs() > 90.0 || v[1].abs() > 180.0 {
        return Err(format!("{s:?}: latitude must be within ±90 and longitude within ±180"));
    }
    if !(-1000.0..=10000.0).contains(&v[2]) {
        return Err(format!("{s:?}: altitude {} m is out of range", v[2]));
    }
    // -360..=360 takes every way of writing a heading; beyond that a number
    // is a typo (and 1e30 would lose every degree to rounding).
    if !(-360.0..=360.0).contains(&v[3]) {
        return Err(format!("{s:?}: heading {}° must be within ±360", v[3]));
    }
    Ok(Home {
        point: GeoPoint {
            lat_deg: v[0],
            lon_deg: v[1],
            alt_m: v[2],
        },
        heading_deg: v[3].rem_euclid(360.0),
    })
}

fn parse_map_origin(s: &str) -> Result<(f64, f64), String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [lat, lon] = parts[..] else {
        return Err(format!("{s:?}: expected LAT,LON"));
    };
    let number = |name: &str, text: &str, limit: f64| {
        text.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && x.abs() <= limit)
            .ok_or_else(|| format!("{s:?}: {name} {text:?} is not a number within ±{limit}"))
    };
    Ok((number("LAT", lat, 90.0)?, number("LON", lon, 180.0)?))
}

fn parse_endpoint(s: &str) -> Result<Endpoint, String> {
    s.parse()
}

fn utc_now_us() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as i64)
}

/// `--vda5050` and its companions, checked.
fn vda5050_options(args: &SitlArgs) -> Result<Option<(MqttConfig, AgentConfig)>, String> {
    let Some(url) = &args.vda5050 else {
        return Ok(None);
    };
    let broker = parse_broker_url(url).map_err(|e| format!("--vda5050 {e}"))?;
    let serial = args.serial_number.clone().unwrap_or_else(|| match args.fleet {
        // A fleet's vehicles are furrow-0, furrow-1, …
        Some(_) => "furrow".to_owned(),
        None => format!("furrow-{}", args.instance),
    });
    let prefix = TopicPrefix::uagv_v2(&args.manufacturer, &serial).map_err(|e| e.to_string())?;
    if args.map_id.is_empty() {
        return Err("--map-id: a map id cannot be empty".into());
    }
    let tls_given = args.vda5050_ca.is_some() || args.vda5050_cert.is_some();
    if tls_given && !broker.tls {
        return Err(format!(
            "--vda5050-ca/--vda5050-cert need an mqtts:// broker, not {url}"
        ));
    }
    let tls = TlsFiles {
        ca_file: args.vda5050_ca.clone(),
        client_auth: args.vda5050_cert.clone().zip(args.vda5050_key.clone()),
    };
    let credentials = match (&args.vda5050_user, &args.vda5050_password_file) {
        (Some(user), Some(file)) => Some((user.clone(), read_password(file)?)),
        _ => None,
    };
    let client_id = format!("{}-{}", args.manufacturer, serial);
    let mqtt = MqttConfig::new(&broker, &tls, prefix, client_id, credentials).map_err(|e| {
        let flag = match e.file {
            TlsFile::Ca => "--vda5050-ca",
            TlsFile::ClientCert => "--vda5050-cert",
            TlsFile::ClientKey => "--vda5050-key",
        };
        format!("{flag}: {e}")
    })?;
    // A simulated fleet shares --home: its map frame is about it unless
    // told otherwise, so every vehicle gives the same map coordinates.
    let map_origin = match args.map_origin {
        Some((lat_deg, lon_deg)) => GeoPoint {
            lat_deg,
            lon_deg,
            alt_m: args.home.point.alt_m,
        },
        None => args.home.point,
    };
    let agent = AgentConfig {
        map_id: args.map_id.clone(),
        map_origin: Some(map_origin),
        ..AgentConfig::default()
    };
    Ok(Some((mqtt, agent)))
}

/// The first line of a password file, without its line end.
fn read_password(file: &std::path::Path) -> Result<String, String> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("--vda5050-password-file: cannot read {}: {e}", file.display()))?;
    let password = text.lines().next().unwrap_or_default();
    if password.is_empty() {
        return Err(format!("--vda5050-password-file: {} is empty", file.display()));
    }
    Ok(password.to_owned())
}

fn run_sitl(args: SitlArgs) -> Result<(), String> {
    let vda5050 = vda5050_options(&args)?;
    let data_dir = args.data_dir.unwrap_or_else(|| match (args.fleet, args.instance) {
        (Some(_), _) => PathBuf::from("furrow-fleet-data"),
        (None, 0) => PathBuf::from("furrow-data"),
        (None, i) => PathBuf::from(format!("furrow-data-{i}")),
    });
    runner::run(SitlOptions {
        sim: SimulationConfig {
            home: args.home.point,
            home_heading_deg: args.home.heading_deg,
            model: match args.model {
                Model::Ackermann => ModelKind::Ackermann,
                Model::Differential => ModelKind::Differential,
            },
            seed: args.seed,
            utc_start_unix_us: utc_now_us(),
            imu: (!args.no_imu).then(sim::ImuSimConfig::default),
        },
        speedup: args.speedup,
        instance: args.instance,
        data_dir,
        tcp_port: args.tcp_port,
        udp_port: args.udp_port,
        mavlink: args.mavlink,
        secure_mavlink: args.secure_mavlink,
        tlog: args.tlog,
        tape: args.tape.map(|path| (path, args.tape_radius)),
        world: args.world,
        vda5050,
        fleet: args.fleet.map(|count| runner::FleetOptions {
            count: usize::from(count),
            homes: args.fleet_homes,
        }),
    })
}

fn main() -> ExitCode {
    autopilot::stderr_log::init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Sitl(args) => run_sitl(*args),
        Command::Params(args) => autopilot::offline::params::run(&args),
        Command::Mission(args) => autopilot::offline::mission::run(&args),
        Command::Logs(args) => autopilot::offline::logs::run(&args),
        Command::Config { action } => autopilot::offline::config::run(&action),
        Command::Run { config } => autopilot::run::runner::run(&config),
        Command::Status(args) => autopilot::run::status::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("furrow: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn home_and_speedup_parsing() {
        let h = parse_home("29.133,119.64,40,-90").unwrap();
        assert_eq!(h.heading_deg, 270.0);
        assert!(parse_home("29.133,119.64,40").is_err());
        assert!(parse_home("91,0,0,0").is_err());
        assert!(parse_home("a,0,0,0").is_err());
        let huge = parse_home("29.133,119.64,40,1e30").unwrap_err();
        assert!(huge.contains("heading") && huge.contains("±360"), "{huge}");
        assert!(parse_home("29.133,119.64,40,-361").is_err());
        assert_eq!(parse_home("29.133,119.64,40,360").unwrap().heading_deg, 0.0);
        assert_eq!(parse_speedup("MAX"), Ok(Speedup::Max));
        assert_eq!(parse_speedup("50"), Ok(Speedup::Factor(50.0)));
        assert!(parse_speedup("0").is_err());
        assert!(parse_speedup("-3").is_err());
    }
}
