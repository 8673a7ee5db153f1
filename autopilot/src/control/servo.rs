//! ArduPilot-style servo outputs: which output channel carries what
//! (`SERVOn_FUNCTION`), each channel's pulse range (`SERVOn_MIN`, `_TRIM`,
//! `_MAX`, `_REVERSED`), and relays switching a channel between its MIN and
//! MAX (`RELAYn_PIN`).
//!
//! Functions (ArduPilot's numbers): 0 Disabled, 1 RCPassThru (Furrow has no
//! RC input: treated as Disabled), -1 GPIO (a relay pin), 26 GroundSteering,
//! 70 Throttle, 73 ThrottleLeft, 74 ThrottleRight. Furrow's own, for the
//! per-wheel outputs of an Ackermann vehicle (seed 002), in the gap ArduPilot
//! leaves unused between 110 (airbrake) and 120 (NeoPixel): 111 left front
//! wheel angle, 112 right front wheel angle, 113 left rear wheel throttle,
//! 114 right rear wheel throttle. (150–155 are ArduPilot's RCIN11–16 mapped.)
//!
//! The drive train is `VEH_DRIVE`, not inferred from the functions. On a
//! skid-steering vehicle GroundSteering and Throttle carry the left and
//! right track throttles, exactly as ThrottleLeft and ThrottleRight do, so
//! one default assignment (26 on servo 1, 70 on servo 3) drives either
//! train and a file that sets 73/74 the ArduPilot way works too. ThrottleLeft
//! and ThrottleRight on an Ackermann vehicle, and the per-wheel functions on
//! a skid-steering one, have nothing to carry: those channels are not driven.
//!
//! Every channel's pulse is one of: the drive value mapped through its range
//! (a disarmed vehicle's neutral demand gives TRIM), a relay's MIN/MAX (GPIO
//! channels), a DO_SET_SERVO pulse (Disabled/RCPassThru channels only, as
//! ArduPilot refuses channels with a function), or 0: not driven.
//!
//! Sources: docs/references.md §Seed 002.

use params::{Param, ParamDef, ParamFlags, ParamName, ParamTable, ParamTableBuilder, ParamType};
use vehicle_types::ActuatorDemand;

use super::mixer::WheelOutputs;

/// Output channels (`SERVO1_*` … `SERVO16_*`), as SERVO_OUTPUT_RAW has.
pub const SERVO_CHANNELS: usize = 16;
/// Relays (`RELAY1_PIN` … `RELAY6_PIN`); DO_SET_RELAY numbers them from 0.
pub const RELAYS: usize = 6;

/// ArduPilot's default servo range (SRV_Channel).
pub const DEFAULT_MIN_US: u16 = 1100;
pub const DEFAULT_TRIM_US: u16 = 1500;
pub const DEFAULT_MAX_US: u16 = 1900;

/// What an output channel carries (`SERVOn_FUNCTION`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ServoFunction {
    /// -1: switched by a relay whose `RELAYn_PIN` names this channel.
    Gpio,
    /// 0: free for DO_SET_SERVO.
    Disabled,
    /// 1: passes RC input through in ArduPilot; Furrow has none, so like 0.
    RcPassThru,
    /// 26 (left track on skid steering).
    GroundSteering,
    /// 70 (right track on skid steering).
    Throttle,
    /// 73.
    ThrottleLeft,
    /// 74.
    ThrottleRight,
    /// 111: Furrow's left front wheel angle (1 = the inner wheel at full lock).
    FrontLeftWheelAngle,
    /// 112.
    FrontRightWheelAngle,
    /// 113: Furrow's left rear wheel throttle (electronic differential).
    RearLeftWheelThrottle,
    /// 114.
    RearRightWheelThrottle,
    /// An ArduPilot function Furrow does not produce (mount, motor, …): the
    /// channel is not driven and refuses DO_SET_SERVO as ArduPilot would.
    Unsupported(i16),
}

