//! SICK CoLa-A from a laser scanner (`drivers::scanner::cola`): the STX/ETX
//! framer, the telegram sorter and the `LMDscandata` parser.
//!
//! Input: byte 0 is a chunk size, the rest the stream. Properties: framing
//! does not depend on chunking (beyond the documented overrun of telegrams
//! left unpopped); a scan telegram
//! that parses, written back by `encode_lmd_scandata`, parses to the same
//! telegram; its scan has one range per beam, each NaN or finite.
#![no_main]

use std::time::Duration;

use drivers::scanner::cola::{
    ColaFramer, ColaTelegram, FramerStats, encode_lmd_scandata, parse_lmd_scandata, parse_telegram,
};
use libfuzzer_sys::fuzz_target;

fn frame_all(stream: &[u8], chunk: usize) -> (Vec<Vec<u8>>, FramerStats) {
    let mut framer = ColaFramer::new();
    let mut telegrams = Vec::new();
    for part in stream.chunks(chunk.max(1)) {
        framer.push(part);
        while let Some(t) = framer.pop() {
            telegrams.push(t);
        }
    }
    (telegrams, framer.stats())
}

fuzz_target!(|data: &[u8]| {
    let Some((&chunk, stream)) = data.split_first() else {
        return;
    };
    // Byte by byte, popping as it goes, the framer never overruns its
    // queue: the reference. In bigger chunks it may drop telegrams the
    // caller did not pop (counted as overrun), and nothing else differs.
    let whole = frame_all(stream, 1);
    let chunked = frame_all(stream, usize::from(chunk));
    let (w, c) = (whole.1, chunked.1);
    assert_eq!(
        (w.telegrams, w.skipped_bytes, w.oversized, w.overrun),
        (c.telegrams, c.skipped_bytes, c.oversized, w.overrun),
        "framing depends on chunking"
    );
    if c.overrun == 0 {
        assert_eq!(whole.0, chunked.0, "framing depends on chunking");
    }

    // Each telegram, and the raw input as one telegram (the parsers take
    // one with or without STX/ETX).
    for telegram in whole.0.iter().map(Vec::as_slice).chain([stream]) {
        let sorted = parse_telegram(telegram);
        let scan = parse_lmd_scandata(telegram);
        if let Ok(ColaTelegram::ScanData(s)) = &sorted {
            assert_eq!(
                scan.as_ref().ok(),
                Some(s.as_ref()),
                "parse_telegram and parse_lmd_scandata disagree"
            );
        }
        let Ok(scan) = scan else {
            continue;
        };
        if scan.encoders.len() <= usize::from(u16::MAX) && scan.dist_raw.len() <= usize::from(u16::MAX) {
            let again = parse_lmd_scandata(&encode_lmd_scandata(&scan));
            assert_eq!(
                again.as_ref(),
                Ok(&scan),
                "written back, the telegram reads differently"
            );
        }
        let converted = scan.to_scan(Duration::ZERO);
        assert_eq!(converted.ranges_m.len(), scan.dist_raw.len());
        assert!(
            converted
                .ranges_m
                .iter()
                .all(|r| r.is_nan() || (r.is_finite() && *r >= 0.0))
        );
        assert!(converted.start_angle_rad.is_finite() && converted.step_rad.is_finite());
    }
});
