//! The parameter table: built once, then fixed in size and order.

use std::collections::HashMap;
use std::fmt;

use crate::def::{ParamDef, ParamName};

/// Why a value was refused. The table keeps the old value in every case.
#[derive(Clone, Debug, PartialEq)]
pub enum SetError {
    UnknownName(String),
    NotFinite,
    OutOfRange { min: f64, max: f64 },
    ReadOnly,
}

impl fmt::Display for SetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SetError::UnknownName(n) => write!(f, "unknown parameter {n}"),
            SetError::NotFinite => write!(f, "value is not a finite number"),
            SetError::OutOfRange { min, max } => write!(f, "value outside {min}..{max}"),
            SetError::ReadOnly => write!(f, "parameter is read-only"),
        }
    }
}

impl std::error::Error for SetError {}

/// Collects declarations; [`ParamTableBuilder::build`] freezes them.
#[derive(Default)]
pub struct ParamTableBuilder {
    defs: Vec<ParamDef>,
    default_overrides: Vec<(String, f64)>,
}

impl ParamTableBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a declaration and returns its index in the final table.
    ///
    /// # Panics
    /// On an inconsistent declaration or a duplicate name: both are
    /// programming errors that must fail the first test that builds the table.
    pub fn add(&mut self, mut def: ParamDef) -> u16 {
        // Declarations are written in f64; the table holds what the type holds.
        def.default = def.ty.quantize(def.default);
        if let Err(e) = def.check() {
            panic!("bad parameter declaration: {e}");
        }
        assert!(
            !self.defs.iter().any(|d| d.name == def.name),
            "parameter {} declared twice",
            def.name
        );
        let index = u16::try_from(self.defs.len()).expect("more than 65535 parameters");
        self.defs.push(def);
        index
    }

    /// Replaces the default of an already declared parameter (a vehicle
    /// profile, as ArduPilot's `--defaults` file). Values stored by the user
    /// still win over it.
    pub fn override_default(&mut self, name: &str, value: f64) {
        self.default_overrides.push((name.to_owned(), value));
    }

    /// Freezes the table with every parameter at its default.
    ///
    /// # Panics
    /// When a default override names an unknown parameter or lies outside the
    /// declared range (a programming error).
    pub fn build(mut self) -> ParamTable {
        for (name, value) in std::mem::take(&mut self.default_overrides) {
            let def = self
                .defs
                .iter_mut()
                .find(|d| d.name.as_str() == name)
                .unwrap_or_else(|| panic!("default override for unknown parameter {name}"));
            let value = def.ty.quantize(value);
            assert!(
                value >= def.min && value <= def.max,
                "default override {name}={value} outside {}..{}",
                def.min,
                def.max
            );
            def.default = value;
        }
        let by_name = self
            .defs
            .iter()
            .enumerate()
            .map(|(i, d)| (d.name.as_str().to_owned(), i as u16))
            .collect();
        let values = self.defs.iter().map(|d| d.default).collect();
        ParamTable {
            defs: self.defs,
            values,
            by_name,
            generation: 0,
        }
    }
}

/// Every parameter of the process with its current value.
///
/// Invariant: the set of parameters and their order never change after
/// [`ParamTableBuilder::build`], so `param_index` is stable for the life of
/// the process.
#[derive(Clone, Debug)]
pub struct ParamTable {
    defs: Vec<ParamDef>,
    values: Vec<f64>,
    by_name: HashMap<String, u16>,
    generation: u64,
}

impl ParamTable {
    pub fn len(&self) -> usize {
        self.defs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.defs.is_empty()
    }

    pub fn index_of(&self, name: &str) -> Option<u16> {
        self.by_name.get(name).copied()
    }

    pub fn def(&self, index: u16) -> &ParamDef {
        &self.defs[usize::from(index)]
    }

    /// Current value of the parameter at `index`.
    pub fn value(&self, index: u16) -> f64 {
        self.values[usize::from(index)]
    }

    /// Current value by name.
    pub fn value_of(&self, name: &str) -> Option<f64> {
        self.index_of(name).map(|i| self.value(i))
    }

    /// Counts changes; a consumer that caches derived values compares it.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Validates and stores `value` (rounded to the parameter's type),
    /// returning the value now held. On error nothing changes.
    pub fn set(&mut self, index: u16, value: f64) -> Result<f64, SetError> {
        let def = &self.defs[usize::from(index)];
        if def.flags.read_only {
            return Err(SetError::ReadOnly);
        }
        self.set_unchecked_access(index, value)
    }

    /// Like [`ParamTable::set`] but also writes read-only parameters: for the
    /// vehicle's own bookkeeping values, never for requests from outside.
    pub fn set_internal(&mut self, index: u16, value: f64) -> Result<f64, SetError> {
        self.set_unchecked_access(index, value)
    }

    /// Sets by name.
    pub fn set_by_name(&mut self, name: &str, value: f64) -> Result<f64, SetError> {
        let index = self
            .index_of(name)
            .ok_or_else(|| SetError::UnknownName(name.to_owned()))?;
        self.set(index, value)
    }

    /// What [`ParamTable::set`] would store, without storing it (a change
    /// that must be saved before it is in force).
    pub fn check(&self, index: u16, value: f64) -> Result<f64, SetError> {
        if self.defs[usize::from(index)].flags.read_only {
            return Err(SetError::ReadOnly);
        }
        self.check_value(index, value)
    }