impl ServoFunction {
    pub fn from_number(number: i16) -> Self {
        match number {
            -1 => ServoFunction::Gpio,
            0 => ServoFunction::Disabled,
            1 => ServoFunction::RcPassThru,
            26 => ServoFunction::GroundSteering,
            70 => ServoFunction::Throttle,
            73 => ServoFunction::ThrottleLeft,
            74 => ServoFunction::ThrottleRight,
            111 => ServoFunction::FrontLeftWheelAngle,
            112 => ServoFunction::FrontRightWheelAngle,
            113 => ServoFunction::RearLeftWheelThrottle,
            114 => ServoFunction::RearRightWheelThrottle,
            other => ServoFunction::Unsupported(other),
        }
    }

    pub fn number(self) -> i16 {
        match self {
            ServoFunction::Gpio => -1,
            ServoFunction::Disabled => 0,
            ServoFunction::RcPassThru => 1,
            ServoFunction::GroundSteering => 26,
            ServoFunction::Throttle => 70,
            ServoFunction::ThrottleLeft => 73,
            ServoFunction::ThrottleRight => 74,
            ServoFunction::FrontLeftWheelAngle => 111,
            ServoFunction::FrontRightWheelAngle => 112,
            ServoFunction::RearLeftWheelThrottle => 113,
            ServoFunction::RearRightWheelThrottle => 114,
            ServoFunction::Unsupported(n) => n,
        }
    }

    /// Whether DO_SET_SERVO may set the channel: only when no function
    /// owns it, so a mission can never fight the steering.
    pub fn accepts_direct_pulse(self) -> bool {
        matches!(self, ServoFunction::Disabled | ServoFunction::RcPassThru)
    }

    /// The function's value in [-1, 1] from this tick's demand; `None` when
    /// the drive train has nothing for it.
    fn drive_value(self, actuators: &ActuatorDemand, wheels: Option<&WheelOutputs>) -> Option<f64> {
        use ServoFunction as F;
        match (self, *actuators) {
            (F::GroundSteering, ActuatorDemand::Ackermann { steering, .. }) => Some(steering),
            (F::Throttle, ActuatorDemand::Ackermann { throttle, .. }) => Some(throttle),
            (F::GroundSteering | F::ThrottleLeft, ActuatorDemand::Differential { left, .. }) => Some(left),
            (F::Throttle | F::ThrottleRight, ActuatorDemand::Differential { right, .. }) => Some(right),
            (F::FrontLeftWheelAngle, _) => wheels.map(|w| w.front_left),
            (F::FrontRightWheelAngle, _) => wheels.map(|w| w.front_right),
            (F::RearLeftWheelThrottle, _) => wheels.map(|w| w.rear_left),
            (F::RearRightWheelThrottle, _) => wheels.map(|w| w.rear_right),
            _ => None,
        }
    }
}

impl std::fmt::Display for ServoFunction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self {
            ServoFunction::Gpio => "GPIO",
            ServoFunction::Disabled => "Disabled",
            ServoFunction::RcPassThru => "RCPassThru",
            ServoFunction::GroundSteering => "GroundSteering",
            ServoFunction::Throttle => "Throttle",
            ServoFunction::ThrottleLeft => "ThrottleLeft",
            ServoFunction::ThrottleRight => "ThrottleRight",
            ServoFunction::FrontLeftWheelAngle => "WheelAngleFL",
            ServoFunction::FrontRightWheelAngle => "WheelAngleFR",
            ServoFunction::RearLeftWheelThrottle => "WheelThrottleRL",
            ServoFunction::RearRightWheelThrottle => "WheelThrottleRR",
            ServoFunction::Unsupported(n) => return write!(f, "function {n}"),
        };
        f.write_str(name)
    }
}

/// One channel's pulse range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServoRange {
    pub min_us: u16,
    pub trim_us: u16,
    pub max_us: u16,
    pub reversed: bool,
}

impl Default for ServoRange {
    fn default() -> Self {
        ServoRange {
            min_us: DEFAULT_MIN_US,
            trim_us: DEFAULT_TRIM_US,
            max_us: DEFAULT_MAX_US,
            reversed: false,
        }
    }
}

