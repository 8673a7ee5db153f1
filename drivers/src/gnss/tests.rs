use std::time::Duration;

use proptest::prelude::*;

use super::*;

const T: Duration = Duration::from_millis(1500);

/// `$body*hh\r\n` with a correct checksum.
fn sentence(body: &str) -> String {
    format!("${body}*{:02X}\r\n", nmea_checksum(body.as_bytes()))
}

fn read(bytes: &[u8]) -> (Vec<GnssSample>, NmeaStats) {
    let mut reader = NmeaReader::new();
    let mut out = Vec::new();
    reader.push(T, bytes, &mut out);
    (out, reader.stats())
}

const GGA_RTK: &str = "GNGGA,123519.25,4807.0381234,N,01131.3240000,W,4,17,0.7,545.432,M,46.9,M,1.0,0000";

fn only_fix(samples: &[GnssSample]) -> GnssFix {
    match samples {
        [GnssSample::Fix(fix)] => *fix,
        other => panic!("expected one fix, got {other:?}"),
    }
}

#[test]
fn gga_rtk_fix() {
    let (samples, stats) = read(sentence(GGA_RTK).as_bytes());
    let fix = only_fix(&samples);
    assert_eq!(fix.t, T);
    assert_eq!(fix.quality, FixQuality::RtkFixed);
    assert!((fix.lat_deg - (48.0 + 7.0381234 / 60.0)).abs() < 1e-12);
    assert!((fix.lon_deg + (11.0 + 31.324 / 60.0)).abs() < 1e-12);
    assert!((fix.alt_msl_m - 545.432).abs() < 1e-4);
    assert_eq!(fix.satellites, 17);
    assert!((fix.hdop - 0.7).abs() < 1e-6);
    let tod = fix.utc_time_of_day_s.unwrap();
    assert!((tod - (12.0 * 3600.0 + 35.0 * 60.0 + 19.25)).abs() < 1e-9);
    assert_eq!(
        stats,
        NmeaStats {
            sentences: 1,
            ..NmeaStats::default()
        }
    );
}

#[test]
fn gga_qualities_map() {
    for (digit, quality) in [
        ('0', FixQuality::NoFix),
        ('1', FixQuality::Single),
        ('2', FixQuality::Dgps),
        ('3', FixQuality::Single),
        ('4', FixQuality::RtkFixed),
        ('5', FixQuality::RtkFloat),
        ('6', FixQuality::DeadReckoning),
        ('7', FixQuality::Manual),
        ('8', FixQuality::Simulation),
    ] {
        let body = GGA_RTK.replace(",W,4,", &format!(",W,{digit},"));
        let fix = only_fix(&read(sentence(&body).as_bytes()).0);
        assert_eq!(fix.quality, quality, "digit {digit}");
        assert_eq!(fix.lat_deg.is_nan(), quality == FixQuality::NoFix);
        if digit != '3' {
            assert_eq!(char::from(b'0' + quality.gga_digit()), digit);
        }
    }
}

#[test]
fn gga_without_position_is_fix_loss() {
    let (samples, stats) = read(sentence("GPGGA,123519.00,,,,,4,05,,,M,,M,,").as_bytes());
    let fix = only_fix(&samples);
    assert_eq!(fix.quality, FixQuality::NoFix);
    assert!(fix.lat_deg.is_nan() && fix.lon_deg.is_nan() && fix.alt_msl_m.is_nan());
    assert!(fix.hdop.is_nan());
    assert_eq!(stats.sentences, 1);
}

#[test]
fn rmc_velocity_and_time() {
    let body = "GNRMC,235959.50,A,4807.0380000,N,01131.0000000,E,3.888,271.250,311224,,,R";
    let (samples, _) = read(sentence(body).as_bytes());
    let [GnssSample::Velocity(vel), GnssSample::Time(time)] = samples[..] else {
        panic!("{samples:?}");
    };
    assert!((vel.speed_mps - 3.888 * 1852.0 / 3600.0).abs() < 1e-6);
    assert!((vel.course_deg.unwrap() - 271.25).abs() < 1e-4);
    // 2024-12-31T23:59:59.5Z
    assert_eq!(time.utc_unix_us, 1_735_689_599_500_000);

    let stationary = "GNRMC,235959.50,A,4807.0380000,N,01131.0000000,E,0.000,,311224,,,R";
    let (samples, _) = read(sentence(stationary).as_bytes());
    let GnssSample::Velocity(vel) = samples[0] else {
        panic!()
    };
    assert_eq!((vel.speed_mps, vel.course_deg), (0.0, None));

    let (samples, stats) = read(sentence("GNRMC,235959.50,V,,,,,,,311224,,,N").as_bytes());
    assert!(samples.is_empty());
    assert_eq!(stats.sentences, 1);
}

