//! Bytes from a ground station, as a TCP or serial link delivers them:
//! framing (MAVLink 1 and 2, garbage, bad CRCs), routing, decoding, and the
//! core's handlers (mission, parameter and command protocols, modes, GUIDED
//! targets…) with the vehicle stepped in between.
//!
//! Input: byte 0 is a chunk size, the rest the stream. Properties: framing
//! does not depend on how the stream is chunked; every command addressed to
//! the vehicle gets exactly one COMMAND_ACK.
#![no_main]

use autopilot::link::frame::{FrameStats, StreamFramer};
use furrow_fuzz::FuzzVehicle;
use libfuzzer_sys::fuzz_target;

/// The frames (their bytes) and counters of `stream` pushed `chunk` bytes
/// at a time.
fn frame_all(stream: &[u8], chunk: usize) -> (Vec<Vec<u8>>, FrameStats) {
    let mut framer = StreamFramer::new();
    let mut frames = Vec::new();
    for part in stream.chunks(chunk.max(1)) {
        framer.push(part, |f| frames.push(f.bytes().to_vec()));
    }
    (frames, framer.stats())
}

fuzz_target!(|data: &[u8]| {
    let Some((&chunk, stream)) = data.split_first() else {
        return;
    };
    let whole = frame_all(stream, stream.len());
    let chunked = frame_all(stream, usize::from(chunk));
    assert_eq!(whole, chunked, "framing must not depend on chunking");

    // The vehicle is made per input (README.md, "Fuzzing", has its cost), so a
    // finding reproduces from its input alone.
    let mut vehicle = FuzzVehicle::new();
    let mut framer = StreamFramer::new();
    for part in stream.chunks(usize::from(chunk).max(1)) {
        let mut frames = Vec::new();
        framer.push(part, |f| frames.push(f));
        for frame in frames {
            vehicle.deliver_frame(frame);
        }
        vehicle.service();
        // A tick between chunks: streams, mission timeouts, mode logic.
        vehicle.steps(1);
    }
    vehicle.steps(5);
});
