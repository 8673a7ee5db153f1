//! `LOG_*`: whether and how much the vehicle logs (ArduPilot's names where
//! they exist).

use params::{ParamTable, declare_params};

use super::FileLimits;

declare_params! {
    /// Onboard DataFlash logs in the data directory's `logs/` folder.
    pub struct LogParams {
        backend: u8 = "LOG_BACKEND_TYPE" => {
            default: 1, range: 0, 1, unit: "",
            desc: "Onboard log: 0 none, 1 files in the data directory's logs/ folder",
        },
        disarmed: u8 = "LOG_DISARMED" => {
            default: 0, range: 0, 1, unit: "",
            desc: "1: log while disarmed too (a file per disarmed period); 0: log only while armed. Every arming starts a new file",
        },
        rate_max_hz: f32 = "LOG_FILE_RATEMAX" => {
            default: 0.0, range: 0.0, 400.0, unit: "Hz",
            desc: "Most often the per-tick records (POS, ATT, NTUN, PIDs…) are written (0: every tick)",
        },
        max_files: i16 = "LOG_MAX_FILES" => {
            default: 500, range: 2, 500, unit: "",
            desc: "Most log files kept: the oldest are removed when a new one starts",
        },
        file_max_mb: i16 = "LOG_FILE_MAXMB" => {
            default: 256, range: 0, 4000, unit: "MB",
            desc: "A log file reaching this size is closed and the log continues in a new one (0: no limit)",
        },
    }
}

impl LogParams {
    pub fn enabled(&self, table: &ParamTable) -> bool {
        self.backend.get(table) & 1 != 0
    }

    pub fn limits(&self, table: &ParamTable) -> FileLimits {
        FileLimits {
            max_files: self.max_files.get(table).clamp(2, 500) as u16,
            max_bytes: u64::try_from(self.file_max_mb.get(table).max(0)).unwrap_or(0) * 1_000_000,
        }
    }
}
