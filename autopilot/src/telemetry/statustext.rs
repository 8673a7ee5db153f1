//! STATUSTEXT: 50 characters per message; longer texts are split into
//! chunks that share an `id` (MAVLink 2 extension) so a GCS can join them.

use mavlink::dialects::ardupilotmega::{MavSeverity, STATUSTEXT_DATA};

const CHUNK: usize = 50;

/// Splits `text` into STATUSTEXT messages. `next_id` numbers multi-chunk
/// texts (0 means "not chunked", so it is skipped).
pub fn statustext(severity: MavSeverity, text: &str, next_id: &mut u16) -> Vec<STATUSTEXT_DATA> {
    // MAVLink text is ASCII in practice; replace anything else so a GCS never
    // sees a split UTF-8 sequence.
    let bytes: Vec<u8> = text
        .chars()
        .map(|c| {
            if c.is_ascii() && !c.is_ascii_control() {
                c as u8
            } else {
                b'?'
            }
        })
        .collect();
    if bytes.len() <= CHUNK {
        let mut data = [0u8; CHUNK];
        data[..bytes.len()].copy_from_slice(&bytes);
        return vec![STATUSTEXT_DATA {
            severity,
            text: data.into(),
            id: 0,
            chunk_seq: 0,
        }];
    }
    *next_id = next_id.wrapping_add(1).max(1);
    let id = *next_id;
    let mut chunks: Vec<STATUSTEXT_DATA> = bytes
        .chunks(CHUNK)
        .enumerate()
        .map(|(seq, part)| {
            let mut data = [0u8; CHUNK];
            data[..part.len()].copy_from_slice(part);
            STATUSTEXT_DATA {
                severity,
                text: data.into(),
                id,
                chunk_seq: seq as u8,
            }
        })
        .collect();
    if bytes.len().is_multiple_of(CHUNK) {
        // A full last chunk has no NUL: an empty chunk ends the text.
        chunks.push(STATUSTEXT_DATA {
            severity,
            text: [0u8; CHUNK].into(),
            id,
            chunk_seq: chunks.len() as u8,
        });
    }
    chunks
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_text_is_one_unchunked_message() {
        let mut id = 0;
        let m = statustext(MavSeverity::MAV_SEVERITY_INFO, "Reached waypoint #1", &mut id);
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].id, 0);
        assert_eq!(m[0].text.to_str().unwrap(), "Reached waypoint #1");
    }

    #[test]
    fn long_text_is_chunked_with_a_shared_id() {
        let mut id = 0;
        let text = "x".repeat(120);
        let m = statustext(MavSeverity::MAV_SEVERITY_WARNING, &text, &mut id);
        assert_eq!(m.len(), 3);
        assert!(m.iter().all(|c| c.id == 1));
        assert_eq!(m.iter().map(|c| c.chunk_seq).collect::<Vec<_>>(), vec![0, 1, 2]);
        let m = statustext(MavSeverity::MAV_SEVERITY_WARNING, &"y".repeat(100), &mut id);
        assert_eq!(m.len(), 3, "two full chunks and a terminator");
        assert!(m.iter().all(|c| c.id == 2));
    }
}