impl ServoRange {
    /// A normalised value in [-1, 1] as a pulse, ArduPilot's way: each side
    /// of TRIM scales to its own end, so an off-centre trim keeps full
    /// travel both ways (a rover's throttle maps around trim for reverse).
    /// REVERSED mirrors the value; the pulse stays within [MIN, MAX] even
    /// when TRIM lies outside; a non-finite value gives TRIM.
    pub fn pulse_us(&self, value: f64) -> u16 {
        let min = f64::from(self.min_us);
        let max = f64::from(self.max_us);
        let trim = f64::from(self.trim_us);
        let v = if value.is_finite() { value.clamp(-1.0, 1.0) } else { 0.0 };
        let v = if self.reversed { -v } else { v };
        let pulse = if v >= 0.0 {
            trim + v * (max - trim)
        } else {
            trim + v * (trim - min)
        };
        // min/max ordered by hand: a MIN above MAX is a bad setting, not a
        // reason to panic in `clamp`.
        pulse.max(min.min(max)).min(max.max(min)).round() as u16
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServoChannel {
    pub function: ServoFunction,
    pub range: ServoRange,
}

/// What drives the outputs this tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputDemand {
    /// The mixed drive demand (neutral when disarmed).
    pub actuators: ActuatorDemand,
    /// Per-wheel commands of an Ackermann vehicle.
    pub wheels: Option<WheelOutputs>,
    /// DO_SET_SERVO pulses by channel (0: never set).
    pub direct_us: [u16; SERVO_CHANNELS],
    /// DO_SET_RELAY states: bit n is relay n (`RELAY{n+1}_PIN`).
    pub relays_on: u16,
}

/// The whole output configuration, read from the parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServoConfig {
    pub channels: [ServoChannel; SERVO_CHANNELS],
    /// Per relay, the output channel it switches (0-based), if any.
    pub relay_channels: [Option<usize>; RELAYS],
}

impl ServoConfig {
    /// Every channel's pulse (µs; 0: not driven).
    pub fn pulses_us(&self, demand: &OutputDemand) -> [u16; SERVO_CHANNELS] {
        std::array::from_fn(|ch| {
            let ServoChannel { function, range } = self.channels[ch];
            match function {
                ServoFunction::Disabled | ServoFunction::RcPassThru => demand.direct_us[ch],
                ServoFunction::Gpio => self
                    .relay_channels
                    .iter()
                    .position(|&relay_ch| relay_ch == Some(ch))
                    .map_or(0, |relay| {
                        if demand.relays_on & (1 << relay) != 0 {
                            range.max_us
                        } else {
                            range.min_us
                        }
                    }),
                _ => function
                    .drive_value(&demand.actuators, demand.wheels.as_ref())
                    .map_or(0, |v| range.pulse_us(v)),
            }
        })
    }

    /// Drops DO_SET_SERVO pulses on channels a function owns, and returns
    /// them (1-based channel, function) so the caller can say so once.
    pub fn refuse_direct_pulses(&self, direct_us: &mut [u16; SERVO_CHANNELS]) -> Vec<(usize, ServoFunction)> {
        let mut refused = Vec::new();
        for (ch, pulse) in direct_us.iter_mut().enumerate() {
            let function = self.channels[ch].function;
            if *pulse != 0 && !function.accepts_direct_pulse() {
                *pulse = 0;
                refused.push((ch + 1, function));
            }
        }
        refused
    }
}

/// The function a channel has by default: today's fixed assignment.
fn default_function(channel: usize) -> ServoFunction {
    match channel {
        1 => ServoFunction::GroundSteering,
        3 => ServoFunction::Throttle,
        5 => ServoFunction::FrontLeftWheelAngle,
        6 => ServoFunction::FrontRightWheelAngle,
        7 => ServoFunction::RearLeftWheelThrottle,
        8 => ServoFunction::RearRightWheelThrottle,
        _ => ServoFunction::Disabled,
    }
}

#[derive(Clone, Copy, Debug)]
struct ChannelParams {
    function: Param<i16>,
    min_us: Param<i16>,
    trim_us: Param<i16>,
    max_us: Param<i16>,
    reversed: Param<i8>,
}

/// `SERVOn_*` (n = 1..16) and `RELAYn_PIN` (n = 1..6).
#[derive(Clone, Copy, Debug)]
pub struct ServoParams {
    channels: [ChannelParams; SERVO_CHANNELS],
    relay_pins: [Param<i8>; RELAYS],
}

