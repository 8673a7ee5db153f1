//! The DataFlash binary log format (ArduPilot's `.BIN`): records of
//! `0xA3 0x95 type` followed by little-endian fields, described in the file
//! itself by FMT records (name, field types, labels), and FMTU/UNIT/MULT
//! records (each field's unit and multiplier). pymavlink's `DFReader`,
//! MAVExplorer, UAV Log Viewer and Mission Planner read it.

/// Every record starts with these two bytes, then its type id.
pub const HEAD: [u8; 2] = [0xA3, 0x95];

/// One message type: its id in the file, a name of up to 4 characters, one
/// format character per field (see [`field_size`]), comma-separated labels,
/// and one unit and one multiplier character per field (see [`UNITS`],
/// [`MULTS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MessageDef {
    pub id: u8,
    pub name: &'static str,
    pub format: &'static str,
    pub labels: &'static str,
    pub units: &'static str,
    pub mults: &'static str,
}

impl MessageDef {
    /// Bytes of one record, header included.
    pub fn length(&self) -> usize {
        3 + self.format.chars().map(|c| field_size(c).unwrap_or(0)).sum::<usize>()
    }
}

/// Bytes of one field of format character `c`, as DFReader unpacks them.
pub fn field_size(c: char) -> Option<usize> {
    Some(match c {
        'b' | 'B' | 'M' => 1,
        'h' | 'H' | 'c' | 'C' => 2,
        'i' | 'I' | 'e' | 'E' | 'L' | 'f' => 4,
        'q' | 'Q' | 'd' => 8,
        'n' => 4,
        'N' => 16,
        'Z' => 64,
        _ => return None,
    })
}

/// What the format's scaled characters store: `c`, `C`, `e`, `E` hold
/// hundredths, `L` holds 1e-7 degrees. Readers scale them back.
pub fn format_scale(c: char) -> f64 {
    match c {
        'c' | 'C' | 'e' | 'E' => 100.0,
        'L' => 1e7,
        _ => 1.0,
    }
}

/// Unit characters (ArduPilot's table, the ones used here).
pub const UNITS: &[(char, &str)] = &[
    ('-', ""),
    ('#', "instance"),
    ('%', "%"),
    ('A', "A"),
    ('a', "Ah"),
    ('D', "deglatitude"),
    ('d', "deg"),
    ('E', "rad/s"),
    ('h', "degheading"),
    ('k', "deg/s"),
    ('m', "m"),
    ('n', "m/s"),
    ('O', "degC"),
    ('o', "m/s/s"),
    ('r', "rad"),
    ('S', "satellites"),
    ('s', "s"),
    ('U', "deglongitude"),
    ('v', "V"),
    ('X', "Wh"),
];

/// Multiplier characters: the stored value times this is in the unit.
pub const MULTS: &[(char, f64)] = &[
    ('-', 0.0),
    ('?', 1.0),
    ('0', 1.0),
    ('B', 1e-2),
    ('C', 1e-3),
    ('F', 1e-6),
    ('G', 1e-7),
];

/// A field's value as the core hands it over: the encoder converts it to
/// the field's format (rounding, clamping, scaling `c`/`e`/`L` fields).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value<'a> {
    U(u64),
    I(i64),
    F(f64),
    S(&'a str),
}

impl Value<'_> {
    fn as_f64(&self) -> f64 {
        match *self {
            Value::U(v) => v as f64,
            Value::I(v) => v as f64,
            Value::F(v) => v,
            Value::S(_) => 0.0,
        }
    }

    /// Rounded into `lo..=hi` (NaN gives 0).
    fn int(&self, scale: f64, lo: f64, hi: f64) -> i128 {
        match *self {
            Value::U(v) if scale == 1.0 => i128::from(v).clamp(lo as i128, hi as i128),
            Value::I(v) if scale == 1.0 => i128::from(v).clamp(lo as i128, hi as i128),
            _ => {
                let v = (self.as_f64() * scale).round();
                if v.is_nan() { 0 } else { v.clamp(lo, hi) as i128 }
            }
        }
    }
}

/// Appends one record of `def` to `out`. A value missing at the end is
/// written as zero; a value of the wrong kind is converted (a text field
/// given a number is left blank). The record always has `def.length()`
/// bytes, so a reader never loses its place.
pub fn write_record(out: &mut Vec<u8>, def: &MessageDef, values: &[Value]) {
    out.extend_from_slice(&HEAD);
    out.push(def.id);
    for (i, c) in def.format.chars().enumerate() {
        let v = values.get(i).copied().unwrap_or(Value::U(0));
        write_field(out, c, v);
    }
}

