//! The parameter microservice, message by message.

use mavlink::dialects::ardupilotmega::{
    MavMessage, MavParamError, MavParamType, PARAM_REQUEST_LIST_DATA, PARAM_REQUEST_READ_DATA, PARAM_SET_DATA,
    PARAM_VALUE_DATA,
};
use params::service::{Outgoing, ParamNotice, ParamService, Reply, Sender};
use params::{ParamDef, ParamFlags, ParamName, ParamTable, ParamTableBuilder, ParamType};

const GCS: Sender = Sender {
    system_id: 255,
    component_id: 190,
};

fn def(name: &str, ty: ParamType, default: f64, min: f64, max: f64, read_only: bool) -> ParamDef {
    ParamDef {
        name: ParamName::new(name.to_owned()).unwrap(),
        ty,
        default,
        min,
        max,
        unit: "",
        description: "",
        flags: ParamFlags {
            read_only,
            reboot_required: name == "SYSID_THISMAV",
        },
    }
}

fn table() -> ParamTable {
    let mut b = ParamTableBuilder::new();
    b.add(def("WP_SPEED", ParamType::Real32, 2.0, 0.0, 10.0, false));
    b.add(def("FS_ACTION", ParamType::Int8, 2.0, 0.0, 5.0, false));
    b.add(def("SYSID_THISMAV", ParamType::Int16, 1.0, 1.0, 255.0, false));
    b.add(def("STAT_BOOTCNT", ParamType::Int32, 0.0, 0.0, 1e6, true));
    // Exactly 16 characters: no terminator on the wire.
    b.add(def("ABCDEFGHIJKLMNOP", ParamType::Real32, 0.5, 0.0, 1.0, false));
    for i in 0..45 {
        b.add(def(&format!("FILL_{i}"), ParamType::Real32, 0.0, -1.0, 1.0, false));
    }
    b.build()
}

fn id(name: &str) -> [u8; 16] {
    let mut id = [0u8; 16];
    id[..name.len()].copy_from_slice(name.as_bytes());
    id
}

fn set(name: &str, value: f32) -> MavMessage {
    MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: value,
        target_system: 1,
        target_component: 1,
        param_id: id(name).into(),
        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
    })
}

fn read(name: &str, index: i16) -> MavMessage {
    MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
        param_index: index,
        target_system: 1,
        target_component: 1,
        param_id: id(name).into(),
    })
}

struct Run {
    out: Vec<Outgoing<u8>>,
    notices: Vec<ParamNotice>,
}

fn run(service: &mut ParamService<u8>, table: &mut ParamTable, message: MavMessage) -> Run {
    let mut r = Run {
        out: Vec::new(),
        notices: Vec::new(),
    };
    assert!(service.handle(table, 7, GCS, &message, &mut r.out, &mut r.notices));
    r
}

fn values(out: &[Outgoing<u8>]) -> Vec<(Reply<u8>, PARAM_VALUE_DATA)> {
    out.iter()
        .filter_map(|o| match &o.message {
            MavMessage::PARAM_VALUE(v) => Some((o.dest, v.clone())),
            _ => None,
        })
        .collect()
}

fn name_of(v: &PARAM_VALUE_DATA) -> String {
    let raw: [u8; 16] = v.param_id.into();
    let len = raw.iter().position(|b| *b == 0).unwrap_or(16);
    String::from_utf8(raw[..len].to_vec()).unwrap()
}

#[test]
fn list_streams_every_parameter_once_with_index_and_count() {
    let mut t = table();
    let mut s = ParamService::new();
    let r = run(
        &mut s,
        &mut t,
        MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA {
            target_system: 1,
            target_component: 0,
        }),
    );
    assert!(r.out.is_empty(), "the list goes out at the next poll");
    let mut out = Vec::new();
    s.poll(&t, &mut out);
    assert!(
        !s.is_streaming(7),
        "the whole table in one poll: the link layer paces it"
    );
    let got = values(&out);
    assert_eq!(got.len(), t.len());
    for (i, (dest, v)) in got.iter().enumerate() {
        assert_eq!(*dest, Reply::Link(7));
        assert_eq!(v.param_index as usize, i);
        assert_eq!(v.param_count as usize, t.len());
    }
    assert_eq!(name_of(&got[4].1), "ABCDEFGHIJKLMNOP");
    let raw: [u8; 16] = got[4].1.param_id.into();
    assert_eq!(&raw, b"ABCDEFGHIJKLMNOP", "16 characters, no terminator");
}