#[test]
fn vtg_gst_hdt() {
    let mut bytes = sentence("GPVTG,054.7,T,034.4,M,005.5,N,010.2,K,A");
    bytes += &sentence("GNGST,172814.00,0.006,0.023,0.020,273.6,0.0112,0.0113,0.0200");
    bytes += &sentence("GNHDT,359.950,T");
    let (samples, stats) = read(bytes.as_bytes());
    assert_eq!(stats.sentences, 3);
    let [
        GnssSample::Velocity(vel),
        GnssSample::Accuracy(acc),
        GnssSample::Heading(hdg),
    ] = samples[..]
    else {
        panic!("{samples:?}");
    };
    assert!((vel.speed_mps - 5.5 * 1852.0 / 3600.0).abs() < 1e-6);
    assert!((vel.course_deg.unwrap() - 54.7).abs() < 1e-4);
    assert!((acc.sigma_north_m - 0.0112).abs() < 1e-6);
    assert!((acc.sigma_east_m - 0.0113).abs() < 1e-6);
    assert!((acc.sigma_up_m.unwrap() - 0.02).abs() < 1e-6);
    assert!((hdg.heading_deg - 359.95).abs() < 1e-4);
}

#[test]
fn every_talker_is_read() {
    let expected = only_fix(&read(sentence(GGA_RTK).as_bytes()).0);
    for talker in ["GP", "GN", "GL", "GA", "GB", "BD", "GQ", "GI"] {
        let body = format!("{talker}{}", &GGA_RTK[2..]);
        let (samples, stats) = read(sentence(&body).as_bytes());
        assert_eq!(only_fix(&samples), expected, "{talker}");
        assert_eq!(stats.sentences, 1);
        let (samples, _) = read(sentence(&format!("{talker}HDT,12.5,T")).as_bytes());
        assert!(matches!(samples[..], [GnssSample::Heading(_)]), "{talker}");
    }
}

#[test]
fn ths_only_when_autonomous() {
    let (samples, stats) = read(sentence("GNTHS,77.52,A").as_bytes());
    assert_eq!(
        samples,
        [GnssSample::Heading(GnssHeading {
            t: T,
            heading_deg: 77.52,
            reference: HeadingReference::True,
        })]
    );
    assert_eq!(stats.sentences, 1);
    for mode in ["E", "M", "S", "V"] {
        let (samples, stats) = read(sentence(&format!("GNTHS,77.52,{mode}")).as_bytes());
        assert!(samples.is_empty(), "{mode}");
        assert_eq!(stats.sentences, 1);
    }
    let (samples, stats) = read(sentence("GNTHS,,V").as_bytes());
    assert!(samples.is_empty());
    assert_eq!(stats.sentences, 1);

    for bad in [
        "GNTHS,77.52,X",
        "GNTHS,abc,A",
        "GNTHS,77.52",
        "GNTHS,1,A,2",
        "GNTHS,inf,A",
    ] {
        let (samples, stats) = read(sentence(bad).as_bytes());
        assert!(samples.is_empty(), "{bad}");
        assert_eq!(
            stats,
            NmeaStats {
                malformed: 1,
                ..NmeaStats::default()
            },
            "{bad}"
        );
    }
    let (samples, stats) = read(b"$GNTHS,77.52,A*00\r\n");
    assert!(samples.is_empty());
    assert_eq!(stats.checksum_errors, 1);
}

