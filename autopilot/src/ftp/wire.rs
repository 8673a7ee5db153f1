//! The FILE_TRANSFER_PROTOCOL payload (mavlink.io file transfer protocol):
//! a 12-byte header and up to 239 bytes of data.

/// Data bytes after the header in one message.
pub const MAX_DATA: usize = 239;
const HEADER_LEN: usize = 12;

/// Request and reply opcodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Opcode {
    None = 0,
    TerminateSession = 1,
    ResetSessions = 2,
    ListDirectory = 3,
    OpenFileRO = 4,
    ReadFile = 5,
    CreateFile = 6,
    WriteFile = 7,
    RemoveFile = 8,
    CreateDirectory = 9,
    RemoveDirectory = 10,
    OpenFileWO = 11,
    TruncateFile = 12,
    Rename = 13,
    CalcFileCRC32 = 14,
    BurstReadFile = 15,
    Ack = 128,
    Nak = 129,
}

impl Opcode {
    pub fn from_u8(v: u8) -> Option<Opcode> {
        use Opcode::*;
        Some(match v {
            0 => None,
            1 => TerminateSession,
            2 => ResetSessions,
            3 => ListDirectory,
            4 => OpenFileRO,
            5 => ReadFile,
            6 => CreateFile,
            7 => WriteFile,
            8 => RemoveFile,
            9 => CreateDirectory,
            10 => RemoveDirectory,
            11 => OpenFileWO,
            12 => TruncateFile,
            13 => Rename,
            14 => CalcFileCRC32,
            15 => BurstReadFile,
            128 => Ack,
            129 => Nak,
            _ => return Option::None,
        })
    }
}

/// NAK error codes (the first data byte of a NAK).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum FtpError {
    Fail = 1,
    /// Followed by an errno byte.
    FailErrno = 2,
    InvalidDataSize = 3,
    InvalidSession = 4,
    NoSessionsAvailable = 5,
    EndOfFile = 6,
    UnknownCommand = 7,
    FileExists = 8,
    FileProtected = 9,
    FileNotFound = 10,
}

/// One payload, request or reply.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Payload {
    pub seq: u16,
    pub session: u8,
    /// The raw opcode (an unknown one must still be answered).
    pub opcode: u8,
    pub req_opcode: u8,
    pub burst_complete: bool,
    pub offset: u32,
    pub data: Vec<u8>,
}

impl Payload {
    /// Decodes a request. `None` when `size` claims more data than fits:
    /// such a frame is answered with InvalidDataSize by the caller.
    pub fn decode(bytes: &[u8; 251]) -> Result<Payload, Payload> {
        let size = usize::from(bytes[4]);
        let mut p = Payload {
            seq: u16::from_le_bytes([bytes[0], bytes[1]]),
            session: bytes[2],
            opcode: bytes[3],
            req_opcode: bytes[5],
            burst_complete: bytes[6] != 0,
            offset: u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]),
            data: Vec::new(),
        };
        if size > MAX_DATA {
            return Err(p);
        }
        p.data = bytes[HEADER_LEN..HEADER_LEN + size].to_vec();
        Ok(p)
    }

    pub fn encode(&self) -> [u8; 251] {
        let mut out = [0u8; 251];
        let len = self.data.len().min(MAX_DATA);
        out[0..2].copy_from_slice(&self.seq.to_le_bytes());
        out[2] = self.session;
        out[3] = self.opcode;
        out[4] = len as u8;
        out[5] = self.req_opcode;
        out[6] = u8::from(self.burst_complete);
        out[8..12].copy_from_slice(&self.offset.to_le_bytes());
        out[HEADER_LEN..HEADER_LEN + len].copy_from_slice(&self.data[..len]);
        out
    }

    /// The data as a path: up to the first NUL, UTF-8.
    pub fn path(&self) -> Option<&str> {
        let end = self.data.iter().position(|&b| b == 0).unwrap_or(self.data.len());
        std::str::from_utf8(&self.data[..end]).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_bounds_the_size() {
        let p = Payload {
            seq: 513,
            session: 2,
            opcode: 4,
            req_opcode: 0,
            burst_complete: true,
            offset: 70_000,
            data: b"@PARAM/param.pck".to_vec(),
        };
        let bytes = p.encode();
        assert_eq!(Payload::decode(&bytes), Ok(p));
        let mut bad = bytes;
        bad[4] = 240;
        assert!(Payload::decode(&bad).is_err());
    }
}
