//! Control: turns guidance demands (steering angle, speed) into normalised
//! actuator commands and servo pulse widths.

pub mod ackermann;
pub mod defaults;
pub mod mixer;
pub mod pid;
pub mod servo;
pub mod speed;
