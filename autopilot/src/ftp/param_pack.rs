//! `@PARAM/param.pck`: the parameter table in ArduPilot's packed format, as
//! MAVProxy, QGroundControl and Mission Planner download it.
//!
//! Layout (all little-endian): a header `magic u16, count u16, total u16`
//! (magic 0x671b, or 0x671c when defaults are included), then per parameter
//! `type | flags << 4`, `common_len | (name_len - 1) << 4`, the name's bytes
//! after the `common_len` it shares with the previous name, the value, and
//! the default when flag bit 0 says it differs. Zero bytes may pad between
//! parameters (no type is 0); they are inserted so no parameter straddles a
//! 239-byte FTP block, which lets a reader decode block by block.

use params::ParamTable;
use params::ParamType;

const MAGIC: u16 = 0x671b;
const MAGIC_WITH_DEFAULTS: u16 = 0x671c;
const FLAG_DEFAULT: u8 = 1;
const BLOCK: usize = super::wire::MAX_DATA;

/// ArduPilot's AP_PARAM type numbers: the narrowest that holds the value.
fn packed_type(ty: ParamType) -> (u8, usize) {
    match ty {
        ParamType::Int8 => (1, 1),
        // No unsigned byte in AP_Param: 0..255 travels as an int16.
        ParamType::Uint8 | ParamType::Int16 => (2, 2),
        ParamType::Int32 => (3, 4),
        ParamType::Real32 => (4, 4),
    }
}

fn value_bytes(ty: ParamType, value: f64, out: &mut Vec<u8>) {
    match packed_type(ty).0 {
        1 => out.extend_from_slice(&(value as i8).to_le_bytes()),
        2 => out.extend_from_slice(&(value as i16).to_le_bytes()),
        3 => out.extend_from_slice(&(value as i32).to_le_bytes()),
        _ => out.extend_from_slice(&(value as f32).to_le_bytes()),
    }
}

/// The packed file for `table`; `with_defaults` as `?withdefaults=1` asks.
pub fn pack(table: &ParamTable, with_defaults: bool) -> Vec<u8> {
    let count = u16::try_from(table.len()).unwrap_or(u16::MAX);
    let magic = if with_defaults { MAGIC_WITH_DEFAULTS } else { MAGIC };
    let mut out = Vec::with_capacity(12 * table.len());
    for v in [magic, count, count] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let mut previous: &[u8] = &[];
    let mut entry = Vec::with_capacity(32);
    for (def, value) in table.iter().take(usize::from(count)) {
        let name = def.name.as_str().as_bytes();
        let common = name.iter().zip(previous).take_while(|(a, b)| a == b).count().min(15);
        // Names are 1..=16 bytes, so the suffix is 1..=16 once at least
        // one byte is left to write.
        let common = common.min(name.len() - 1);
        let suffix = &name[common..];
        let (ty, _) = packed_type(def.ty);
        let has_default = with_defaults && def.ty.quantize(def.default) != value;
        entry.clear();
        entry.push(ty | if has_default { FLAG_DEFAULT << 4 } else { 0 });
        entry.push(common as u8 | ((suffix.len() - 1) as u8) << 4);
        entry.extend_from_slice(suffix);
        value_bytes(def.ty, value, &mut entry);
        if has_default {
            value_bytes(def.ty, def.default, &mut entry);
        }
        let used = out.len() % BLOCK;
        if used + entry.len() > BLOCK {
            out.resize(out.len() + BLOCK - used, 0);
        }
        out.extend_from_slice(&entry);
        previous = name;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use params::{ParamDef, ParamFlags, ParamName, ParamTableBuilder};

    fn def(name: &str, ty: ParamType, default: f64) -> ParamDef {
        let (lo, hi) = ty.limits();
        ParamDef {
            name: ParamName::new(name.to_owned()).unwrap(),
            ty,
            default,
            min: lo.max(-1e6),
            max: hi.min(1e6),
            unit: "",
            description: "",
            flags: ParamFlags::default(),
        }
    }

    /// A reader written from the format description (as MAVProxy's).
    fn unpack(data: &[u8]) -> (bool, Vec<(String, f64, Option<f64>)>) {
        let magic = u16::from_le_bytes([data[0], data[1]]);
        let total = u16::from_le_bytes([data[4], data[5]]);
        let mut rest = &data[6..];
        let mut last = Vec::new();
        let mut out = Vec::new();
        loop {
            while rest.first() == Some(&0) {
                rest = &rest[1..];
            }
            let Some(&t) = rest.first() else { break };
            let (ty, flags) = (t & 0xf, t >> 4);
            let (common, len) = (usize::from(rest[1] & 0xf), usize::from(rest[1] >> 4) + 1);
            let mut name = last[..common].to_vec();
            name.extend_from_slice(&rest[2..2 + len]);
            rest = &rest[2 + len..];
            let read = |b: &[u8]| -> (f64, usize) {
                match ty {
                    1 => (f64::from(b[0] as i8), 1),
                    2 => (f64::from(i16::from_le_bytes([b[0], b[1]])), 2),
                    3 => (f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])), 4),
                    _ => (f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])), 4),
                }
            };
            let (v, n) = read(rest);
            rest = &rest[n..];
            let default = if flags & 1 != 0 {
                let (d, n) = read(rest);
                rest = &rest[n..];
                Some(d)
            } else {
                None
            };
            out.push((String::from_utf8(name.clone()).unwrap(), v, default));
            last = name;
        }
        assert_eq!(out.len(), usize::from(total));
        (magic == MAGIC_WITH_DEFAULTS, out)
    }

    #[test]
    fn packs_names_values_and_changed_defaults_readably() {
        let mut b = ParamTableBuilder::new();
        b.add(def("WP_SPEED", ParamType::Real32, 2.0));
        b.add(def("WP_RADIUS", ParamType::Real32, 2.0));
        b.add(def("SYSID_THISMAV", ParamType::Uint8, 1.0));
        b.add(def("ARMING_CHECK", ParamType::Int32, 1.0));
        b.add(def("X", ParamType::Int8, -3.0));
        let mut t = b.build();
        t.set_by_name("WP_SPEED", 2.5).unwrap();
        t.set_by_name("SYSID_THISMAV", 200.0).unwrap();
        let (defaults, got) = unpack(&pack(&t, true));
        assert!(defaults);
        let expect: Vec<(String, f64, Option<f64>)> = t
            .iter()
            .map(|(d, v)| (d.name.as_str().to_owned(), v, (v != d.default).then_some(d.default)))
            .collect();
        assert_eq!(got, expect);
        let (defaults, got) = unpack(&pack(&t, false));
        assert!(!defaults && got.iter().all(|(_, _, d)| d.is_none()));
    }

    #[test]
    fn no_parameter_straddles_an_ftp_block() {
        let mut b = ParamTableBuilder::new();
        let names: Vec<String> = (0..200).map(|i| format!("P{i:03}_LONGER_NAME")).collect();
        for n in &names {
            b.add(def(n, ParamType::Real32, 0.5));
        }
        let t = b.build();
        let bytes = pack(&t, true);
        assert_eq!(unpack(&bytes).1.len(), 200);
        assert!(bytes.len() > 3 * BLOCK);
    }
}
