//! The real vehicle's config file (`furrow run --config`, TOML):
//! `autopilot::run::config::parse`, as `furrow config check` runs it.
//!
//! Properties: a config that parses gives a summary, and the summary never
//! depends on the NTRIP password (it must not show it).
#![no_main]

use std::path::Path;

use autopilot::run::config::parse;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(config) = parse(text, Path::new("/furrow-fuzz")) else {
        return;
    };
    let summary = config.summary();
    let mut other = config.clone();
    if let Some(ntrip) = other.corrections.ntrip.as_mut()
        && let Some(password) = ntrip.password.as_mut()
    {
        *password = format!("{password}-other");
        assert_eq!(other.summary(), summary, "the summary shows the NTRIP password");
    }
});
