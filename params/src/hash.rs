//! The parameter table hash, PX4's `_HASH_CHECK` scheme: one number that
//! changes whenever any parameter's value does, so a ground station with a
//! cached copy can skip the full download.
//!
//! How a GCS uses it: send PARAM_REQUEST_READ with `param_id = "_HASH_CHECK"`
//! and `param_index = -1`. The answer is a PARAM_VALUE named `_HASH_CHECK`,
//! type UINT32, `param_index` 65535, whose float field holds the 32 bits of
//! the hash (copied bytewise, not converted). If it equals the hash of the
//! cached copy, the cache is current. A PARAM_SET of `_HASH_CHECK` (any
//! value) stops a PARAM_REQUEST_LIST stream already under way on that link.
//!
//! The hash: CRC-32 (IEEE 802.3, as zlib) over every parameter in name
//! order, each contributing its name's ASCII bytes followed by the four
//! little-endian bytes of its PARAM_VALUE float (the C-cast value). A GCS can
//! therefore compute it from the PARAM_VALUEs it received.

use crate::service::wire_value;
use crate::table::ParamTable;

/// The reserved id of the hash pseudo-parameter.
pub const HASH_CHECK_ID: &str = "_HASH_CHECK";

pub fn table_hash(table: &ParamTable) -> u32 {
    let mut entries: Vec<(&str, f32)> = table.iter().map(|(d, v)| (d.name.as_str(), wire_value(v))).collect();
    entries.sort_by(|a, b| a.0.cmp(b.0));
    let mut crc = crc32fast::Hasher::new();
    for (name, value) in entries {
        crc.update(name.as_bytes());
        crc.update(&value.to_le_bytes());
    }
    crc.finalize()
}
