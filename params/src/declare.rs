//! [`declare_params!`](crate::declare_params): one declaration per parameter.

/// Declares a group of parameters and a struct of typed handles to them.
///
/// ```
/// params::declare_params! {
///     /// Waypoint navigation.
///     pub struct WpParams {
///         speed_mps: f32 = "WP_SPEED" => {
///             default: 2.0, range: 0.0, 10.0, unit: "m/s",
///             desc: "Speed in AUTO and GUIDED",
///         },
///         loop_rate_hz: i16 = "SCHED_LOOP_RATE" => {
///             default: 50, range: 10, 400, unit: "Hz", flags: [reboot_required],
///             desc: "Core tick rate",
///         },
///     }
/// }
/// let mut builder = params::ParamTableBuilder::new();
/// let wp = WpParams::register(&mut builder);
/// let table = builder.build();
/// assert_eq!(wp.speed_mps.get(&table), 2.0);
/// ```
#[macro_export]
macro_rules! declare_params {
    (
        $(#[$meta:meta])*
        $vis:vis struct $group:ident {
            $(
                $field:ident : $ty:ty = $name:expr => {
                    default: $default:expr,
                    range: $min:expr, $max:expr,
                    unit: $unit:expr,
                    $(flags: [$($flag:ident),* $(,)?],)?
                    desc: $desc:expr $(,)?
                }
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug)]
        $vis struct $group {
            $( pub $field: $crate::Param<$ty>, )*
        }

        impl $group {
            /// Declares this group's parameters and returns their handles.
            pub fn register(builder: &mut $crate::ParamTableBuilder) -> Self {
                Self {
                    $(
                        $field: $crate::Param::from_index(builder.add($crate::ParamDef {
                            name: $crate::ParamName::new($name).expect("valid parameter name"),
                            ty: <$ty as $crate::ParamScalar>::TYPE,
                            default: f64::from($default),
                            min: f64::from($min),
                            max: f64::from($max),
                            unit: $unit,
                            description: $desc,
                            flags: $crate::ParamFlags {
                                $($($flag: true,)*)?
                                ..$crate::ParamFlags::default()
                            },
                        })),
                    )*
                }
            }
        }
    };
}