    fn check_value(&self, index: u16, value: f64) -> Result<f64, SetError> {
        let def = &self.defs[usize::from(index)];
        if !value.is_finite() {
            return Err(SetError::NotFinite);
        }
        let value = def.ty.quantize(value);
        if value < def.min || value > def.max {
            return Err(SetError::OutOfRange {
                min: def.min,
                max: def.max,
            });
        }
        Ok(value)
    }

    fn set_unchecked_access(&mut self, index: u16, value: f64) -> Result<f64, SetError> {
        let value = self.check_value(index, value)?;
        let slot = &mut self.values[usize::from(index)];
        if *slot != value {
            *slot = value;
            self.generation += 1;
        }
        Ok(value)
    }

    /// `(definition, value)` in table order.
    pub fn iter(&self) -> impl Iterator<Item = (&ParamDef, f64)> {
        self.defs.iter().zip(self.values.iter().copied())
    }

    /// Parameters whose value differs from the default, in table order.
    pub fn non_defaults(&self) -> impl Iterator<Item = (&ParamName, f64)> {
        self.iter().filter(|(d, v)| *v != d.default).map(|(d, v)| (&d.name, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::def::{ParamFlags, ParamType};

    fn def(name: &'static str, ty: ParamType, default: f64, min: f64, max: f64) -> ParamDef {
        ParamDef {
            name: ParamName::new(name).unwrap(),
            ty,
            default,
            min,
            max,
            unit: "",
            description: "test",
            flags: ParamFlags::default(),
        }
    }

    fn table() -> ParamTable {
        let mut b = ParamTableBuilder::new();
        b.add(def("WP_SPEED", ParamType::Real32, 2.0, 0.0, 10.0));
        b.add(def("FS_ACTION", ParamType::Int8, 2.0, 0.0, 5.0));
        b.build()
    }

    #[test]
    fn set_validates_and_keeps_old_value_on_refusal() {
        let mut t = table();
        assert_eq!(t.set_by_name("WP_SPEED", 3.5), Ok(3.5));
        assert_eq!(t.set_by_name("WP_SPEED", f64::NAN), Err(SetError::NotFinite));
        assert_eq!(
            t.set_by_name("WP_SPEED", 11.0),
            Err(SetError::OutOfRange { min: 0.0, max: 10.0 })
        );
        assert_eq!(t.value_of("WP_SPEED"), Some(3.5));
        assert!(matches!(t.set_by_name("NOPE", 1.0), Err(SetError::UnknownName(_))));
    }

    #[test]
    fn minus_zero_is_zero_so_the_hash_survives_a_reload() {
        let mut t = table();
        t.set_by_name("WP_SPEED", 3.0).unwrap();
        assert_eq!(t.set_by_name("WP_SPEED", -0.0).map(f64::to_bits), Ok(0.0f64.to_bits()));
        assert_eq!(t.value_of("WP_SPEED").map(f64::to_bits), Some(0.0f64.to_bits()));
        // What a restart gives: the stored file read back into a fresh table.
        let file = crate::store::Snapshot::of(&t).render();
        let mut reloaded = table();
        for e in crate::files::parse(&file, crate::files::FileFormat::MissionPlanner).unwrap() {
            reloaded.set_by_name(&e.name, e.value).unwrap();
        }
        assert_eq!(crate::hash::table_hash(&reloaded), crate::hash::table_hash(&t));
    }

    #[test]
    fn integers_round_and_generation_counts_changes() {
        let mut t = table();
        let g = t.generation();
        assert_eq!(t.set_by_name("FS_ACTION", 1.4), Ok(1.0));
        assert_eq!(t.generation(), g + 1);
        assert_eq!(t.set_by_name("FS_ACTION", 1.0), Ok(1.0));
        assert_eq!(t.generation(), g + 1, "same value is not a change");
    }

    #[test]
    fn read_only_refuses_outside_writes() {
        let mut b = ParamTableBuilder::new();
        let mut d = def("STAT_RUNTIME", ParamType::Int32, 0.0, 0.0, 1e9);
        d.flags.read_only = true;
        let i = b.add(d);
        let mut t = b.build();
        assert_eq!(t.set(i, 5.0), Err(SetError::ReadOnly));
        assert_eq!(t.set_internal(i, 5.0), Ok(5.0));
    }

    #[test]
    fn default_override_changes_default_not_declaration_order() {
        let mut b = ParamTableBuilder::new();
        b.add(def("WP_SPEED", ParamType::Real32, 2.0, 0.0, 10.0));
        b.add(def("FS_ACTION", ParamType::Int8, 2.0, 0.0, 5.0));
        b.override_default("FS_ACTION", 1.0);
        let t = b.build();
        assert_eq!(t.index_of("FS_ACTION"), Some(1));
        assert_eq!(t.value_of("FS_ACTION"), Some(1.0));
        assert_eq!(t.non_defaults().count(), 0);
    }

    #[test]
    #[should_panic(expected = "declared twice")]
    fn duplicate_names_are_rejected() {
        let mut b = ParamTableBuilder::new();
        b.add(def("WP_SPEED", ParamType::Real32, 2.0, 0.0, 10.0));
        b.add(def("WP_SPEED", ParamType::Real32, 2.0, 0.0, 10.0));
    }
}
