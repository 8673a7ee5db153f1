//! Property tests: parameter files never panic the parser, and what Furrow
//! writes it reads back exactly.

use params::files::{FileFormat, format_mission_planner, format_qgroundcontrol, parse};
use params::{ParamDef, ParamFlags, ParamName, ParamType};
use proptest::prelude::*;

proptest! {
    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,400}") {
        let _ = parse(&text, FileFormat::MissionPlanner);
        let _ = parse(&text, FileFormat::QGroundControl);
    }

    #[test]
    fn written_files_read_back(values in proptest::collection::vec((-1.0e6f32..1.0e6f32, -30000i16..30000), 1..40)) {
        let defs: Vec<(ParamDef, f64)> = values
            .iter()
            .enumerate()
            .flat_map(|(i, (f, n))| {
                let float = ParamDef {
                    name: ParamName::new(format!("F_{i}")).unwrap(),
                    ty: ParamType::Real32, default: 0.0, min: -1e7, max: 1e7,
                    unit: "", description: "", flags: ParamFlags::default(),
                };
                let int = ParamDef { name: ParamName::new(format!("I_{i}")).unwrap(), ty: ParamType::Int16, ..float.clone() };
                [(float, f64::from(*f)), (int, f64::from(*n))]
            })
            .collect();
        for (format, text) in [
            (FileFormat::MissionPlanner, format_mission_planner(defs.iter().map(|(d, v)| (d, *v)), "test")),
            (FileFormat::QGroundControl, format_qgroundcontrol(defs.iter().map(|(d, v)| (d, *v)), 1, 1, "test")),
        ] {
            let back = parse(&text, format).unwrap();
            prop_assert_eq!(back.len(), defs.len());
            for e in back {
                let (d, v) = defs.iter().find(|(d, _)| d.name.as_str() == e.name).unwrap();
                match d.ty {
                    ParamType::Real32 => prop_assert_eq!(e.value as f32, *v as f32),
                    _ => prop_assert_eq!(e.value, *v),
                }
            }
        }
    }
}