fn write_field(out: &mut Vec<u8>, c: char, v: Value) {
    let s = format_scale(c);
    match c {
        'b' => out.push(v.int(s, -128.0, 127.0) as i8 as u8),
        'B' | 'M' => out.push(v.int(s, 0.0, 255.0) as u8),
        'h' | 'c' => out.extend_from_slice(&(v.int(s, -32768.0, 32767.0) as i16).to_le_bytes()),
        'H' | 'C' => out.extend_from_slice(&(v.int(s, 0.0, 65535.0) as u16).to_le_bytes()),
        'i' | 'e' | 'L' => out.extend_from_slice(&(v.int(s, -2147483648.0, 2147483647.0) as i32).to_le_bytes()),
        'I' | 'E' => out.extend_from_slice(&(v.int(s, 0.0, 4294967295.0) as u32).to_le_bytes()),
        'q' => out.extend_from_slice(&(v.int(s, i64::MIN as f64, i64::MAX as f64) as i64).to_le_bytes()),
        'Q' => out.extend_from_slice(&(v.int(s, 0.0, u64::MAX as f64) as u64).to_le_bytes()),
        'f' => out.extend_from_slice(&(v.as_f64() as f32).to_le_bytes()),
        'd' => out.extend_from_slice(&v.as_f64().to_le_bytes()),
        'n' | 'N' | 'Z' => {
            let width = field_size(c).unwrap_or(0);
            write_text(out, if let Value::S(t) = v { t } else { "" }, width);
        }
        _ => {}
    }
}

/// Text padded with NULs to `width` bytes (cut at a character boundary).
fn write_text(out: &mut Vec<u8>, text: &str, width: usize) {
    let mut end = text.len().min(width);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    out.extend_from_slice(&text.as_bytes()[..end]);
    out.resize(out.len() + width - end, 0);
}

/// FMT: describes a message type (itself included).
pub const FMT: MessageDef = MessageDef {
    id: 128,
    name: "FMT",
    format: "BBnNZ",
    labels: "Type,Length,Name,Format,Columns",
    units: "-----",
    mults: "-----",
};

/// UNIT: a unit character and its name.
pub const UNIT: MessageDef = MessageDef {
    id: 177,
    name: "UNIT",
    format: "QbZ",
    labels: "TimeUS,Id,Label",
    units: "s--",
    mults: "F--",
};

/// MULT: a multiplier character and its value.
pub const MULT: MessageDef = MessageDef {
    id: 178,
    name: "MULT",
    format: "Qbd",
    labels: "TimeUS,Id,Mult",
    units: "s--",
    mults: "F--",
};

/// FMTU: a message type's unit and multiplier characters.
pub const FMTU: MessageDef = MessageDef {
    id: 179,
    name: "FMTU",
    format: "QBNN",
    labels: "TimeUS,FmtType,UnitIds,MultIds",
    units: "s---",
    mults: "F---",
};

