//! The protocol against the real data-directory files in a scratch
//! directory: what a client sees, error codes included.

use std::path::PathBuf;

use super::disk::{DataFiles, Handle};
use super::server::{Files, Server};
use super::wire::{FtpError, MAX_DATA, Opcode, Payload};

struct Client {
    server: Server<Handle>,
    files: DataFiles,
    seq: u16,
    dir: PathBuf,
    /// Holds `dir` and the "outside" file beside it; removed on drop.
    _scratch: tempfile::TempDir,
}

impl Client {
    fn new(tag: &str) -> Client {
        let scratch = tempfile::Builder::new()
            .prefix(&format!("furrow-ftp-{tag}-"))
            .tempdir()
            .unwrap();
        let dir = scratch.path().join("data");
        std::fs::create_dir(&dir).unwrap();
        Client {
            server: Server::default(),
            files: DataFiles::new(&dir),
            seq: 0,
            dir,
            _scratch: scratch,
        }
    }

    fn send(&mut self, opcode: Opcode, session: u8, offset: u32, data: &[u8]) -> Vec<Payload> {
        self.seq = self.seq.wrapping_add(1);
        let req = Payload {
            seq: self.seq,
            session,
            opcode: opcode as u8,
            req_opcode: 0,
            burst_complete: false,
            offset,
            data: data.to_vec(),
        };
        let mut out = Vec::new();
        self.server.handle(&mut self.files, &req, &mut out);
        for (k, r) in out.iter().enumerate() {
            assert_eq!(
                r.seq,
                self.seq.wrapping_add(k as u16 + 1),
                "reply seq follows the request's"
            );
            assert_eq!((r.session, r.req_opcode), (session, opcode as u8));
        }
        out
    }

    fn one(&mut self, opcode: Opcode, session: u8, offset: u32, data: &[u8]) -> Payload {
        let mut r = self.send(opcode, session, offset, data);
        assert_eq!(r.len(), 1, "{r:?}");
        r.remove(0)
    }
}

fn acked(r: &Payload) -> bool {
    r.opcode == Opcode::Ack as u8
}

fn nak_code(r: &Payload) -> Option<u8> {
    (r.opcode == Opcode::Nak as u8).then(|| r.data[0])
}

#[test]
fn a_file_is_read_by_burst_and_read_and_its_crc_matches_ardupilots() {
    let mut c = Client::new("read");
    let body: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
    std::fs::write(c.dir.join("data.bin"), &body).unwrap();
    let open = c.one(Opcode::OpenFileRO, 3, 0, b"/data.bin");
    assert!(acked(&open));
    assert_eq!(open.data, 1000u32.to_le_bytes());
    let burst = c.send(Opcode::BurstReadFile, 3, 0, &[0; 80]);
    let got: Vec<u8> = burst.iter().filter(|r| acked(r)).flat_map(|r| r.data.clone()).collect();
    assert_eq!(got, body);
    let last = burst.last().unwrap();
    assert!(
        last.burst_complete && last.data.len() < 80,
        "EOF shows as a short final packet"
    );
    let read = c.one(Opcode::ReadFile, 3, 990, &[0; 50]);
    assert_eq!((read.offset, &read.data[..]), (990, &body[990..]));
    assert_eq!(
        nak_code(&c.one(Opcode::ReadFile, 3, 1000, &[0; 50])),
        Some(FtpError::EndOfFile as u8)
    );
    assert!(acked(&c.one(Opcode::TerminateSession, 3, 0, &[])));
    assert_eq!(
        nak_code(&c.one(Opcode::ReadFile, 3, 0, &[0; 50])),
        Some(FtpError::InvalidSession as u8)
    );
    // A file ending on a packet boundary ends its burst with an EOF NAK.
    std::fs::write(c.dir.join("even.bin"), vec![1u8; 2 * MAX_DATA]).unwrap();
    c.one(Opcode::OpenFileRO, 0, 0, b"even.bin");
    let burst = c.send(Opcode::BurstReadFile, 0, 0, &[]);
    assert_eq!(burst.len(), 3);
    assert_eq!(nak_code(&burst[2]), Some(FtpError::EndOfFile as u8));
    assert_eq!(burst[2].offset, 2 * MAX_DATA as u32);
    // ArduPilot's CRC: zero seed, no final inversion (zlib's is
    // crc32(data, 0xffffffff) ^ 0xffffffff).
    let crc = c.one(Opcode::CalcFileCRC32, 0, 0, b"data.bin");
    let expect = {
        let mut h = crc32fast::Hasher::new_with_initial(u32::MAX);
        h.update(&body);
        h.finalize() ^ u32::MAX
    };
    assert_eq!(crc.data, expect.to_le_bytes());
}

