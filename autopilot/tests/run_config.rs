//! The vehicle configuration of `furrow run --config`: the shipped examples
//! load, every kind of mistake is reported with its key and line, and
//! `furrow config check` exits 0 / 1 accordingly.

use std::path::{Path, PathBuf};
use std::process::Command;

use autopilot::fleet::AgentConfig;
use autopilot::link::endpoint::Endpoint;
use autopilot::run::config::{
    self, BAUD_RATES, ConfigError, Frame, GnssLink, HeadingSource, HostPort, PwmOutputSetting, SerialLine,
    VehicleConfig,
};
use drivers::ntrip::NtripVersion;
use proptest::prelude::*;

fn examples_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples")
}

const BASE_DIR: &str = "/srv/vehicle";

fn parse(text: &str) -> Result<VehicleConfig, ConfigError> {
    config::parse(text, Path::new(BASE_DIR))
}

/// The 1-based line holding `# <-` in a test document: where an error must point.
fn marked_line(text: &str) -> usize {
    let index = text.lines().position(|l| l.contains("# <-"));
    index
        .map(|i| i + 1)
        .unwrap_or_else(|| panic!("no `# <-` marker in\n{text}"))
}

fn expect_error(text: &str, key: &str, fragment: &str) -> ConfigError {
    let err = match parse(text) {
        Ok(config) => panic!("accepted:\n{text}\nas {config:?}"),
        Err(e) => e,
    };
    assert_eq!(err.key, key, "wrong key in {err}\nfor\n{text}");
    assert!(
        err.message.contains(fragment),
        "{err:?} lacks {fragment:?}\nfor\n{text}"
    );
    let shown = err.to_string();
    assert!(shown.contains(key), "{shown} does not name {key}");
    err
}

/// An error on the marked line that names `key`.
fn expect_error_at_mark(text: &str, key: &str, fragment: &str) {
    let err = expect_error(text, key, fragment);
    let line = marked_line(text);
    assert_eq!(err.line, Some(line), "wrong line in {err}\nfor\n{text}");
    assert!(err.to_string().contains(&format!(":{line}:")), "{err}");
}

