//! Reads a DataFlash log back (for `furrow logs` and the tests): the FMT
//! records say how to decode the rest. Bytes that do not parse are skipped
//! and counted, as DFReader does, so a log cut short or damaged still reads.

use std::collections::BTreeMap;
use std::path::Path;

use super::format::{FMT, HEAD, field_size, format_scale};

/// One message type as the file describes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Format {
    pub id: u8,
    pub name: String,
    pub format: String,
    pub labels: Vec<String>,
    /// Bytes of one record, header included.
    pub length: usize,
}

impl Format {
    pub fn column(&self, label: &str) -> Option<usize> {
        self.labels.iter().position(|l| l == label)
    }
}

/// A decoded field: scaled fields (`c`, `e`, `L`…) are in their units.
#[derive(Clone, Debug, PartialEq)]
pub enum Field {
    Int(i64),
    Float(f64),
    Text(String),
}

impl Field {
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Field::Int(v) => Some(*v as f64),
            Field::Float(v) => Some(*v),
            Field::Text(_) => None,
        }
    }
}

impl std::fmt::Display for Field {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Field::Int(v) => write!(f, "{v}"),
            Field::Float(v) => write!(f, "{v}"),
            Field::Text(t) => write!(f, "{t}"),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    pub id: u8,
    pub fields: Vec<Field>,
}

#[derive(Clone, Debug, Default)]
pub struct DataFlashLog {
    pub formats: BTreeMap<u8, Format>,
    pub records: Vec<Record>,
    /// Bytes that were not part of a record.
    pub skipped_bytes: usize,
}

/// A record with its format, for reading fields by label.
#[derive(Clone, Copy, Debug)]
pub struct Message<'a> {
    pub format: &'a Format,
    pub fields: &'a [Field],
}

impl Message<'_> {
    pub fn get(&self, label: &str) -> Option<f64> {
        self.fields.get(self.format.column(label)?)?.as_f64()
    }

    pub fn text(&self, label: &str) -> Option<&str> {
        match self.fields.get(self.format.column(label)?)? {
            Field::Text(t) => Some(t),
            _ => None,
        }
    }

    /// TimeUS in seconds.
    pub fn time_s(&self) -> Option<f64> {
        self.get("TimeUS").map(|us| us * 1e-6)
    }
}

fn format_of_fmt() -> Format {
    Format {
        id: FMT.id,
        name: FMT.name.into(),
        format: FMT.format.into(),
        labels: FMT.labels.split(',').map(String::from).collect(),
        length: FMT.length(),
    }
}