#[test]
fn files_are_written_renamed_truncated_and_removed_in_the_data_directory() {
    let mut c = Client::new("write");
    assert!(acked(&c.one(Opcode::CreateDirectory, 0, 0, b"notes")));
    assert!(acked(&c.one(Opcode::CreateFile, 1, 0, b"notes/a.txt")));
    assert!(acked(&c.one(Opcode::WriteFile, 1, 0, b"hello ")));
    assert!(acked(&c.one(Opcode::WriteFile, 1, 6, b"world")));
    // A repeated request (lost reply) is answered again, not done twice.
    let again = c.server_repeat(Opcode::WriteFile, 1, 6, b"world");
    assert!(acked(&again));
    c.one(Opcode::TerminateSession, 1, 0, &[]);
    assert_eq!(std::fs::read(c.dir.join("notes/a.txt")).unwrap(), b"hello world");
    assert!(acked(&c.one(Opcode::TruncateFile, 0, 5, b"notes/a.txt")));
    assert!(acked(&c.one(Opcode::Rename, 0, 0, b"notes/a.txt\0notes/b.txt")));
    assert_eq!(std::fs::read(c.dir.join("notes/b.txt")).unwrap(), b"hello");
    let list = c.one(Opcode::ListDirectory, 0, 0, b"notes");
    assert_eq!(list.data, b"Fb.txt\t5\0");
    assert_eq!(
        nak_code(&c.one(Opcode::ListDirectory, 0, 1, b"notes")),
        Some(FtpError::EndOfFile as u8)
    );
    assert_eq!(
        nak_code(&c.one(Opcode::RemoveDirectory, 0, 0, b"notes")).map(|_| ()),
        Some(())
    );
    assert!(acked(&c.one(Opcode::RemoveFile, 0, 0, b"notes/b.txt")));
    assert!(acked(&c.one(Opcode::RemoveDirectory, 0, 0, b"notes")));
    assert_eq!(
        nak_code(&c.one(Opcode::RemoveFile, 0, 0, b"nothing")),
        Some(FtpError::FileNotFound as u8)
    );
    assert_eq!(
        nak_code(&c.one(Opcode::OpenFileWO, 0, 0, b"nothing")),
        Some(FtpError::FileNotFound as u8)
    );
}

#[test]
fn nothing_outside_the_data_directory_or_owned_by_the_vehicle_is_reachable() {
    let mut c = Client::new("escape");
    let outside = c.dir.with_extension("outside");
    std::fs::write(&outside, b"secret").unwrap();
    std::os::unix::fs::symlink(&outside, c.dir.join("link")).unwrap();
    std::fs::write(c.dir.join(params::store::STORE_FILE), b"WP_SPEED 2\n").unwrap();
    std::fs::write(c.dir.join(crate::storage::signing_key::KEY_FILE), b"key").unwrap();
    let protected = Some(FtpError::FileProtected as u8);
    for path in [
        &b"../x"[..],
        b"/../../etc/passwd",
        b"a/../../x",
        b"link",
        b"signing.key",
    ] {
        assert_eq!(nak_code(&c.one(Opcode::OpenFileRO, 0, 0, path)), protected, "{path:?}");
    }
    // A leading / is the data directory, not the host's root.
    assert_eq!(
        nak_code(&c.one(Opcode::OpenFileRO, 0, 0, b"/etc/passwd")),
        Some(FtpError::FileNotFound as u8)
    );
    for (op, path) in [
        (Opcode::CreateFile, &b"../evil"[..]),
        (Opcode::RemoveFile, b"params.parm"),
        (Opcode::CreateFile, b"params.parm"),
        (Opcode::RemoveFile, b"mission.waypoints"),
        (Opcode::CreateFile, b"params.parm.tmp"),
        (Opcode::CreateFile, b"fence.waypoints.tmp"),
        (Opcode::RemoveDirectory, b"/"),
    ] {
        assert_eq!(nak_code(&c.one(op, 0, 0, path)), protected, "{op:?} {path:?}");
    }
    assert!(
        acked(&c.one(Opcode::OpenFileRO, 0, 0, b"params.parm")),
        "readable, not writable"
    );
    let list = c.one(Opcode::ListDirectory, 0, 0, b"/");
    let text = String::from_utf8_lossy(&list.data);
    assert!(text.contains("Fparams.parm\t11") && text.contains("D@PARAM"), "{text}");
    assert!(!text.contains("signing.key"), "{text}");
}