#[test]
fn ackermann_example_loads_with_every_device() {
    let dir = examples_dir();
    let agv = config::load(&dir.join("ackermann-agv.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(agv.frame, Frame::Ackermann);
    assert_eq!(agv.data_dir, dir.join("agv-data"));
    match &agv.gnss.link {
        GnssLink::Serial(line) => {
            assert!(line.path.starts_with("/dev/serial/by-id"), "{line:?}");
            assert_eq!(line.baud, 460_800);
        }
        other => panic!("gnss {other:?}"),
    }
    assert_eq!(agv.heading, HeadingSource::Gnss);
    assert!(agv.corrections.mavlink);
    let ntrip = agv.corrections.ntrip.as_ref().unwrap_or_else(|| panic!("no ntrip"));
    assert_eq!(ntrip.version, NtripVersion::V2);
    assert_eq!((ntrip.host.as_str(), ntrip.port), ("rtk.example.net", 2101));
    assert_eq!(ntrip.gga_interval.as_secs(), 10);
    assert!(ntrip.user.is_some() && ntrip.password.is_some());
    assert_eq!(agv.scanners.len(), 2);
    assert!(agv.scanners.iter().all(|s| s.port == 2111));
    assert!(agv.magnetic.is_some());
    let imu = agv.imu.as_ref().unwrap_or_else(|| panic!("no imu"));
    assert_eq!((imu.path.to_str(), imu.baud), (Some("/dev/ttyUSB3"), 115_200));
    // Steering, throttle, four wheels, an aux servo and a relay.
    let servos: Vec<u8> = agv.pwm.outputs.iter().map(|o| o.servo).collect();
    assert_eq!(servos, [1, 3, 5, 6, 7, 8, 9, 10]);
    assert_eq!(agv.pwm.period_us, 20_000);
    assert!(matches!(agv.mavlink[0], Endpoint::Serial { baud: 57_600, .. }));
    assert!(matches!(agv.mavlink[1], Endpoint::UdpOut { port: 14_550, .. }));
    assert_eq!(agv.mavlink.len(), 2);

    let summary = agv.summary();
    assert!(
        !summary.contains("change-me"),
        "the summary shows the NTRIP password:\n{summary}"
    );
    assert!(
        !summary.contains("change-me-too"),
        "the summary shows the broker password:\n{summary}"
    );
    // One line per device: vehicle, gnss, heading, corrections, ntrip, 2 scanners, magnetic, imu, 8 outputs, 2 links;
    // VDA 5050: the broker, its map frame, its user, 3 actions.
    assert_eq!(summary.lines().count(), 25, "{summary}");
    let fleet = agv.vda5050.as_ref().unwrap_or_else(|| panic!("no [vda5050]"));
    assert_eq!(fleet.broker.to_string(), "mqtt://fleet.example.net:1883");
    assert_eq!(fleet.prefix.topic(vda5050::Topic::State), "uagv/v2/Furrow/agv07/state");
    assert_eq!(
        (fleet.agent.map_id.as_str(), fleet.agent.map_version.as_str()),
        ("yard-2", "2026-11")
    );
    let types: Vec<&str> = fleet.agent.mappings.iter().map(|m| m.action_type.as_str()).collect();
    assert_eq!(types, ["pick", "drop", "beaconOn"]);
    assert!(fleet.mqtt().is_ok_and(|m| m.tls.is_none() && m.credentials.is_some()));
}

#[test]
fn differential_example_loads_with_every_device() {
    let dir = examples_dir();
    let rover = config::load(&dir.join("differential-rover.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rover.frame, Frame::Differential);
    assert_eq!(
        rover.gnss.link,
        GnssLink::Tcp(HostPort {
            host: "192.168.2.20".into(),
            port: 5017
        })
    );
    assert_eq!(
        rover.heading,
        HeadingSource::Compass(SerialLine {
            path: "/dev/ttyUSB1".into(),
            baud: 4800
        })
    );
    assert!(rover.corrections.mavlink && rover.corrections.ntrip.is_none());
    assert!(rover.scanners.is_empty() && rover.magnetic.is_none());
    assert_eq!(
        rover.pwm.outputs,
        [
            PwmOutputSetting {
                servo: 1,
                chip: 0,
                channel: 0
            },
            PwmOutputSetting {
                servo: 3,
                chip: 0,
                channel: 1
            }
        ]
    );
    assert!(matches!(rover.mavlink[0], Endpoint::UdpOut { .. }));
    assert!(matches!(rover.mavlink[1], Endpoint::TcpServer { port: 5760, .. }));
}

#[test]
fn a_minimal_file_gets_the_documented_defaults() {
    let text = "[vehicle]\nframe = \"ackermann\"\n[gnss]\nserial = \"/dev/ttyACM0\"\n";
    let c = parse(text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(c.data_dir, Path::new(BASE_DIR).join(config::DEFAULT_DATA_DIR));
    assert_eq!(
        c.gnss.link,
        GnssLink::Serial(SerialLine {
            path: "/dev/ttyACM0".into(),
            baud: config::DEFAULT_GNSS_BAUD
        })
    );
    assert_eq!(c.gnss.stale_ms, config::DEFAULT_GNSS_STALE_MS);
    assert_eq!(c.heading, HeadingSource::Gnss);
    assert!(c.corrections.mavlink && c.corrections.ntrip.is_none());
    assert_eq!(c.pwm.root, Path::new(config::DEFAULT_PWM_ROOT));
    assert_eq!(c.pwm.period_us, config::DEFAULT_PWM_PERIOD_US);
    assert!(c.pwm.outputs.is_empty() && c.mavlink.is_empty() && c.scanners.is_empty());

    let ntrip = parse(&format!(
        "{text}[corrections.ntrip]\nhost = \"caster\"\nmountpoint = \"M\"\n[pwm]\nroot = \"fake/pwm\"\n"
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    let n = ntrip.corrections.ntrip.unwrap_or_else(|| panic!("no ntrip"));
    assert_eq!(
        (n.port, n.version, n.gga_interval.as_secs()),
        (2101, NtripVersion::V2, 10)
    );
    assert_eq!((n.user, n.password), (None, None));
    // Relative to the config file's directory.
    assert_eq!(ntrip.pwm.root, Path::new(BASE_DIR).join("fake/pwm"));
}

const HEAD: &str = "[vehicle]\nframe = \"ackermann\"\n\n";
const GNSS: &str = "[gnss]\nserial = \"/dev/ttyUSB0\"\n\n";

#[test]
fn unknown_keys_are_named_with_their_line() {
    expect_error_at_mark(
        &format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\nbauds = 9600 # <-\n"),
        "gnss.bauds",
        "unknown key `bauds`",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[lidar] # <-\naddress = \"a:1\"\n"),
        "lidar",
        "unknown key",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[[scanner]]\naddress = \"a:2111\"\n[[scanner]]\nadress = \"b:2111\" # <-\n"),
        "scanner[1].adress",
        "unknown key",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[corrections.ntrip]\nhost = \"c\"\nmountpoint = \"M\"\npasswd = \"x\" # <-\n"),
        "corrections.ntrip.passwd",
        "unknown key",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[pwm]\n[[pwm.output]]\nservo = 1\nchip = 0\nchannel = 0\npin = 4 # <-\n"),
        "pwm.output[0].pin",
        "unknown key",
    );
}

#[test]
fn wrong_types_are_named_with_their_line() {
    expect_error_at_mark(
        &format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\nbaud = \"fast\" # <-\n"),
        "gnss.baud",
        "expected an integer",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[corrections]\nmavlink = \"yes\" # <-\n"),
        "corrections.mavlink",
        "expected true or false",
    );
    expect_error_at_mark(
        "[vehicle]\nframe = \"tank\" # <-\n[gnss]\ntcp = \"a:1\"\n",
        "vehicle.frame",
        "ackermann",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[heading]\nsource = \"magnetometer\" # <-\n"),
        "heading.source",
        "compass",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[[mavlink]]\nendpoint = \"udp:a:1\"\n[[mavlink]]\nendpoint = 14550 # <-\n"),
        "mavlink[1].endpoint",
        "invalid type",
    );
}

#[test]
fn bad_baud_rates_are_named_with_their_line() {
    for baud in ["11520", "0", "-9600", "5000000"] {
        expect_error_at_mark(
            &format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\nbaud = {baud} # <-\n"),
            "gnss.baud",
            "not a standard baud rate",
        );
    }
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[heading]\nsource = \"compass\"\nserial = \"/dev/ttyS2\"\nbaud = 4700 # <-\n"),
        "heading.baud",
        "4700",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[magnetic]\nserial = \"/dev/ttyS3\"\nbaud = 19201 # <-\n"),
        "magnetic.baud",
        "19201",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[[mavlink]]\nendpoint = \"serial:/dev/ttyAMA0:57601\" # <-\n"),
        "mavlink[0].endpoint",
        "57601",
    );
}