const FUNCTION_DESC: &str = "Output function: 0 Disabled (DO_SET_SERVO), 1 RCPassThru (as 0), -1 GPIO (relay pin), \
     26 GroundSteering, 70 Throttle, 73 ThrottleLeft, 74 ThrottleRight, 111/112 left/right front wheel angle, \
     113/114 left/right rear wheel throttle; on skid steering (VEH_DRIVE 1) 26 and 70 carry left and right";

impl ServoParams {
    // Stays whole: a declaration table, one `add` per parameter, in the
    // order the parameter table (and a ground station's list) shows them.
    pub fn register(builder: &mut ParamTableBuilder) -> Self {
        let mut add = |name: String, ty: ParamType, default: f64, min: f64, max: f64, unit, description| {
            builder.add(ParamDef {
                name: ParamName::new(name).expect("valid servo parameter name"),
                ty,
                default,
                min,
                max,
                unit,
                description,
                flags: ParamFlags::default(),
            })
        };
        let channels = std::array::from_fn(|i| {
            let n = i + 1;
            let function = f64::from(default_function(n).number());
            let (min, trim, max) = (
                f64::from(DEFAULT_MIN_US),
                f64::from(DEFAULT_TRIM_US),
                f64::from(DEFAULT_MAX_US),
            );
            let int16 = ParamType::Int16;
            ChannelParams {
                function: Param::from_index(add(
                    format!("SERVO{n}_FUNCTION"),
                    int16,
                    function,
                    -1.0,
                    255.0,
                    "",
                    FUNCTION_DESC,
                )),
                min_us: Param::from_index(add(
                    format!("SERVO{n}_MIN"),
                    int16,
                    min,
                    500.0,
                    2200.0,
                    "PWM",
                    "Minimum output pulse width",
                )),
                trim_us: Param::from_index(add(
                    format!("SERVO{n}_TRIM"),
                    int16,
                    trim,
                    800.0,
                    2200.0,
                    "PWM",
                    "Pulse width at neutral (and while disarmed); each side scales to MIN or MAX",
                )),
                max_us: Param::from_index(add(
                    format!("SERVO{n}_MAX"),
                    int16,
                    max,
                    500.0,
                    2200.0,
                    "PWM",
                    "Maximum output pulse width",
                )),
                reversed: Param::from_index(add(
                    format!("SERVO{n}_REVERSED"),
                    ParamType::Int8,
                    0.0,
                    0.0,
                    1.0,
                    "",
                    "1: output reversed about TRIM",
                )),
            }
        });
        let relay_pins = std::array::from_fn(|i| {
            Param::from_index(add(
                format!("RELAY{}_PIN", i + 1),
                ParamType::Int8,
                -1.0,
                -1.0,
                16.0,
                "",
                "Servo output this relay switches (-1 none; the output's SERVOn_FUNCTION must be -1 GPIO): \
                 on = SERVOn_MAX, off = SERVOn_MIN",
            ))
        });
        ServoParams { channels, relay_pins }
    }

