//! Typed handles: a subsystem keeps a `Param<T>` and reads the current value
//! from the table when it needs it.

use std::marker::PhantomData;

use crate::def::ParamType;
use crate::table::ParamTable;

/// A Rust type a parameter can be read as.
pub trait ParamScalar: Copy {
    const TYPE: ParamType;
    fn from_value(value: f64) -> Self;
}

impl ParamScalar for f32 {
    const TYPE: ParamType = ParamType::Real32;
    fn from_value(value: f64) -> Self {
        value as f32
    }
}

impl ParamScalar for i8 {
    const TYPE: ParamType = ParamType::Int8;
    fn from_value(value: f64) -> Self {
        value as i8
    }
}

impl ParamScalar for u8 {
    const TYPE: ParamType = ParamType::Uint8;
    fn from_value(value: f64) -> Self {
        value as u8
    }
}

impl ParamScalar for i16 {
    const TYPE: ParamType = ParamType::Int16;
    fn from_value(value: f64) -> Self {
        value as i16
    }
}

impl ParamScalar for i32 {
    const TYPE: ParamType = ParamType::Int32;
    fn from_value(value: f64) -> Self {
        value as i32
    }
}

/// Booleans travel as INT8 0/1, as ArduPilot's enable flags do.
impl ParamScalar for bool {
    const TYPE: ParamType = ParamType::Int8;
    fn from_value(value: f64) -> Self {
        value != 0.0
    }
}

/// Index of a parameter in the table, typed by how it is read.
#[derive(Debug)]
pub struct Param<T> {
    index: u16,
    _ty: PhantomData<fn() -> T>,
}

impl<T> Clone for Param<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Param<T> {}

impl<T: ParamScalar> Param<T> {
    /// Wraps an index returned by [`crate::ParamTableBuilder::add`].
    pub fn from_index(index: u16) -> Self {
        Param {
            index,
            _ty: PhantomData,
        }
    }

    pub fn index(self) -> u16 {
        self.index
    }

    /// Current value.
    pub fn get(self, table: &ParamTable) -> T {
        T::from_value(table.value(self.index))
    }
}