#[test]
fn every_listed_baud_rate_is_accepted_and_near_misses_are_not() {
    for baud in BAUD_RATES {
        let c = parse(&format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\nbaud = {baud}\n"))
            .unwrap_or_else(|e| panic!("{baud}: {e}"));
        assert!(matches!(c.gnss.link, GnssLink::Serial(SerialLine { baud: b, .. }) if b == baud));
        for near in [baud - 1, baud + 1, baud / 10]
            .into_iter()
            .filter(|n| !BAUD_RATES.contains(n))
        {
            assert!(
                parse(&format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\nbaud = {near}\n")).is_err(),
                "{near} accepted"
            );
        }
    }
}

#[test]
fn missing_or_ambiguous_gnss_is_an_error() {
    let err = expect_error(HEAD, "gnss", "missing section [gnss]");
    assert_eq!(err.line, None, "a missing section has no line: {err}");
    let err = expect_error("[gnss]\ntcp = \"a:1\"\n", "vehicle", "missing section [vehicle]");
    assert_eq!(err.line, None, "a missing section has no line: {err}");

    expect_error_at_mark(
        &format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\ntcp = \"10.0.0.2:5017\" # <-\n"),
        "gnss.tcp",
        "not both",
    );
    expect_error_at_mark(
        &format!("{HEAD}[gnss]\ntcp = \"10.0.0.2:5017\"\nserial = \"/dev/ttyUSB0\" # <-\n"),
        "gnss.serial",
        "not both",
    );
    expect_error_at_mark(&format!("{HEAD}[gnss] # <-\nstale_ms = 500\n"), "gnss", "no receiver");
    expect_error_at_mark(
        &format!("{HEAD}[gnss]\ntcp = \"10.0.0.2:5017\"\nbaud = 9600 # <-\n"),
        "gnss.baud",
        "tcp",
    );
    expect_error_at_mark(
        &format!("{HEAD}[gnss]\ntcp = \"10.0.0.2\" # <-\n"),
        "gnss.tcp",
        "HOST:PORT",
    );
    expect_error_at_mark(
        &format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\nstale_ms = 5 # <-\n"),
        "gnss.stale_ms",
        "out of range",
    );
    expect_error_at_mark(
        "[gnss]\ntcp = \"a:1\"\n[vehicle] # <-\ndata_dir = \"d\"\n",
        "vehicle",
        "missing key `frame`",
    );
}

#[test]
fn duplicate_outputs_are_errors_at_the_second_one() {
    let output = |servo: u32, chip: u32, channel: u32, mark: &str| {
        format!("[[pwm.output]]\nservo = {servo} {mark}\nchip = {chip}\nchannel = {channel} {mark}\n")
    };
    let mut text = format!("{HEAD}{GNSS}");
    text += &output(1, 0, 0, "");
    text += &output(3, 0, 1, "");
    let servo_clash = format!("{text}[[pwm.output]]\nservo = 1 # <-\nchip = 1\nchannel = 0\n");
    expect_error_at_mark(
        &servo_clash,
        "pwm.output[2].servo",
        "SERVO1 already goes out on pwm.output[0]",
    );
    let channel_clash = format!("{text}[[pwm.output]]\nservo = 5\nchip = 0\nchannel = 1 # <-\n");
    expect_error_at_mark(
        &channel_clash,
        "pwm.output[2].channel",
        "pwmchip0/pwm1 is already used by pwm.output[1]",
    );
    let missing = format!("{text}[[pwm.output]] # <-\nservo = 5\nchip = 0\n");
    expect_error_at_mark(&missing, "pwm.output[2]", "missing key `channel`");
    for servo in ["0", "17"] {
        expect_error_at_mark(
            &format!("{text}[[pwm.output]]\nservo = {servo} # <-\nchip = 1\nchannel = 0\n"),
            "pwm.output[2].servo",
            "out of range 1..=16",
        );
    }
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[pwm]\nperiod_us = 1000 # <-\n"),
        "pwm.period_us",
        "out of range",
    );
}

