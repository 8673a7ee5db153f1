//! MQTT topic layout (§6.3) and the QoS/retain each topic is sent with
//! (§6.2, §6.14, §6.15), as data for the MQTT edge.

/// The six topics of VDA 5050 2.1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Topic {
    Order,
    InstantActions,
    State,
    Visualization,
    Connection,
    Factsheet,
}

/// MQTT quality of service.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Qos {
    AtMostOnce,
    AtLeastOnce,
}

impl Topic {
    pub const ALL: [Topic; 6] = [
        Topic::Order,
        Topic::InstantActions,
        Topic::State,
        Topic::Visualization,
        Topic::Connection,
        Topic::Factsheet,
    ];

    /// The last topic level, as spelled in the standard.
    pub fn name(self) -> &'static str {
        match self {
            Topic::Order => "order",
            Topic::InstantActions => "instantActions",
            Topic::State => "state",
            Topic::Visualization => "visualization",
            Topic::Connection => "connection",
            Topic::Factsheet => "factsheet",
        }
    }

    /// The topic named by a last topic level, if it is one of the six.
    pub fn from_name(name: &str) -> Option<Topic> {
        Topic::ALL.into_iter().find(|topic| topic.name() == name)
    }

    /// QoS 1 for `connection` only; QoS 0 for everything else (§6.2).
    pub fn qos(self) -> Qos {
        match self {
            Topic::Connection => Qos::AtLeastOnce,
            _ => Qos::AtMostOnce,
        }
    }

    /// `connection` and `factsheet` are retained (§6.14, §6.15).
    pub fn retained(self) -> bool {
        matches!(self, Topic::Connection | Topic::Factsheet)
    }

    /// True for the topics the vehicle subscribes to (master → vehicle).
    pub fn subscribed_by_vehicle(self) -> bool {
        matches!(self, Topic::Order | Topic::InstantActions)
    }
}

/// `{interfaceName}/{majorVersion}/{manufacturer}/{serialNumber}`, the prefix
/// of one vehicle's topics.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicPrefix {
    pub interface_name: String,
    pub major_version: String,
    pub manufacturer: String,
    pub serial_number: String,
}

/// A topic level that would break the topic structure.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicLevelError {
    pub level: &'static str,
    pub value: String,
}

impl std::fmt::Display for TopicLevelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {:?} is not a valid MQTT topic level (empty, or contains '/', '+', '#' or NUL)",
            self.level, self.value
        )
    }
}

impl std::error::Error for TopicLevelError {}

fn check_level(level: &'static str, value: &str) -> Result<String, TopicLevelError> {
    let bad = value.is_empty() || value.contains(['/', '+', '#', '\0']);
    if bad {
        return Err(TopicLevelError {
            level,
            value: value.to_owned(),
        });
    }
    Ok(value.to_owned())
}

impl TopicPrefix {
    /// The default interface `uagv`, major version `v2`.
    pub fn uagv_v2(manufacturer: &str, serial_number: &str) -> Result<Self, TopicLevelError> {
        Self::new("uagv", "v2", manufacturer, serial_number)
    }

    pub fn new(
        interface_name: &str,
        major_version: &str,
        manufacturer: &str,
        serial_number: &str,
    ) -> Result<Self, TopicLevelError> {
        Ok(Self {
            interface_name: check_level("interfaceName", interface_name)?,
            major_version: check_level("majorVersion", major_version)?,
            manufacturer: check_level("manufacturer", manufacturer)?,
            serial_number: check_level("serialNumber", serial_number)?,
        })
    }

    /// The full topic, e.g. `uagv/v2/Furrow/R1/state`.
    pub fn topic(&self, topic: Topic) -> String {
        format!(
            "{}/{}/{}/{}/{}",
            self.interface_name,
            self.major_version,
            self.manufacturer,
            self.serial_number,
            topic.name()
        )
    }

    /// Which of this vehicle's topics a full topic string is, if any.
    pub fn parse_topic(&self, full: &str) -> Option<Topic> {
        let rest = full
            .strip_prefix(&self.topic_base())
            .and_then(|rest| rest.strip_prefix('/'))?;
        Topic::from_name(rest)
    }

    fn topic_base(&self) -> String {
        format!(
            "{}/{}/{}/{}",
            self.interface_name, self.major_version, self.manufacturer, self.serial_number
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_follow_the_standard_layout() {
        let prefix = TopicPrefix::uagv_v2("Furrow", "R1").unwrap();
        assert_eq!(prefix.topic(Topic::State), "uagv/v2/Furrow/R1/state");
        assert_eq!(prefix.topic(Topic::InstantActions), "uagv/v2/Furrow/R1/instantActions");
        for topic in Topic::ALL {
            assert_eq!(prefix.parse_topic(&prefix.topic(topic)), Some(topic));
        }
        assert_eq!(prefix.parse_topic("uagv/v2/Furrow/R2/order"), None);
        assert_eq!(prefix.parse_topic("uagv/v2/Furrow/R1/orders"), None);
    }

    #[test]
    fn qos_and_retain_per_section_6_2_and_6_14() {
        for topic in Topic::ALL {
            let expected_qos = if topic == Topic::Connection {
                Qos::AtLeastOnce
            } else {
                Qos::AtMostOnce
            };
            assert_eq!(topic.qos(), expected_qos, "{topic:?}");
        }
        assert!(Topic::Connection.retained());
        assert!(Topic::Factsheet.retained());
        assert!(!Topic::State.retained());
        assert!(!Topic::Order.retained());
    }

    #[test]
    fn bad_topic_levels_are_refused() {
        assert!(TopicPrefix::uagv_v2("Fur/row", "R1").is_err());
        assert!(TopicPrefix::uagv_v2("Furrow", "").is_err());
        assert!(TopicPrefix::uagv_v2("Furrow", "R#1").is_err());
        let err = TopicPrefix::uagv_v2("Furrow", "a+b").unwrap_err();
        assert!(err.to_string().contains("serialNumber"));
    }
}
