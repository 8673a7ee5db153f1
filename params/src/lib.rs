//! Furrow's parameters: every tunable is declared once, typed, with its
//! metadata, and read by the subsystem that owns it through a typed handle.
//!
//! Layout:
//! - [`def`]: what a parameter is ([`ParamDef`], [`ParamType`], [`ParamName`]).
//! - [`table`]: the process-wide table ([`ParamTable`]) built once by a
//!   [`ParamTableBuilder`]; its order and size never change afterwards, which
//!   is what the MAVLink parameter protocol's `param_index` relies on.
//! - [`handle`]: typed handles ([`Param<T>`]) that subsystems keep and read
//!   every tick, so a change made by a ground station applies on the next tick.
//! - [`declare`]: the [`declare_params!`] macro a subsystem uses to declare
//!   its group (`WP_*`, `SR0_*`, …) in one place.
//! - [`service`]: the MAVLink parameter microservice (messages in, messages
//!   out, no I/O); [`hash`]: the `_HASH_CHECK` table hash.
//! - [`files`]: Mission Planner `.param` and QGroundControl `.params` files;
//!   [`store`]: atomic persistence in the data directory.

pub mod declare;
pub mod def;
pub mod files;
pub mod handle;
pub mod hash;
pub mod service;
pub mod store;
pub mod table;

pub use def::{ParamDef, ParamFlags, ParamName, ParamNameError, ParamType};
pub use handle::{Param, ParamScalar};
pub use table::{ParamTable, ParamTableBuilder, SetError};