#[test]
fn bad_endpoints_are_named_with_their_line() {
    for spec in [
        "udp:gcs",
        "ftp:gcs:21",
        "tcp::5760",
        "udp:gcs:99999",
        "serial:ttyUSB0:57600",
    ] {
        let text =
            format!("{HEAD}{GNSS}[[mavlink]]\nendpoint = \"udp:a:1\"\n\n[[mavlink]]\nendpoint = \"{spec}\" # <-\n");
        expect_error_at_mark(&text, "mavlink[1].endpoint", "");
    }
}

#[test]
fn devices_scanners_and_ntrip_are_checked() {
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[magnetic]\nserial = \"/dev/ttyUSB0\" # <-\nbaud = 115200\n"),
        "magnetic.serial",
        "already used by gnss.serial (line 5)",
    );
    // Sections are checked in a fixed order; the later line in the file is blamed.
    expect_error_at_mark(
        &format!(
            "{HEAD}{GNSS}[[mavlink]]\nendpoint = \"serial:/dev/ttyS1:57600\"\n[magnetic]\nserial = \"/dev/ttyS1\" # <-\nbaud = 9600\n"
        ),
        "magnetic.serial",
        "already used by mavlink[0].endpoint (line 8)",
    );
    expect_error_at_mark(
        &format!("{HEAD}[gnss]\nserial = \"ttyUSB0\" # <-\n"),
        "gnss.serial",
        "not absolute",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[heading]\nsource = \"compass\" # <-\nbaud = 4800\n"),
        "heading.serial",
        "needs serial",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[heading]\nsource = \"gnss\"\nserial = \"/dev/ttyS1\" # <-\n"),
        "heading.serial",
        "only with source",
    );
    let scanner = |address: &str, mark: &str| format!("[[scanner]]\naddress = \"{address}\" {mark}\n");
    let three = format!(
        "{HEAD}{GNSS}{}{}{}",
        scanner("10.0.0.1:2111", ""),
        scanner("10.0.0.2:2111", ""),
        scanner("10.0.0.3:2111", "# <-")
    );
    expect_error_at_mark(&three, "scanner[2].address", "at most 2");
    let twice = format!(
        "{HEAD}{GNSS}{}{}",
        scanner("10.0.0.1:2111", ""),
        scanner("10.0.0.1:2111", "# <-")
    );
    expect_error_at_mark(&twice, "scanner[1].address", "already scanner[0]");
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}{}", scanner("10.0.0.1", "# <-")),
        "scanner[0].address",
        "HOST:PORT",
    );

    let ntrip = format!("{HEAD}{GNSS}[corrections.ntrip]\nhost = \"caster\"\nmountpoint = \"M\"\n");
    expect_error_at_mark(
        &format!("{ntrip}version = 3 # <-\n"),
        "corrections.ntrip.version",
        "1 or 2",
    );
    expect_error_at_mark(
        &format!("{ntrip}port = 0 # <-\n"),
        "corrections.ntrip.port",
        "out of range",
    );
    expect_error_at_mark(
        &format!("{ntrip}password = \"p\" # <-\n"),
        "corrections.ntrip.password",
        "without a user",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[corrections.ntrip]\nhost = \"http://caster\" # <-\nmountpoint = \"M\"\n"),
        "corrections.ntrip.host",
        "without scheme",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[corrections.ntrip]\nhost = \"caster\"\nmountpoint = \"/M\" # <-\n"),
        "corrections.ntrip.mountpoint",
        "leading '/'",
    );
    expect_error_at_mark(
        &format!("{HEAD}{GNSS}[corrections.ntrip] # <-\nhost = \"caster\"\n"),
        "corrections.ntrip",
        "missing key `mountpoint`",
    );
}