    /// The configuration as the table holds it now.
    pub fn config(&self, table: &ParamTable) -> ServoConfig {
        // The table keeps every value within its declared range, so the
        // pulse widths are positive.
        let us = |p: Param<i16>| u16::try_from(p.get(table)).unwrap_or(0);
        ServoConfig {
            channels: std::array::from_fn(|i| {
                let c = &self.channels[i];
                ServoChannel {
                    function: ServoFunction::from_number(c.function.get(table)),
                    range: ServoRange {
                        min_us: us(c.min_us),
                        trim_us: us(c.trim_us),
                        max_us: us(c.max_us),
                        reversed: c.reversed.get(table) != 0,
                    },
                }
            }),
            relay_channels: std::array::from_fn(|r| {
                let pin = self.relay_pins[r].get(table);
                (1..=SERVO_CHANNELS as i8).contains(&pin).then(|| pin as usize - 1)
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range(min_us: u16, trim_us: u16, max_us: u16, reversed: bool) -> ServoRange {
        ServoRange {
            min_us,
            trim_us,
            max_us,
            reversed,
        }
    }

    #[test]
    fn ends_and_centre_map_to_min_trim_max() {
        let r = range(1100, 1500, 1900, false);
        assert_eq!(r.pulse_us(-1.0), 1100);
        assert_eq!(r.pulse_us(0.0), 1500);
        assert_eq!(r.pulse_us(1.0), 1900);
        assert_eq!(r.pulse_us(0.5), 1700);
        assert_eq!(r.pulse_us(-0.25), 1400);
    }

    #[test]
    fn reversed_mirrors_about_trim() {
        let normal = range(1000, 1400, 2000, false);
        let reversed = range(1000, 1400, 2000, true);
        assert_eq!(reversed.pulse_us(1.0), 1000);
        assert_eq!(reversed.pulse_us(-1.0), 2000);
        assert_eq!(reversed.pulse_us(0.0), 1400);
        for v in [-0.8, -0.3, 0.2, 0.7] {
            assert_eq!(reversed.pulse_us(v), normal.pulse_us(-v), "v = {v}");
        }
    }

    #[test]
    fn asymmetric_trim_scales_each_side_to_its_end() {
        // 300 µs of travel below trim, 600 above: half deflection is half
        // of each side, not the same step both ways.
        let r = range(1000, 1300, 1900, false);
        assert_eq!(r.pulse_us(0.5), 1600);
        assert_eq!(r.pulse_us(-0.5), 1150);
        assert_eq!(r.pulse_us(1.0), 1900);
        assert_eq!(r.pulse_us(-1.0), 1000);
    }

    #[test]
    fn out_of_range_and_non_finite_values_are_contained() {
        let r = range(1100, 1520, 1900, false);
        assert_eq!(r.pulse_us(3.0), 1900);
        assert_eq!(r.pulse_us(-7.5), 1100);
        assert_eq!(r.pulse_us(f64::NAN), 1520);
        assert_eq!(r.pulse_us(f64::INFINITY), 1520);
        assert_eq!(r.pulse_us(f64::NEG_INFINITY), 1520);
        // A trim set outside MIN..MAX never leaves the range.
        let bad_trim = range(1100, 2100, 1900, false);
        assert_eq!(bad_trim.pulse_us(0.0), 1900);
        assert_eq!(bad_trim.pulse_us(-1.0), 1100);
        // MIN above MAX: no panic, still within the two.
        let swapped = range(1900, 1500, 1100, false);
        let p = swapped.pulse_us(0.3);
        assert!((1100..=1900).contains(&p), "{p}");
    }

    #[test]
    fn function_numbers_round_trip() {
        for n in -1..=255 {
            assert_eq!(ServoFunction::from_number(n).number(), n);
        }
        assert_eq!(ServoFunction::from_number(26), ServoFunction::GroundSteering);
        assert_eq!(ServoFunction::from_number(33), ServoFunction::Unsupported(33));
    }

    fn table() -> (ParamTable, ServoParams) {
        let mut builder = ParamTableBuilder::new();
        let p = ServoParams::register(&mut builder);
        (builder.build(), p)
    }

    fn demand(actuators: ActuatorDemand, wheels: Option<WheelOutputs>) -> OutputDemand {
        OutputDemand {
            actuators,
            wheels,
            direct_us: [0; SERVO_CHANNELS],
            relays_on: 0,
        }
    }

    #[test]
    fn defaults_put_steering_on_1_throttle_on_3_and_wheels_on_5_to_8() {
        let (t, p) = table();
        let config = p.config(&t);
        let wheels = WheelOutputs {
            front_left: 0.5,
            front_right: 1.0,
            rear_left: -0.5,
            rear_right: -1.0,
        };
        let pwm = config.pulses_us(&demand(
            ActuatorDemand::Ackermann {
                steering: -1.0,
                throttle: 0.25,
            },
            Some(wheels),
        ));
        assert_eq!(pwm, [1100, 0, 1600, 0, 1700, 1900, 1300, 1100, 0, 0, 0, 0, 0, 0, 0, 0]);
        // Skid steering: the same channels carry left and right.
        let pwm = config.pulses_us(&demand(ActuatorDemand::Differential { left: 1.0, right: -0.5 }, None));
        assert_eq!(pwm, [1900, 0, 1300, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn skid_functions_by_ardupilot_numbers_and_nothing_for_the_wrong_train() {
        let (mut t, p) = table();
        t.set_by_name("SERVO2_FUNCTION", 74.0).unwrap();
        t.set_by_name("SERVO4_FUNCTION", 73.0).unwrap();
        let config = p.config(&t);
        let skid = config.pulses_us(&demand(ActuatorDemand::Differential { left: 0.5, right: -1.0 }, None));
        assert_eq!((skid[1], skid[3]), (1100, 1700));
        let ackermann = config.pulses_us(&demand(
            ActuatorDemand::Ackermann {
                steering: 0.5,
                throttle: 0.5,
            },
            None,
        ));
        assert_eq!((ackermann[1], ackermann[3]), (0, 0), "no left/right on Ackermann");
        assert_eq!(ackermann[4], 0, "no wheel outputs without wheels");
    }

    #[test]
    fn do_set_servo_only_on_free_channels() {
        let (mut t, p) = table();
        t.set_by_name("SERVO10_FUNCTION", 1.0).unwrap();
        t.set_by_name("SERVO11_FUNCTION", 33.0).unwrap();
        let config = p.config(&t);
        let mut direct = [0u16; SERVO_CHANNELS];
        direct[0] = 1900; // steering
        direct[8] = 1234; // free
        direct[9] = 1800; // RCPassThru
        direct[10] = 1700; // a motor in ArduPilot
        let refused = config.refuse_direct_pulses(&mut direct);
        assert_eq!(
            refused,
            vec![(1, ServoFunction::GroundSteering), (11, ServoFunction::Unsupported(33))]
        );
        assert_eq!((direct[0], direct[8], direct[9], direct[10]), (0, 1234, 1800, 0));
        let mut d = demand(
            ActuatorDemand::Ackermann {
                steering: 0.0,
                throttle: 0.0,
            },
            None,
        );
        d.direct_us = direct;
        let pwm = config.pulses_us(&d);
        assert_eq!((pwm[0], pwm[8], pwm[9], pwm[10]), (1500, 1234, 1800, 0));
    }

    #[test]
    fn relays_switch_gpio_channels_between_min_and_max() {
        let (mut t, p) = table();
        t.set_by_name("SERVO12_FUNCTION", -1.0).unwrap();
        t.set_by_name("SERVO12_MIN", 1000.0).unwrap();
        t.set_by_name("SERVO12_MAX", 2000.0).unwrap();
        t.set_by_name("RELAY2_PIN", 12.0).unwrap();
        // A relay on a channel that is not GPIO does nothing.
        t.set_by_name("RELAY3_PIN", 13.0).unwrap();
        let config = p.config(&t);
        assert_eq!(config.relay_channels, [None, Some(11), Some(12), None, None, None]);
        let mut d = demand(
            ActuatorDemand::Ackermann {
                steering: 0.0,
                throttle: 0.0,
            },
            None,
        );
        assert_eq!(config.pulses_us(&d)[11], 1000, "off until switched");
        d.relays_on = 0b110;
        let pwm = config.pulses_us(&d);
        assert_eq!(pwm[11], 2000);
        assert_eq!(pwm[12], 0);
        d.relays_on = 0b001;
        assert_eq!(config.pulses_us(&d)[11], 1000, "relay 1 is another relay");
    }

    #[test]
    fn parameters_are_ardupilots_names_ranges_and_defaults() {
        let (mut t, _) = table();
        assert_eq!(t.value_of("SERVO16_REVERSED"), Some(0.0));
        assert_eq!(t.value_of("SERVO1_FUNCTION"), Some(26.0));
        assert_eq!(t.value_of("SERVO3_FUNCTION"), Some(70.0));
        assert_eq!(t.value_of("SERVO9_FUNCTION"), Some(0.0));
        assert_eq!(t.value_of("SERVO2_MIN"), Some(1100.0));
        assert_eq!(t.value_of("SERVO2_TRIM"), Some(1500.0));
        assert_eq!(t.value_of("SERVO2_MAX"), Some(1900.0));
        assert_eq!(t.value_of("RELAY6_PIN"), Some(-1.0));
        assert!(t.set_by_name("SERVO1_MIN", 499.0).is_err());
        assert!(t.set_by_name("SERVO1_TRIM", 799.0).is_err());
        assert!(t.set_by_name("SERVO1_MAX", 2201.0).is_err());
        assert!(t.set_by_name("SERVO1_MIN", 500.0).is_ok());
        assert!(t.set_by_name("RELAY1_PIN", 17.0).is_err());
    }
}