#[test]
fn compass_headings_are_magnetic_with_deviation_applied() {
    let heading = |body: &str| match read(sentence(body).as_bytes()).0[..] {
        [GnssSample::Heading(h)] => Some((h.heading_deg, h.reference)),
        _ => None,
    };
    assert_eq!(heading("HCHDM,238.5,M"), Some((238.5, HeadingReference::Magnetic)));
    assert_eq!(
        heading("HCHDG,98.3,1.5,E,12.6,W"),
        Some((99.8, HeadingReference::Magnetic))
    );
    assert_eq!(heading("HCHDG,98.3,1.5,W,,"), Some((96.8, HeadingReference::Magnetic)));
    assert_eq!(heading("HCHDG,98.3,,,,"), Some((98.3, HeadingReference::Magnetic)));
    assert_eq!(heading("GNHDT,98.5,T"), Some((98.5, HeadingReference::True)));
    let (samples, stats) = read(sentence("HCHDM,,M").as_bytes());
    assert!(samples.is_empty());
    assert_eq!(stats.sentences, 1, "an empty heading is a valid 'no heading'");
    for bad in [
        "HCHDM,238.5,T",
        "HCHDM,abc,M",
        "HCHDM,1,M,2",
        "HCHDG,98.3,1.5,N,12.6,W",
        "HCHDG,98.3,1.5,E,12.6",
        "HCHDG,98.3,x,E,12.6,W",
        "HCHDG,NaN,1.5,E,12.6,W",
    ] {
        let (samples, stats) = read(sentence(bad).as_bytes());
        assert!(samples.is_empty(), "{bad}");
        assert_eq!(stats.malformed, 1, "{bad}");
    }
}

#[test]
fn bad_checksum_is_counted_and_dropped() {
    let good = sentence(GGA_RTK);
    let bad = good.replace("545.432", "545.433");
    let (samples, stats) = read(format!("{bad}{good}").as_bytes());
    assert_eq!(samples.len(), 1);
    assert_eq!(
        stats,
        NmeaStats {
            sentences: 1,
            checksum_errors: 1,
            ..NmeaStats::default()
        }
    );
    // Lower-case hex is valid; a sign or a third digit is not.
    let body = "GNHDT,1.5,T";
    let sum = nmea_checksum(body.as_bytes());
    let (_, stats) = read(format!("${body}*{sum:02x}\r\n${body}*+{sum:X}\r\n${body}*{sum:02X}0\r\n").as_bytes());
    assert_eq!(
        stats,
        NmeaStats {
            sentences: 1,
            malformed: 2,
            ..NmeaStats::default()
        }
    );
}

#[test]
fn truncated_and_garbage_lines_are_malformed() {
    let good = sentence(GGA_RTK);
    // Cut mid-sentence (no checksum), then the next sentence with no line end between.
    let truncated = &good[..30];
    let stream = format!("{truncated}{good}hello world\r\n\u{00e9}{good}");
    let (samples, stats) = read(stream.as_bytes());
    assert_eq!(samples.len(), 2);
    // The truncated GGA, the garbage line, and the lone non-ASCII byte before `$`.
    assert_eq!(
        stats,
        NmeaStats {
            sentences: 2,
            malformed: 3,
            ..NmeaStats::default()
        }
    );

    // Fields the nmea crate rejects, with a valid checksum.
    let (samples, stats) = read(sentence("GNGGA,123519.00,4807.038,N,01131.324,E,9,08,0.9,1,M,,M,,").as_bytes());
    assert!(samples.is_empty());
    assert_eq!(stats.malformed, 1);
    // Impossible latitude.
    let (samples, stats) = read(sentence("GNGGA,123519.00,9507.038,N,01131.324,E,1,08,0.9,1,M,,M,,").as_bytes());
    assert!(samples.is_empty());
    assert_eq!(stats.malformed, 1);
}

#[test]
fn unknown_types_are_unsupported() {
    let mut bytes = sentence("GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,2.1");
    bytes += &sentence("PUBX,00,081350.00,4717.113210,N");
    bytes += &sentence("GPXYZ,1,2");
    bytes += &sentence("AIVDM,1,1,,A,13aG?P0P00PD;88MD5MTDww@2D7k,0").replacen('$', "!", 1);
    let (samples, stats) = read(bytes.as_bytes());
    assert!(samples.is_empty());
    assert_eq!(
        stats,
        NmeaStats {
            unsupported: 4,
            ..NmeaStats::default()
        }
    );
}