#[test]
fn syntax_errors_point_at_their_line() {
    let text = format!("{HEAD}{GNSS}[[mavlink]]\nendpoint = \"udp:a:1 # <-\n");
    let err = parse(&text).err().unwrap_or_else(|| panic!("accepted"));
    assert_eq!(err.line, Some(marked_line(&text)), "{err}");
    assert_eq!(err.key, "mavlink[0].endpoint", "{err}");
    expect_error_at_mark(
        &format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\nserial = \"/dev/ttyUSB1\" # <-\n"),
        "gnss.serial",
        "duplicate key",
    );
}

#[test]
fn load_names_the_file() {
    let scratch = tempfile::tempdir().unwrap();
    let dir = scratch.path();
    let path = dir.join("bad.toml");
    std::fs::write(
        &path,
        format!("{HEAD}[gnss]\nserial = \"/dev/ttyUSB0\"\nbaud = 11520\n"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let err = config::load(&path).err().unwrap_or_else(|| panic!("accepted"));
    assert_eq!(err.file.as_deref(), Some(path.as_path()));
    assert!(
        err.to_string()
            .starts_with(&format!("{}:6:8: gnss.baud: ", path.display())),
        "{err}"
    );
    let missing = config::load(&dir.join("absent.toml"))
        .err()
        .unwrap_or_else(|| panic!("accepted"));
    assert!(missing.to_string().contains("cannot read"), "{missing}");
}

#[test]
fn furrow_config_check_exits_0_on_examples_and_1_on_a_bad_file() {
    let furrow = env!("CARGO_BIN_EXE_furrow");
    for example in ["ackermann-agv.toml", "differential-rover.toml"] {
        let out = Command::new(furrow)
            .args(["config", "check"])
            .arg(examples_dir().join(example))
            .output()
            .unwrap_or_else(|e| panic!("{e}"));
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{example}: {stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(stdout.lines().any(|l| l.starts_with("gnss ")), "{stdout}");
        assert!(stdout.lines().any(|l| l.starts_with("mavlink ")), "{stdout}");
    }

    let scratch = tempfile::tempdir().unwrap();
    let dir = scratch.path();
    let bad = dir.join("duplicate.toml");
    let text = format!(
        "{HEAD}{GNSS}[[pwm.output]]\nservo = 1\nchip = 0\nchannel = 0\n[[pwm.output]]\nservo = 1 # <-\nchip = 0\nchannel = 1\n"
    );
    std::fs::write(&bad, &text).unwrap_or_else(|e| panic!("{e}"));
    let out = Command::new(furrow)
        .args(["config", "check"])
        .arg(&bad)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let expected = format!("{}:{}:", bad.display(), marked_line(&text));
    assert!(stderr.contains(&expected), "{stderr} lacks {expected}");
    assert!(stderr.contains("pwm.output[1].servo"), "{stderr}");
    assert!(out.stdout.is_empty(), "{}", String::from_utf8_lossy(&out.stdout));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any set of outputs is accepted exactly when no servo and no
    /// (chip, channel) repeats; the error names the first repeating entry.
    #[test]
    fn outputs_are_accepted_iff_unique(outputs in prop::collection::vec((1u8..=16, 0u32..3, 0u32..4), 0..10)) {
        let mut text = format!("{HEAD}{GNSS}");
        for (servo, chip, channel) in &outputs {
            text += &format!("[[pwm.output]]\nservo = {servo}\nchip = {chip}\nchannel = {channel}\n");
        }
        let first_clash = (0..outputs.len()).find(|&i| {
            outputs[..i].iter().any(|o| o.0 == outputs[i].0 || (o.1, o.2) == (outputs[i].1, outputs[i].2))
        });
        match (parse(&text), first_clash) {
            (Ok(c), None) => {
                let got: Vec<_> = c.pwm.outputs.iter().map(|o| (o.servo, o.chip, o.channel)).collect();
                prop_assert_eq!(got, outputs);
            }
            (Err(e), Some(i)) => {
                prop_assert!(e.key.starts_with(&format!("pwm.output[{i}].")), "{}", e);
                // The header of entry i, plus one or three lines in.
                let header = HEAD.lines().count() + GNSS.lines().count() + 1 + 4 * i;
                prop_assert!(e.line == Some(header + 1) || e.line == Some(header + 3), "{}", e);
            }
            (Ok(_), Some(i)) => prop_assert!(false, "clash at {} accepted", i),
            (Err(e), None) => prop_assert!(false, "rejected: {}", e),
        }
    }
}

const VDA: &str = "[vda5050]\nbroker = \"mqtt://127.0.0.1:1883\"\nserial_number = \"agv1\"\n";

#[test]
fn a_minimal_vda5050_section_gets_the_documented_defaults() {
    let c = parse(&format!("{HEAD}{GNSS}{VDA}")).unwrap_or_else(|e| panic!("{e}"));
    let v = c.vda5050.unwrap_or_else(|| panic!("no [vda5050]"));
    assert_eq!(
        (v.broker.host.as_str(), v.broker.port, v.broker.tls),
        ("127.0.0.1", 1883, false)
    );
    assert_eq!(v.prefix.topic(vda5050::Topic::Order), "uagv/v2/Furrow/agv1/order");
    assert_eq!(v.client_id, "Furrow-agv1");
    assert_eq!(v.credentials, None);
    let defaults = AgentConfig::default();
    assert_eq!(v.agent, defaults, "map, rates and the pick/drop mapping");
    assert!(parse(&format!("{HEAD}{GNSS}")).is_ok_and(|c| c.vda5050.is_none()));
}

#[test]
fn vda5050_mistakes_are_named_with_their_line() {
    let cases: [(&str, &str, &str); 16] = [
        (
            "broker = \"http://x:1\" # <-\nserial_number = \"a\"\n",
            "vda5050.broker",
            "mqtt://",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a/b\" # <-\n",
            "vda5050.serial_number",
            "topic level",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\nmanufacturer = \"A+B\" # <-\n",
            "vda5050.manufacturer",
            "topic level",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\nmap_id = \"\" # <-\n",
            "vda5050.map_id",
            "empty",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\nca_file = \"ca.pem\" # <-\n",
            "vda5050.ca_file",
            "mqtts://",
        ),
        (
            "broker = \"mqtts://x:1\"\nserial_number = \"a\"\nca_file = \"no-such-ca.pem\" # <-\n",
            "vda5050.ca_file",
            "cannot read /srv/vehicle/no-such-ca.pem",
        ),
        (
            "broker = \"mqtts://x:1\"\nserial_number = \"a\"\nclient_cert = \"c.pem\" # <-\n",
            "vda5050.client_key",
            "needs client_key",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\npassword = \"p\" # <-\n",
            "vda5050.password",
            "without a user",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\nstate_interval_s = 31 # <-\n",
            "vda5050.state_interval_s",
            "out of range",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\nvisualization_interval_s = -1.0 # <-\n",
            "vda5050.visualization_interval_s",
            "out of range",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\n[[vda5050.action]]\ntype = \"cancelOrder\" # <-\nrelay = 0\non = true\nduration_s = 1\n",
            "vda5050.action[0].type",
            "vehicle itself",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\n[[vda5050.action]]\ntype = \"lift\"\nservo = 17 # <-\npwm_us = 1500\nduration_s = 1\n",
            "vda5050.action[0].servo",
            "out of range",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\n[[vda5050.action]]\ntype = \"lift\"\nservo = 9 # <-\nduration_s = 1\n",
            "vda5050.action[0].pwm_us",
            "needs pwm_us",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\n[[vda5050.action]]\ntype = \"horn\"\nrelay = 6 # <-\non = true\nduration_s = 1\n",
            "vda5050.action[0].relay",
            "out of range",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\n[[vda5050.action]]\ntype = \"horn\"\nrelay = 1\non = true\nduration_s = 1\n[[vda5050.action]]\ntype = \"horn\" # <-\nrelay = 2\non = true\nduration_s = 1\n",
            "vda5050.action[1].type",
            "already vda5050.action[0]",
        ),
        (
            "broker = \"mqtt://x:1\"\nserial_number = \"a\"\nqos = 2 # <-\n",
            "vda5050.qos",
            "unknown",
        ),
    ];
    for (body, key, fragment) in cases {
        expect_error_at_mark(&format!("{HEAD}{GNSS}[vda5050]\n{body}"), key, fragment);
    }
    let missing = expect_error(
        &format!("{HEAD}{GNSS}[vda5050]\nbroker = \"mqtt://x\"\n"),
        "vda5050",
        "serial_number",
    );
    assert!(missing.line.is_some(), "{missing}");
}

/// Runs openssl in `dir`.
fn openssl(dir: &Path, args: &str) {
    let status = Command::new("openssl")
        .current_dir(dir)
        .args(args.split_whitespace())
        .stderr(std::process::Stdio::null())
        .status()
        .unwrap_or_else(|e| panic!("openssl: {e}"));
    assert!(status.success(), "openssl {args}");
}

/// A CA and a client certificate it signed, plus a key of another pair.
fn make_pki(dir: &Path) {
    let ec = "-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
    openssl(
        dir,
        &format!("req -x509 {ec} -keyout ca.key -out ca.pem -days 2 -subj /CN=test-ca"),
    );
    openssl(dir, &format!("req {ec} -keyout agv.key -out agv.csr -subj /CN=agv1"));
    // Extensions make it an X.509 v3 certificate, the only version rustls takes.
    std::fs::write(dir.join("v3.ext"), "basicConstraints=CA:FALSE\n").unwrap_or_else(|e| panic!("{e}"));
    openssl(
        dir,
        "x509 -req -in agv.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out agv.pem -days 2 -extfile v3.ext",
    );
    openssl(
        dir,
        &format!("req {ec} -keyout other.key -out other.csr -subj /CN=other"),
    );
}

#[test]
fn an_mqtts_broker_takes_a_ca_and_a_client_certificate_that_go_together() {
    let scratch = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let dir = scratch.path();
    make_pki(dir);
    let section = |key_file: &str| {
        format!(
            "{HEAD}{GNSS}[vda5050]\nbroker = \"mqtts://127.0.0.1\"\nserial_number = \"agv1\"\n\
             ca_file = \"ca.pem\"\nclient_cert = \"agv.pem\"\nclient_key = \"{key_file}\" # <-\n\
             username = \"agv1\"\n"
        )
    };
    let good = config::parse(&section("agv.key"), dir).unwrap_or_else(|e| panic!("{e}"));
    let v = good.vda5050.unwrap_or_else(|| panic!("no [vda5050]"));
    assert_eq!((v.broker.port, v.broker.tls), (8883, true));
    assert_eq!(v.tls.ca_file.as_deref(), Some(dir.join("ca.pem").as_path()));
    assert_eq!(v.credentials, Some(("agv1".into(), String::new())));
    let mqtt = v.mqtt().unwrap_or_else(|e| panic!("{e}"));
    assert!(mqtt.tls.is_some());

    let text = section("other.key");
    let e = config::parse(&text, dir)
        .err()
        .unwrap_or_else(|| panic!("a key of another pair accepted"));
    assert_eq!(
        (e.key.as_str(), e.line),
        ("vda5050.client_key", Some(marked_line(&text))),
        "{e}"
    );
    let text = section("ca.pem");
    let e = config::parse(&text, dir)
        .err()
        .unwrap_or_else(|| panic!("a certificate as a key accepted"));
    assert!(e.message.contains("no private key"), "{e}");
}