#[test]
fn read_by_id_by_index_and_a_16_character_id() {
    let mut t = table();
    let mut s = ParamService::new();
    let r = run(&mut s, &mut t, read("FS_ACTION", -1));
    let v = values(&r.out);
    assert_eq!(
        (name_of(&v[0].1), v[0].1.param_value, v[0].1.param_index),
        ("FS_ACTION".to_string(), 2.0, 1)
    );
    assert_eq!(v[0].1.param_type, MavParamType::MAV_PARAM_TYPE_INT8);
    let r = run(&mut s, &mut t, read("", 0));
    assert_eq!(name_of(&values(&r.out)[0].1), "WP_SPEED");
    let r = run(&mut s, &mut t, read("ABCDEFGHIJKLMNOP", -1));
    assert_eq!(values(&r.out)[0].1.param_value, 0.5);
}

#[test]
fn unknown_reads_get_param_error_and_a_notice() {
    let mut t = table();
    let mut s = ParamService::new();
    for message in [read("NO_SUCH", -1), read("", 500)] {
        let r = run(&mut s, &mut t, message);
        assert!(values(&r.out).is_empty());
        assert!(r.out.iter().any(|o| matches!(&o.message, MavMessage::PARAM_ERROR(e)
            if e.error == MavParamError::MAV_PARAM_ERROR_DOES_NOT_EXIST && e.target_system == 255 && e.target_component == 190)));
        assert!(matches!(&r.notices[0], ParamNotice::Refused { .. }));
    }
}

#[test]
fn set_echoes_the_new_value_to_all_links() {
    let mut t = table();
    let mut s = ParamService::new();
    let r = run(&mut s, &mut t, set("WP_SPEED", 3.5));
    let v = values(&r.out);
    assert_eq!(v.len(), 1);
    assert_eq!(v[0].0, Reply::AllLinks);
    assert_eq!(v[0].1.param_value, 3.5);
    assert_eq!(r.notices, vec![ParamNotice::Changed { index: 0 }]);
    assert_eq!(t.value_of("WP_SPEED"), Some(3.5));
}

#[test]
fn integer_parameters_round_and_ignore_the_sent_type() {
    let mut t = table();
    let mut s = ParamService::new();
    let r = run(&mut s, &mut t, set("FS_ACTION", 1.0));
    assert_eq!(values(&r.out)[0].1.param_value, 1.0);
    assert_eq!(t.value_of("FS_ACTION"), Some(1.0));
}