fn text(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

/// Decodes the body of a record of `format` (`None`: a format character
/// DataFlash does not have).
fn decode(format: &str, mut body: &[u8]) -> Option<Vec<Field>> {
    let mut fields = Vec::with_capacity(format.len());
    for c in format.chars() {
        let size = field_size(c)?;
        let (b, rest) = body.split_at_checked(size)?;
        body = rest;
        let int = |v: i64| {
            let scale = format_scale(c);
            if scale == 1.0 {
                Field::Int(v)
            } else {
                Field::Float(v as f64 / scale)
            }
        };
        fields.push(match c {
            'b' => int(i64::from(b[0] as i8)),
            'B' | 'M' => int(i64::from(b[0])),
            'h' | 'c' => int(i64::from(i16::from_le_bytes([b[0], b[1]]))),
            'H' | 'C' => int(i64::from(u16::from_le_bytes([b[0], b[1]]))),
            'i' | 'e' | 'L' => int(i64::from(i32::from_le_bytes(b.try_into().ok()?))),
            'I' | 'E' => int(i64::from(u32::from_le_bytes(b.try_into().ok()?))),
            'q' => int(i64::from_le_bytes(b.try_into().ok()?)),
            'Q' => int(u64::from_le_bytes(b.try_into().ok()?).min(i64::MAX as u64) as i64),
            'f' => Field::Float(f64::from(f32::from_le_bytes(b.try_into().ok()?))),
            'd' => Field::Float(f64::from_le_bytes(b.try_into().ok()?)),
            _ => Field::Text(text(b)),
        });
    }
    Some(fields)
}

impl DataFlashLog {
    /// Parses `bytes`, skipping what is not a record.
    pub fn parse(bytes: &[u8]) -> DataFlashLog {
        let mut log = DataFlashLog::default();
        log.formats.insert(FMT.id, format_of_fmt());
        let mut at = 0;
        while at + 3 <= bytes.len() {
            let known = bytes[at..at + 2] == HEAD && log.formats.contains_key(&bytes[at + 2]);
            let parsed = known.then(|| log.read_record(&bytes[at..])).flatten();
            match parsed {
                Some(length) => at += length,
                None => {
                    log.skipped_bytes += 1;
                    at += 1;
                }
            }
        }
        log.skipped_bytes += bytes.len() - at;
        log
    }

    /// Reads the record at the start of `bytes`; its length if it parsed.
    fn read_record(&mut self, bytes: &[u8]) -> Option<usize> {
        let format = &self.formats[&bytes[2]];
        let length = format.length;
        let body = bytes.get(3..length)?;
        let fields = decode(&format.format, body)?;
        let id = format.id;
        if id == FMT.id {
            self.add_format(&fields);
        }
        self.records.push(Record { id, fields });
        Some(length)
    }

    fn add_format(&mut self, fields: &[Field]) {
        let (Some(Field::Int(id)), Some(Field::Int(length)), Some(Field::Text(name)), Some(Field::Text(format))) =
            (fields.first(), fields.get(1), fields.get(2), fields.get(3))
        else {
            return;
        };
        let labels = match fields.get(4) {
            Some(Field::Text(l)) => l.split(',').map(String::from).collect(),
            _ => Vec::new(),
        };
        let computed: Option<usize> = format.chars().map(field_size).sum();
        // A format whose length disagrees with its fields cannot be decoded.
        if computed.map(|c| c + 3) != Some(*length as usize) || *id == i64::from(FMT.id) {
            return;
        }
        let id = *id as u8;
        self.formats.insert(
            id,
            Format {
                id,
                name: name.clone(),
                format: format.clone(),
                labels,
                length: *length as usize,
            },
        );
    }

    /// Reads the log at `path`: an error when it cannot be read or holds
    /// no DataFlash records at all.
    pub fn read(path: &Path) -> Result<DataFlashLog, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let log = DataFlashLog::parse(&bytes);
        if log.records.is_empty() {
            return Err(format!("{}: not a DataFlash log (no records)", path.display()));
        }
        Ok(log)
    }

    /// The records of the message type `name`, in order.
    pub fn messages<'a>(&'a self, name: &str) -> impl Iterator<Item = Message<'a>> + 'a {
        let id = self.formats.values().find(|f| f.name == name).map(|f| f.id);
        self.records.iter().filter(move |r| Some(r.id) == id).map(|r| Message {
            format: &self.formats[&r.id],
            fields: &r.fields,
        })
    }

    /// How many records of each message type, by name.
    pub fn counts(&self) -> BTreeMap<&str, usize> {
        let mut counts = BTreeMap::new();
        for r in &self.records {
            *counts.entry(self.formats[&r.id].name.as_str()).or_insert(0) += 1;
        }
        counts
    }
}

#[cfg(test)]
mod tests {
    use super::super::format::{Value, write_header, write_record};
    use super::super::messages::{ALL, NTUN, PARM};
    use super::*;

    fn sample() -> Vec<u8> {
        let mut out = Vec::new();
        write_header(&mut out, 0, ALL);
        write_record(
            &mut out,
            &PARM,
            &[Value::U(5), Value::S("WP_SPEED"), Value::F(2.0), Value::F(2.0)],
        );
        for i in 0..3 {
            let values = [
                Value::U(1000 * i),
                Value::F(4.0),
                Value::F(90.0),
                Value::F(91.0),
                Value::F(92.0),
                Value::F(-0.01),
            ];
            write_record(&mut out, &NTUN, &values);
        }
        out
    }

    #[test]
    fn what_is_written_reads_back() {
        let log = DataFlashLog::parse(&sample());
        assert_eq!(log.skipped_bytes, 0);
        let ntun: Vec<_> = log.messages("NTUN").collect();
        assert_eq!(ntun.len(), 3);
        assert_eq!(ntun[2].time_s(), Some(0.002));
        assert!((ntun[1].get("XTrack").unwrap() + 0.01).abs() < 1e-9);
        let parm = log.messages("PARM").next().unwrap();
        assert_eq!(parm.text("Name"), Some("WP_SPEED"));
        assert_eq!(log.counts()["NTUN"], 3);
    }

    #[test]
    fn garbage_and_a_cut_record_are_skipped() {
        let mut bytes = sample();
        let ntun_at = bytes.len() - NTUN.length();
        bytes.insert(ntun_at, 0xA3);
        bytes.insert(ntun_at, 0x00);
        bytes.truncate(bytes.len() - 5);
        let log = DataFlashLog::parse(&bytes);
        assert_eq!(log.messages("NTUN").count(), 2, "the last one is cut");
        assert_eq!(log.skipped_bytes, 2 + NTUN.length() - 5);
        assert!(DataFlashLog::parse(b"not a log at all").records.is_empty());
    }
}