/// The records that open a file: FMT for the format records and every
/// message of `defs`, the UNIT and MULT tables, and each message's FMTU.
pub fn write_header(out: &mut Vec<u8>, time_us: u64, defs: &[MessageDef]) {
    let own = [FMT, UNIT, MULT, FMTU];
    for def in own.iter().chain(defs) {
        write_record(
            out,
            &FMT,
            &[
                Value::U(u64::from(def.id)),
                Value::U(def.length() as u64),
                Value::S(def.name),
                Value::S(def.format),
                Value::S(def.labels),
            ],
        );
    }
    for &(id, label) in UNITS {
        write_record(out, &UNIT, &[Value::U(time_us), Value::I(id as i64), Value::S(label)]);
    }
    for &(id, mult) in MULTS {
        write_record(out, &MULT, &[Value::U(time_us), Value::I(id as i64), Value::F(mult)]);
    }
    for def in own.iter().skip(1).chain(defs) {
        write_record(
            out,
            &FMTU,
            &[
                Value::U(time_us),
                Value::U(u64::from(def.id)),
                Value::S(def.units),
                Value::S(def.mults),
            ],
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEST: MessageDef = MessageDef {
        id: 9,
        name: "TEST",
        format: "QbBhHcCeELfdnNZ",
        labels: "TimeUS,A,B,C,D,E,F,G,H,Lat,J,K,N,O,P",
        units: "s--------D-----",
        mults: "F--------G-----",
    };

    #[test]
    fn a_record_has_its_declared_length_and_little_endian_fields() {
        let mut out = Vec::new();
        write_record(
            &mut out,
            &TEST,
            &[
                Value::U(0x0102030405060708),
                Value::I(-2),
                Value::U(300),
                Value::I(-1234),
                Value::U(65535),
                Value::F(-1.5),
                Value::F(2.25),
                Value::F(-12.5),
                Value::F(7.0),
                Value::F(29.133_000_1),
                Value::F(0.5),
                Value::F(-0.25),
                Value::S("ABCDEFG"),
                Value::S("PARAM"),
                Value::S("héllo"),
            ],
        );
        assert_eq!(out.len(), TEST.length());
        assert_eq!(
            TEST.length(),
            3 + 8 + 1 + 1 + 2 + 2 + 2 + 2 + 4 + 4 + 4 + 4 + 8 + 4 + 16 + 64
        );
        assert_eq!(&out[..3], &[0xA3, 0x95, 9]);
        assert_eq!(&out[3..11], &0x0102030405060708u64.to_le_bytes());
        assert_eq!(out[11] as i8, -2);
        assert_eq!(out[12], 255, "300 clamps to a byte");
        assert_eq!(i16::from_le_bytes([out[13], out[14]]), -1234);
        assert_eq!(u16::from_le_bytes([out[15], out[16]]), 65535);
        assert_eq!(i16::from_le_bytes([out[17], out[18]]), -150, "c holds hundredths");
        assert_eq!(u16::from_le_bytes([out[19], out[20]]), 225);
        assert_eq!(i32::from_le_bytes(out[21..25].try_into().unwrap()), -1250);
        assert_eq!(u32::from_le_bytes(out[25..29].try_into().unwrap()), 700);
        assert_eq!(
            i32::from_le_bytes(out[29..33].try_into().unwrap()),
            291_330_001,
            "L holds 1e-7 degrees"
        );
        assert_eq!(f32::from_le_bytes(out[33..37].try_into().unwrap()), 0.5);
        assert_eq!(f64::from_le_bytes(out[37..45].try_into().unwrap()), -0.25);
        assert_eq!(&out[45..49], b"ABCD", "n is cut to 4 bytes");
        assert_eq!(&out[49..65], b"PARAM\0\0\0\0\0\0\0\0\0\0\0");
        assert_eq!(&out[65..71], "héllo".as_bytes());
        assert!(out[71..].iter().all(|&b| b == 0));
    }

    #[test]
    fn missing_and_non_finite_values_are_zero_and_the_length_holds() {
        let mut out = Vec::new();
        write_record(&mut out, &TEST, &[Value::U(1), Value::F(f64::NAN)]);
        assert_eq!(out.len(), TEST.length());
        assert!(out[11..].iter().all(|&b| b == 0));
        let mut out = Vec::new();
        write_record(&mut out, &TEST, &[Value::U(1), Value::F(f64::INFINITY), Value::F(-5.0)]);
        assert_eq!(out[11] as i8, 127);
        assert_eq!(out[12], 0);
    }

    #[test]
    fn the_header_describes_itself_and_every_message() {
        let mut out = Vec::new();
        write_header(&mut out, 5, &[TEST]);
        // FMT for FMT, UNIT, MULT, FMTU, TEST; the tables; FMTU for the rest.
        let expected = 5 * FMT.length() + UNITS.len() * UNIT.length() + MULTS.len() * MULT.length() + 4 * FMTU.length();
        assert_eq!(out.len(), expected);
        assert_eq!(FMT.length(), 89, "DFReader's built-in FMT length");
        assert_eq!(&out[..6], &[0xA3, 0x95, 128, 128, 89, b'F']);
        let test_fmt = &out[4 * FMT.length()..5 * FMT.length()];
        assert_eq!(test_fmt[3], 9);
        assert_eq!(usize::from(test_fmt[4]), TEST.length());
        assert_eq!(&test_fmt[5..9], b"TEST");
        assert_eq!(&test_fmt[9..24], TEST.format.as_bytes());
    }

    #[test]
    fn every_format_character_used_has_a_size() {
        for def in [FMT, UNIT, MULT, FMTU] {
            assert!(def.format.chars().all(|c| field_size(c).is_some()), "{}", def.name);
            assert_eq!(def.format.len(), def.labels.split(',').count(), "{}", def.name);
            assert_eq!(def.format.len(), def.units.len(), "{}", def.name);
            assert_eq!(def.format.len(), def.mults.len(), "{}", def.name);
        }
    }
}
