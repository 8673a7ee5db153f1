//! The `furrow sitl --fleet N` child process: started, waited for, watched
//! (CPU time and RSS from /proc), stopped with SIGINT for its exit report.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

/// `/proc/PID/stat` counts CPU time in clock ticks of 1/100 s (USER_HZ).
const TICKS_PER_S: f64 = 100.0;

pub struct FleetProcess {
    child: Child,
    stderr_path: std::path::PathBuf,
    // Kept open: a closed stdout would make a later print fail in the child.
    _stdout: BufReader<ChildStdout>,
}

impl FleetProcess {
    /// `furrow sitl --fleet N` with `args`, waited for until every vehicle
    /// is listening.
    pub fn start(exe: &Path, count: usize, args: &[String], dir: &Path) -> Result<FleetProcess, String> {
        let stderr_path = dir.join(format!("fleet-{count}.log"));
        let stderr = std::fs::File::create(&stderr_path).map_err(|e| format!("{}: {e}", stderr_path.display()))?;
        let mut child = Command::new(exe)
            .args(["sitl", "--fleet", &count.to_string()])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(stderr)
            .spawn()
            .map_err(|e| format!("starting {} sitl --fleet {count}: {e}", exe.display()))?;
        let mut stdout = BufReader::new(child.stdout.take().ok_or("no stdout")?);
        let mut line = String::new();
        loop {
            line.clear();
            let read = stdout.read_line(&mut line).map_err(|e| e.to_string())?;
            if line.starts_with("furrow sitl fleet ready") {
                break;
            }
            if read == 0 {
                let _ = child.kill();
                let _ = child.wait();
                let log = std::fs::read_to_string(&stderr_path).unwrap_or_default();
                return Err(format!("furrow sitl --fleet {count} did not start: {}", log.trim()));
            }
        }
        Ok(FleetProcess {
            child,
            stderr_path,
            _stdout: stdout,
        })
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// User + system CPU seconds used so far.
    pub fn cpu_s(&self) -> f64 {
        cpu_s(self.pid())
    }

    /// Resident memory now, kB.
    pub fn rss_kb(&self) -> u64 {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.pid())).unwrap_or_default();
        status
            .lines()
            .find(|l| l.starts_with("VmRSS:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(0)
    }

    /// Threads of the process now.
    pub fn threads(&self) -> usize {
        std::fs::read_dir(format!("/proc/{}/task", self.pid())).map_or(0, Iterator::count)
    }

    /// SIGINT, then its exit report's simulated and wall seconds.
    pub fn stop(mut self) -> Result<(f64, f64), String> {
        let _ = Command::new("kill").args(["-INT", &self.pid().to_string()]).status();
        let deadline = Instant::now() + Duration::from_secs(30);
        while self.child.try_wait().map_err(|e| e.to_string())?.is_none() {
            if Instant::now() > deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                return Err("the fleet did not stop within 30 s of SIGINT".into());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let log = std::fs::read_to_string(&self.stderr_path).unwrap_or_default();
        let report = log
            .lines()
            .find_map(|l| l.split(" stopped after ").nth(1))
            .ok_or_else(|| format!("no exit report in {}", self.stderr_path.display()))?;
        let number = |text: &str| text.trim().split(' ').next().and_then(|v| v.parse::<f64>().ok());
        let simulated = number(report);
        let wall = report.split(" simulated in ").nth(1).and_then(number);
        simulated
            .zip(wall)
            .ok_or_else(|| format!("unreadable exit report {report:?}"))
    }
}

impl Drop for FleetProcess {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// User + system CPU seconds of process `pid` so far (0 if gone).
pub fn cpu_s(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // The command name may hold spaces: fields count from after its ')'.
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map_or("", |(_, rest)| rest)
        .split_whitespace()
        .collect();
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    // utime and stime are fields 14 and 15 of the line, 12 and 13 here.
    (ticks(11) + ticks(12)) / TICKS_PER_S
}