#[test]
fn unknown_and_malformed_requests_get_clean_naks() {
    let mut c = Client::new("bad");
    let mut out = Vec::new();
    let req = |opcode: u8| Payload {
        seq: 9,
        session: 0,
        opcode,
        req_opcode: 0,
        burst_complete: false,
        offset: 0,
        data: Vec::new(),
    };
    for opcode in [0u8, 16, 99, 128, 129, 255] {
        out.clear();
        c.server.handle(&mut c.files, &req(opcode), &mut out);
        assert_eq!(
            nak_code(&out[0]),
            Some(FtpError::UnknownCommand as u8),
            "opcode {opcode}"
        );
    }
    assert_eq!(
        nak_code(&c.one(Opcode::BurstReadFile, 7, 0, &[])),
        Some(FtpError::InvalidSession as u8)
    );
    assert_eq!(
        nak_code(&c.one(Opcode::WriteFile, 7, 0, b"x")),
        Some(FtpError::InvalidSession as u8)
    );
    assert_eq!(
        nak_code(&c.one(Opcode::OpenFileRO, 0, 0, &[0xff, 0xfe])),
        Some(FtpError::FileNotFound as u8)
    );
    assert_eq!(
        nak_code(&c.one(Opcode::Rename, 0, 0, b"only-one")),
        Some(FtpError::FileNotFound as u8)
    );
}

#[test]
fn the_parameter_file_is_served_from_memory() {
    let mut c = Client::new("param");
    c.files.set_param_pack(true, vec![0x1c, 0x67, 0, 0, 0, 0]);
    let open = c.one(Opcode::OpenFileRO, 0, 0, b"@PARAM/param.pck?withdefaults=1");
    assert_eq!(open.data, 6u32.to_le_bytes());
    let burst = c.send(Opcode::BurstReadFile, 0, 0, &[0; 239]);
    assert_eq!(burst[0].data, [0x1c, 0x67, 0, 0, 0, 0]);
    assert_eq!(
        nak_code(&c.one(Opcode::CreateFile, 1, 0, b"@PARAM/param.pck")),
        Some(FtpError::FileProtected as u8)
    );
    assert_eq!(
        nak_code(&c.one(Opcode::OpenFileRO, 0, 0, b"@PARAM/other")),
        Some(FtpError::FileNotFound as u8)
    );
}

impl Client {
    /// Sends the last request again with the same seq.
    fn server_repeat(&mut self, opcode: Opcode, session: u8, offset: u32, data: &[u8]) -> Payload {
        let req = Payload {
            seq: self.seq,
            session,
            opcode: opcode as u8,
            req_opcode: 0,
            burst_complete: false,
            offset,
            data: data.to_vec(),
        };
        let mut out = Vec::new();
        self.server.handle(&mut self.files, &req, &mut out);
        out.remove(0)
    }
}

#[test]
fn files_trait_reads_past_the_end_as_empty() {
    let mut c = Client::new("past");
    std::fs::write(c.dir.join("f"), b"abc").unwrap();
    let (mut h, size) = c.files.open_read("f").unwrap();
    assert_eq!(size, 3);
    let mut buf = [0u8; 8];
    assert_eq!(c.files.read(&mut h, 10, &mut buf).unwrap(), 0);
}

#[test]
fn a_long_burst_stops_and_the_client_continues_where_it_ended() {
    let mut c = Client::new("long");
    let body: Vec<u8> = (0..100_000u32).map(|i| (i % 253) as u8).collect();
    std::fs::write(c.dir.join("big"), &body).unwrap();
    c.one(Opcode::OpenFileRO, 0, 0, b"big");
    let mut got = Vec::new();
    let mut bursts = 0;
    while got.len() < body.len() {
        let burst = c.send(Opcode::BurstReadFile, 0, got.len() as u32, &[]);
        bursts += 1;
        assert!(burst.len() <= 64, "a burst is bounded");
        assert!(burst.last().unwrap().burst_complete);
        for r in burst.iter().filter(|r| acked(r)) {
            assert_eq!(r.offset as usize, got.len());
            got.extend_from_slice(&r.data);
        }
    }
    assert_eq!(got, body);
    assert_eq!(bursts, body.len().div_ceil(64 * MAX_DATA));
}
