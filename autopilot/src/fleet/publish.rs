//! The bytes of what the vehicle publishes: each message's header stamped
//! (per-topic headerId, timestamp, manufacturer, serial number) and
//! serialised, with the topic's QoS and retain flag (§6.2–6.5). Pure: the
//! edge hands in the time.

use vda5050::{Connection, ConnectionState, Header, Qos, Topic, TopicPrefix};

use crate::vehicle::FleetMessage;

/// One MQTT publication.
#[derive(Clone, Debug, PartialEq)]
pub struct Publication {
    pub topic: String,
    pub qos: Qos,
    pub retain: bool,
    pub payload: Vec<u8>,
}

/// Stamps and serialises messages for one vehicle.
#[derive(Clone, Debug)]
pub struct Publisher {
    prefix: TopicPrefix,
    /// The next headerId per topic (§6.4: per topic, +1 per message).
    next_ids: [u32; 6],
}

impl Publisher {
    pub fn new(prefix: TopicPrefix) -> Self {
        Publisher {
            prefix,
            next_ids: [0; 6],
        }
    }

    pub fn prefix(&self) -> &TopicPrefix {
        &self.prefix
    }

    fn header(&mut self, topic: Topic, unix_ms: u64) -> Header {
        let index = Topic::ALL.iter().position(|t| *t == topic).unwrap_or(0);
        let id = self.next_ids[index];
        self.next_ids[index] = id.wrapping_add(1);
        Header::new(id, unix_ms, &self.prefix.manufacturer, &self.prefix.serial_number)
    }

    fn publication(&self, topic: Topic, payload: Vec<u8>) -> Publication {
        Publication {
            topic: self.prefix.topic(topic),
            qos: topic.qos(),
            retain: topic.retained(),
            payload,
        }
    }

    /// A message from the core, stamped now.
    pub fn message(&mut self, message: FleetMessage, unix_ms: u64) -> Publication {
        let (topic, payload) = match message {
            FleetMessage::State(mut state) => {
                state.header = self.header(Topic::State, unix_ms);
                (Topic::State, serde_json::to_vec(&state))
            }
            FleetMessage::Visualization(mut visualization) => {
                visualization.header = self.header(Topic::Visualization, unix_ms);
                (Topic::Visualization, serde_json::to_vec(&visualization))
            }
            FleetMessage::Factsheet(mut factsheet) => {
                factsheet.header = self.header(Topic::Factsheet, unix_ms);
                (Topic::Factsheet, serde_json::to_vec(&factsheet))
            }
        };
        // Serialising these types cannot fail (no maps with non-string keys).
        self.publication(topic, payload.unwrap_or_default())
    }

    /// A `connection` message (ONLINE, OFFLINE, or the last will's
    /// CONNECTIONBROKEN).
    pub fn connection(&mut self, state: ConnectionState, unix_ms: u64) -> Publication {
        let message = Connection {
            header: self.header(Topic::Connection, unix_ms),
            connection_state: state,
        };
        let payload = serde_json::to_vec(&message).unwrap_or_default();
        self.publication(Topic::Connection, payload)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_ids_count_per_topic_and_connection_is_retained_at_qos_1() {
        let mut p = Publisher::new(TopicPrefix::uagv_v2("Furrow", "R7").unwrap());
        let first = p.connection(ConnectionState::Online, 0);
        let second = p.connection(ConnectionState::Offline, 1000);
        assert_eq!(first.topic, "uagv/v2/Furrow/R7/connection");
        assert!(first.retain);
        assert_eq!(first.qos, Qos::AtLeastOnce);
        let ids: Vec<u64> = [first, second]
            .iter()
            .map(|p| {
                serde_json::from_slice::<serde_json::Value>(&p.payload).unwrap()["headerId"]
                    .as_u64()
                    .unwrap()
            })
            .collect();
        assert_eq!(ids, [0, 1]);
        let body: serde_json::Value =
            serde_json::from_slice(&p.connection(ConnectionState::Online, 0).payload).unwrap();
        assert_eq!(body["serialNumber"], "R7");
        assert_eq!(body["connectionState"], "ONLINE");
    }
}
