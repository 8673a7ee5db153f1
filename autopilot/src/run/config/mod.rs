//! The vehicle configuration file of `furrow run --config FILE`: which
//! devices the real vehicle has and where they are plugged in. Tuning lives
//! in the parameters (SERVOn_*, SYSID_THISMAV, …), never here: this file only
//! says what hardware exists, so one parameter set can move between vehicles
//! wired differently.
//!
//! Rules the checks enforce (the examples in `autopilot/examples/*.toml`
//! explain every key):
//! - Unknown keys are errors, so a typo never silently falls back to a default.
//! - Every error names the key (`pwm.output[2].servo`, 0-based indices for
//!   arrays of tables; for a missing key, the table that lacks it) and the
//!   line, as `FILE:LINE:COLUMN: KEY: message`.
//! - Baud rates must be one of [`BAUD_RATES`]: the rates Linux sets through
//!   plain termios (no custom divisors). A list rather than a range catches
//!   the usual typos (11520, 15200) before the port opens and stays silent.
//! - Device paths (`serial = …`) must be absolute: a relative device path
//!   would depend on the directory `furrow` happens to be started from.
//! - `data_dir` and `pwm.root` are relative to the config file's directory, so
//!   a vehicle's config and its data can move together.
//! - One device path serves one purpose: the same port given twice is an error.
//! - `[gnss]` is the only required section.

//!
//! - [`types`]: the validated configuration the runner uses;
//! - [`checks`]: the file as written (with spans) and the checks that turn
//!   it into those types;
//! - [`error`]: [`ConfigError`], placed by the workspace's one TOML error
//!   locator (`toml_report`).

mod checks;
mod error;
mod types;

use std::path::Path;

pub use error::ConfigError;
pub use types::*;

/// Reads and checks a config file.
pub fn load(path: &Path) -> Result<VehicleConfig, ConfigError> {
    let with_file = |mut e: ConfigError| {
        e.file = Some(path.to_path_buf());
        e
    };
    let text = std::fs::read_to_string(path)
        .map_err(|e| with_file(ConfigError::whole_file("", format!("cannot read: {e}"))))?;
    let base_dir = path.parent().unwrap_or(Path::new(""));
    parse(&text, base_dir).map_err(with_file)
}

/// Checks config text; relative paths are resolved against `base_dir`.
pub fn parse(text: &str, base_dir: &Path) -> Result<VehicleConfig, ConfigError> {
    checks::check(text, base_dir)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::endpoint::Endpoint;

    #[test]
    fn a_nul_in_any_path_is_refused() {
        let base = "[vehicle]\nframe = \"ackermann\"\n[gnss]\nserial = \"/dev/ttyUSB0\"\n";
        let with_dir = base.replace(
            "frame = \"ackermann\"\n",
            "frame = \"ackermann\"\ndata_dir = \"data\\u0000x\"\n",
        );
        let e = parse(&with_dir, Path::new("/")).unwrap_err().to_string();
        assert!(e.contains("NUL") && e.contains("data_dir"), "{e}");
        let device = base.replace("/dev/ttyUSB0", "/dev/tty\\u0000USB0");
        let e = parse(&device, Path::new("/")).unwrap_err().to_string();
        assert!(e.contains("NUL"), "{e}");
        assert!(parse(base, Path::new("/")).is_ok());
    }

    #[test]
    fn secure_endpoints_are_kept_apart() {
        let text = "[vehicle]\nframe = \"ackermann\"\n[gnss]\nserial = \"/dev/ttyUSB0\"\n\
                    [[mavlink]]\nendpoint = \"tcpin:0.0.0.0:5760\"\n\
                    [[mavlink]]\nendpoint = \"serial:/dev/ttyACM0:115200\"\nsecure = true\n\
                    [[mavlink]]\nendpoint = \"udp:10.0.0.1:14550\"\nsecure = false\n";
        let config = parse(text, Path::new("/")).expect("parses");
        assert_eq!(config.mavlink.len(), 2);
        assert_eq!(
            config.secure_mavlink,
            vec![Endpoint::Serial {
                device: "/dev/ttyACM0".into(),
                baud: 115_200
            }]
        );
        assert!(config.summary().contains("serial:/dev/ttyACM0:115200 (secure"));
        let typo = text.replace("secure = true", "secure = \"yes\"");
        assert!(parse(&typo, Path::new("/")).is_err());
    }
}
