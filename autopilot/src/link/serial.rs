//! A serial link (telemetry radio). The port is blocking, so it gets two
//! threads that bridge to the hub's channels; the core never touches it.

use std::io::{Read, Write};
use std::time::Duration;

use tokio::sync::mpsc;

use super::frame::StreamFramer;
use super::hub::{HubEvent, LinkIds, LinkRole, PeerPolicy, gather, open_link};
use super::pacing::LinkPace;

/// Opens the port, retrying until it exists (a USB radio plugged in later),
/// and serves it; reopens after an unplug.
pub(super) fn spawn(device: String, baud: u32, role: LinkRole, ids: LinkIds, hub: mpsc::Sender<HubEvent>) {
    std::thread::Builder::new()
        .name(format!("serial {device}"))
        .spawn(move || {
            let mut backoff = super::reconnect_backoff();
            loop {
                match serialport::new(&device, baud)
                    .timeout(Duration::from_millis(100))
                    .open()
                {
                    Ok(port) => {
                        tracing::info!("serial {device} at {baud} baud: open");
                        backoff.reset();
                        serve(port, &device, baud, role, ids.next(), &hub);
                        tracing::warn!("serial {device}: closed; reopening");
                    }
                    Err(e) => tracing::debug!("serial {device}: {e}"),
                }
                if hub.is_closed() {
                    return;
                }
                std::thread::sleep(backoff.next_delay());
            }
        })
        .expect("spawn serial thread");
}

fn serve(
    mut port: Box<dyn serialport::SerialPort>,
    device: &str,
    baud: u32,
    role: LinkRole,
    link: crate::vehicle::LinkId,
    hub: &mpsc::Sender<HubEvent>,
) {
    let name = format!("serial {device}");
    let (opened, mut rx, queued) = open_link(link, role, PeerPolicy::FirstFrame, name, LinkPace::Serial { baud });
    if hub.blocking_send(opened).is_err() {
        return;
    }
    let Ok(mut writer_port) = port.try_clone() else {
        let _ = hub.blocking_send(HubEvent::Closed { link });
        return;
    };
    let writer = std::thread::spawn(move || {
        let mut buf = Vec::new();
        while let Some(frame) = rx.blocking_recv() {
            gather(frame, &mut rx, &mut buf);
            if writer_port.write_all(&buf).is_err() {
                return;
            }
            queued.written(buf.len());
        }
    });
    let mut framer = StreamFramer::new();
    let mut buf = [0u8; 1024];
    loop {
        match port.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                let mut frames = Vec::new();
                framer.push(&buf[..n], |f| frames.push(f));
                for frame in frames {
                    if hub
                        .blocking_send(HubEvent::Frame {
                            link,
                            frame,
                            from: None,
                        })
                        .is_err()
                    {
                        return;
                    }
                }
                let _ = hub.try_send(HubEvent::Stats {
                    link,
                    stats: framer.stats(),
                });
            }
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {
                if writer.is_finished() {
                    break;
                }
            }
            Err(_) => break,
        }
    }
    // Dropping the hub's sender (on Closed) ends the writer thread.
    let _ = hub.blocking_send(HubEvent::Closed { link });
    let _ = writer.join();
}
