//! MCAP files (ROS 2 bags) read as a stream with the `mcap` crate's sans-io reader: the file is
//! read in pieces and each chunk decompressed on its own, so memory holds one chunk however
//! long the recording.

use super::{MessageVisitor, TopicCounts, Topics};
use crate::ImportError;
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader};
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

/// The first bytes of an MCAP file.
pub const MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// The schema name ROS 2 gives `sensor_msgs/msg/Imu`.
pub const IMU_TYPE: &str = "sensor_msgs/msg/Imu";

/// A channel's topic, schema name and message encoding, and its entry in the topic list.
struct ChannelOf {
    at: usize,
    wanted: bool,
}

/// Read the file's records in order: every channel counted, every message on `topic` (of
/// schema `sensor_msgs/msg/Imu` in CDR, else refused) given to `visit` as its bytes.
pub fn read(path: &Path, file: &str, topic: &str, visit: MessageVisitor<'_>) -> TopicCounts {
    let read_err = |source| ImportError::read(file, source);
    let broken = |e: mcap::McapError| {
        ImportError::file(
            file,
            format!("reading stopped: {e}: expected a whole MCAP file (truncated?)"),
        )
    };
    let mut f = std::fs::File::open(path).map_err(read_err)?;
    let mut reader = LinearReader::new();
    let mut schemas = HashMap::<u16, String>::new();
    let mut channels = HashMap::<u16, ChannelOf>::new();
    let mut topics = Topics::default();
    while let Some(event) = reader.next_event() {
        match event.map_err(broken)? {
            LinearReadEvent::ReadRequest(need) => {
                let n = f.read(reader.insert(need)).map_err(read_err)?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record { opcode, data } => {
                match mcap::parse_record(opcode, data).map_err(broken)? {
                    Record::Schema { header, .. } => {
                        schemas.insert(header.id, header.name);
                    }
                    Record::Channel(c) => {
                        let name = schemas.get(&c.schema_id).cloned().unwrap_or_default();
                        if c.topic == topic {
                            if name != IMU_TYPE {
                                return Err(super::wrong_type(file, topic, &name, IMU_TYPE));
                            }
                            if c.message_encoding != "cdr" {
                                return Err(ImportError::file(
                                    file,
                                    format!(
                                        "topic {topic}: its messages are encoded as `{}`: \
                                         expected `cdr` (ROS 2)",
                                        c.message_encoding
                                    ),
                                ));
                            }
                        }
                        let at = topics.entry(&c.topic, &name);
                        let wanted = c.topic == topic;
                        channels.insert(c.id, ChannelOf { at, wanted });
                    }
                    Record::Message { header, data } => {
                        let Some(c) = channels.get(&header.channel_id) else {
                            return Err(ImportError::file(
                                file,
                                format!(
                                    "a message of channel {} comes before that channel's \
                                     record: expected an MCAP file as ROS 2 writes it",
                                    header.channel_id
                                ),
                            ));
                        };
                        topics.count(c.at);
                        if c.wanted {
                            visit(&data)?;
                        }
                    }
                    _ => {}
                }
            }
        }
    }
    Ok(topics.list)
}