#[test]
fn overlong_lines_are_counted_once_and_bounded() {
    let long = format!("$GPTXT,{}", "A".repeat(200));
    let good = sentence(GGA_RTK);
    let (samples, stats) = read(format!("{long}\r\n{good}").as_bytes());
    assert_eq!(samples.len(), 1);
    assert_eq!(
        stats,
        NmeaStats {
            sentences: 1,
            overlong: 1,
            ..NmeaStats::default()
        }
    );

    // 10 kB that never ends: counted when it crosses the limit, memory stays put.
    let mut reader = NmeaReader::new();
    let size_before = std::mem::size_of_val(&reader);
    let mut out = Vec::new();
    for chunk in vec![b'7'; 10_240].chunks(1000) {
        reader.push(T, chunk, &mut out);
        assert!(reader.pending_len() <= MAX_SENTENCE_LEN);
    }
    assert_eq!(reader.pending_len(), 0, "the overlong line is being discarded");
    assert_eq!(reader.stats().overlong, 1);
    assert_eq!(std::mem::size_of_val(&reader), size_before);
    reader.push(T, good.as_bytes(), &mut out);
    assert_eq!(out.len(), 1, "a `$` resynchronises");
    assert_eq!(reader.stats().total(), 2);

    // Exactly at the limit is still a sentence.
    let body = format!("GNTXT,{}", "B".repeat(MAX_SENTENCE_LEN - 10));
    let at_limit = sentence(&body);
    assert_eq!(at_limit.trim_end().len(), MAX_SENTENCE_LEN);
    assert_eq!(read(at_limit.as_bytes()).1.unsupported, 1);
}

#[test]
fn byte_by_byte_equals_one_push() {
    let mut stream = sentence(GGA_RTK);
    stream += "junk\r\n";
    stream += &sentence("GNRMC,235959.50,A,4807.0380000,N,01131.0000000,E,3.888,271.250,311224,,,R");
    stream += &sentence("GNTHS,77.52,A");
    stream += &sentence("GNHDT,1.000,T").replace("*", "*0");
    stream += &sentence("GNGST,172814.00,0.006,0.023,0.020,273.6,0.0112,0.0113,0.0200");
    let (whole, whole_stats) = read(stream.as_bytes());
    let mut reader = NmeaReader::new();
    let mut out = Vec::new();
    for byte in stream.as_bytes() {
        reader.push(T, std::slice::from_ref(byte), &mut out);
    }
    assert_eq!(out, whole);
    assert_eq!(reader.stats(), whole_stats);
    assert_eq!(whole.len(), 5);
}

/// Lines as the reader frames them: CR/LF end a line, `$` starts one; an
/// unterminated last line counts only once it is overlong.
fn reference_line_count(bytes: &[u8]) -> u64 {
    let (mut lines, mut len) = (0, 0usize);
    for &b in bytes {
        match b {
            b'\r' | b'\n' => {
                lines += u64::from(len > 0);
                len = 0;
            }
            b'$' => {
                lines += u64::from(len > 0);
                len = 1;
            }
            _ => len += 1,
        }
    }
    lines + u64::from(len > MAX_SENTENCE_LEN)
}

fn noisy_bytes() -> impl Strategy<Value = Vec<u8>> {
    // Weighted towards NMEA-ish bytes so framing paths are exercised.
    let byte = prop_oneof![
        4 => any::<u8>(),
        2 => Just(b'$'),
        2 => Just(b'*'),
        2 => Just(b','),
        1 => Just(b'\r'),
        1 => Just(b'\n'),
        4 => prop::sample::select(b"GNPGAT0123456789ABCDEF.".to_vec()),
    ];
    prop::collection::vec(byte, 0..600)
}

proptest! {
    #[test]
    fn random_bytes_never_panic_and_stats_add_up(
        bytes in noisy_bytes(),
        cuts in prop::collection::vec(any::<prop::sample::Index>(), 0..8),
    ) {
        let (whole, stats) = read(&bytes);
        prop_assert_eq!(stats.total(), reference_line_count(&bytes));
        prop_assert!(whole.len() as u64 <= 2 * stats.sentences);

        // Any chunking gives the same samples and counters.
        let mut points: Vec<usize> = cuts.iter().map(|i| i.index(bytes.len() + 1)).collect();
        points.sort_unstable();
        let mut reader = NmeaReader::new();
        let mut out = Vec::new();
        let mut from = 0;
        for to in points.into_iter().chain([bytes.len()]) {
            reader.push(T, &bytes[from..to], &mut out);
            from = to;
        }
        prop_assert_eq!(reader.stats(), stats);
        prop_assert_eq!(out.len(), whole.len());
        prop_assert!(reader.pending_len() <= MAX_SENTENCE_LEN);
    }

    #[test]
    fn a_good_sentence_survives_any_garbage_before_it(garbage in noisy_bytes()) {
        let mut bytes = garbage;
        bytes.extend_from_slice(b"\r\n");
        bytes.extend_from_slice(sentence(GGA_RTK).as_bytes());
        let (samples, _) = read(&bytes);
        let expected = only_fix(&read(sentence(GGA_RTK).as_bytes()).0);
        prop_assert_eq!(samples.last(), Some(&GnssSample::Fix(expected)));
    }
}
