//! The telemetry log MAVProxy, MAVExplorer and `mavlogdump.py` read: each
//! frame preceded by its wall-clock time as a big-endian u64 of µs since
//! the Unix epoch.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use tokio::sync::mpsc;

/// One frame to record.
pub struct TlogRecord {
    pub unix_us: u64,
    pub bytes: Vec<u8>,
}

impl TlogRecord {
    pub fn now(bytes: Vec<u8>) -> Self {
        let unix_us = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_micros() as u64);
        TlogRecord { unix_us, bytes }
    }
}

/// Appends a record in tlog layout.
pub fn write_record(out: &mut impl Write, record: &TlogRecord) -> io::Result<()> {
    out.write_all(&record.unix_us.to_be_bytes())?;
    out.write_all(&record.bytes)
}

/// Creates (truncates) the file and returns the task that fills it. The
/// file is flushed every second so a crash loses at most that much.
pub fn open(path: &Path) -> io::Result<(mpsc::Sender<TlogRecord>, impl std::future::Future<Output = ()> + use<>)> {
    let file = File::create(path)?;
    let (tx, mut rx) = mpsc::channel::<TlogRecord>(8192);
    let path = path.display().to_string();
    let task = async move {
        let mut out = BufWriter::new(file);
        let mut flush = tokio::time::interval(Duration::from_secs(1));
        loop {
            tokio::select! {
                record = rx.recv() => match record {
                    Some(r) => {
                        if let Err(e) = write_record(&mut out, &r) {
                            tracing::error!("tlog {path}: {e}; recording stopped");
                            return;
                        }
                    }
                    None => break,
                },
                _ = flush.tick() => {
                    if let Err(e) = out.flush() {
                        tracing::error!("tlog {path}: {e}; recording stopped");
                        return;
                    }
                }
            }
        }
        let _ = out.flush();
    };
    Ok((tx, task))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn record_layout_is_big_endian_time_then_frame() {
        let mut buf = Vec::new();
        write_record(
            &mut buf,
            &TlogRecord {
                unix_us: 0x0102030405060708,
                bytes: vec![0xfd, 1, 2],
            },
        )
        .unwrap();
        assert_eq!(buf, vec![1, 2, 3, 4, 5, 6, 7, 8, 0xfd, 1, 2]);
    }
}
