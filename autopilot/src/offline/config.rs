//! `furrow config check FILE`: validates a vehicle configuration (the file
//! `furrow run --config` reads) without touching any device, and lists the
//! devices it describes.

use std::path::PathBuf;

use crate::run::config;

#[derive(clap::Subcommand, Debug)]
pub enum ConfigAction {
    /// Checks FILE and prints one line per device; exit status 1 with the first error otherwise.
    Check { file: PathBuf },
}

pub fn run(action: &ConfigAction) -> Result<(), String> {
    match action {
        ConfigAction::Check { file } => {
            let vehicle = config::load(file).map_err(|e| e.to_string())?;
            println!("{}: ok", file.display());
            println!("{}", vehicle.summary());
            Ok(())
        }
    }
}
