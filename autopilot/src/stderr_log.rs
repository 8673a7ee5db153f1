//! The log every Furrow binary writes: to stderr (stdout carries what a
//! script reads, such as the `ready` line), filtered by `RUST_LOG`
//! (default `info`), coloured only on a terminal.
//!
//! `RUST_LOG` takes target directives (`debug`, `info,autopilot::link=trace`).
//! They are parsed by `filter::Targets`, not `EnvFilter`: the span and field
//! filters `EnvFilter` adds need the regex engine, about 270 kB of code that
//! every process would carry in memory for a feature nobody here uses.

use tracing_subscriber::filter::{LevelFilter, Targets};
use tracing_subscriber::prelude::*;

pub fn init() {
    let (filter, bad_directives) = filter_from_env();
    tracing_subscriber::registry()
        .with(
            tracing_subscriber::fmt::layer()
                .with_writer(std::io::stderr)
                .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr())),
        )
        .with(filter)
        .init();
    if let Some(error) = bad_directives {
        tracing::warn!("RUST_LOG ignored ({error}); logging at info");
    }
}

/// The filter `RUST_LOG` asks for, or `info` with the reason it was refused.
fn filter_from_env() -> (Targets, Option<String>) {
    let default = Targets::new().with_default(LevelFilter::INFO);
    match std::env::var("RUST_LOG") {
        Ok(directives) if !directives.trim().is_empty() => match directives.parse::<Targets>() {
            Ok(filter) => (filter, None),
            Err(error) => (default, Some(format!("{directives:?}: {error}"))),
        },
        _ => (default, None),
    }
}