#[test]
fn refused_sets_keep_the_old_value_and_still_echo_it() {
    let mut t = table();
    let mut s = ParamService::new();
    for (name, value, error) in [
        ("WP_SPEED", f32::NAN, MavParamError::MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE),
        (
            "WP_SPEED",
            f32::INFINITY,
            MavParamError::MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE,
        ),
        ("WP_SPEED", 11.0, MavParamError::MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE),
        ("STAT_BOOTCNT", 5.0, MavParamError::MAV_PARAM_ERROR_READ_ONLY),
    ] {
        let r = run(&mut s, &mut t, set(name, value));
        let v = values(&r.out);
        assert_eq!(v.len(), 1, "{name}={value}: always an echo");
        assert_eq!(v[0].0, Reply::AllLinks);
        assert_eq!(
            f64::from(v[0].1.param_value),
            t.value_of(name).unwrap(),
            "the old value"
        );
        assert!(
            r.out
                .iter()
                .any(|o| matches!(&o.message, MavMessage::PARAM_ERROR(e) if e.error == error)),
            "{name}={value}"
        );
        match &r.notices[..] {
            [ParamNotice::Refused { text }] => assert!(text.starts_with(name), "{text}"),
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(t.value_of("WP_SPEED"), Some(2.0));
    assert_eq!(t.value_of("STAT_BOOTCNT"), Some(0.0));
}

#[test]
fn unknown_set_gets_param_error_but_no_value() {
    let mut t = table();
    let mut s = ParamService::new();
    let r = run(&mut s, &mut t, set("NO_SUCH", 1.0));
    assert!(values(&r.out).is_empty());
    assert!(r.out.iter().any(
        |o| matches!(&o.message, MavMessage::PARAM_ERROR(e) if e.error == MavParamError::MAV_PARAM_ERROR_DOES_NOT_EXIST)
    ));
}

#[test]
fn reboot_required_parameters_say_so() {
    let mut t = table();
    let mut s = ParamService::new();
    let r = run(&mut s, &mut t, set("SYSID_THISMAV", 7.0));
    assert!(r.notices.contains(&ParamNotice::RebootRequired {
        name: "SYSID_THISMAV".into()
    }));
}

#[test]
fn hash_check_changes_with_any_value_and_stops_a_stream() {
    let mut t = table();
    let mut s = ParamService::new();
    let hash = |t: &mut ParamTable, s: &mut ParamService<u8>| {
        let r = run(s, t, read("_HASH_CHECK", -1));
        let v = values(&r.out);
        assert_eq!(v[0].1.param_type, MavParamType::MAV_PARAM_TYPE_UINT32);
        assert_eq!(v[0].1.param_index, u16::MAX);
        v[0].1.param_value.to_bits()
    };
    let h0 = hash(&mut t, &mut s);
    assert_eq!(h0, hash(&mut t, &mut s), "stable");
    run(&mut s, &mut t, set("FILL_3", 0.25));
    let h1 = hash(&mut t, &mut s);
    assert_ne!(h0, h1);
    run(&mut s, &mut t, set("FILL_3", 0.0));
    assert_eq!(
        h0,
        hash(&mut t, &mut s),
        "back to the same values, back to the same hash"
    );

    run(
        &mut s,
        &mut t,
        MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA {
            target_system: 1,
            target_component: 1,
        }),
    );
    assert!(s.is_streaming(7));
    let r = run(&mut s, &mut t, set("_HASH_CHECK", 0.0));
    assert!(r.out.is_empty());
    assert!(!s.is_streaming(7));
}

#[test]
fn saving_first_a_new_value_is_echoed_only_once_saved() {
    let mut t = table();
    let mut s = ParamService::new();
    s.set_save_first(true);
    let r = run(&mut s, &mut t, set("WP_SPEED", 3.5));
    assert!(values(&r.out).is_empty(), "no echo before the save: {:?}", r.out);
    assert_eq!(r.notices, vec![ParamNotice::SaveRequested { index: 0, value: 3.5 }]);
    assert_eq!(t.value_of("WP_SPEED"), Some(2.0), "not in force before the save");
    let (mut out, mut notices) = (Vec::new(), Vec::new());
    s.apply_saved(&mut t, 0, 3.5, &mut out, &mut notices);
    let v = values(&out);
    assert_eq!((v[0].0, v[0].1.param_value), (Reply::AllLinks, 3.5));
    assert_eq!(notices, vec![ParamNotice::Changed { index: 0 }]);
    assert_eq!(t.value_of("WP_SPEED"), Some(3.5));
    // Reboot-required parameters still say so once saved.
    let r = run(&mut s, &mut t, set("SYSID_THISMAV", 9.0));
    assert_eq!(r.notices, vec![ParamNotice::SaveRequested { index: 2, value: 9.0 }]);
    let (mut out, mut notices) = (Vec::new(), Vec::new());
    s.apply_saved(&mut t, 2, 9.0, &mut out, &mut notices);
    assert!(notices.contains(&ParamNotice::RebootRequired {
        name: "SYSID_THISMAV".into()
    }));
}

#[test]
fn saving_first_a_failed_save_echoes_the_old_value_and_says_why() {
    let mut t = table();
    let mut s = ParamService::new();
    s.set_save_first(true);
    let r = run(&mut s, &mut t, set("WP_SPEED", 3.5));
    let Some(ParamNotice::SaveRequested { index, .. }) = r.notices.first().cloned() else {
        panic!("{:?}", r.notices);
    };
    let (mut out, mut notices) = (Vec::new(), Vec::new());
    s.refuse_unsaved(
        &t,
        index,
        "params.parm: No space left on device",
        &mut out,
        &mut notices,
    );
    let v = values(&out);
    assert_eq!((v[0].0, v[0].1.param_value), (Reply::AllLinks, 2.0), "the old value");
    match &notices[..] {
        [ParamNotice::Refused { text }] => {
            assert!(text.contains("WP_SPEED") && text.contains("No space left"), "{text}")
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(t.value_of("WP_SPEED"), Some(2.0));
}

#[test]
fn saving_first_unchanged_and_refused_values_are_answered_at_once() {
    let mut t = table();
    let mut s = ParamService::new();
    s.set_save_first(true);
    // The value in force: nothing to save, echoed now.
    let r = run(&mut s, &mut t, set("WP_SPEED", 2.0));
    assert_eq!(values(&r.out)[0].1.param_value, 2.0);
    assert!(r.notices.is_empty());
    // Out of range: refused as before, nothing to save.
    let r = run(&mut s, &mut t, set("WP_SPEED", 99.0));
    assert_eq!(values(&r.out)[0].1.param_value, 2.0);
    assert!(
        matches!(r.notices[..], [ParamNotice::Refused { .. }]),
        "{:?}",
        r.notices
    );
}
