//! ROS 1 bags (format 2.0) read with the `rosbag` crate: the crate maps the file into memory
//! (the operating system pages it in and out; nothing is copied but one decompressed chunk at a
//! time) and walks its chunks in file order.

use super::{MessageVisitor, TopicCounts, Topics};
use crate::ImportError;
use rosbag::{ChunkRecord, MessageRecord, RosBag};
use std::io::Read;
use std::path::Path;

/// The first line of a ROS 1 bag.
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// The type name a ROS 1 connection gives `sensor_msgs/Imu`, and its definition's MD5 sum
/// (the same for every ROS 1 release: the definition has not changed).
pub const IMU_TYPE: &str = "sensor_msgs/Imu";
const IMU_MD5: &str = "6a62c6daae103f4ff57a132d6f95cec2";

/// Where the bag header says the index starts: checked against the file's length before the
/// crate slices the mapped file there (a truncated or unindexed bag would make it panic).
fn check_index_position(path: &Path, file: &str) -> Result<(), ImportError> {
    let read_err = |source| ImportError::read(file, source);
    let len = std::fs::metadata(path).map_err(read_err)?.len();
    let mut head = Vec::new();
    std::fs::File::open(path)
        .map_err(read_err)?
        .take(4096 + MAGIC.len() as u64)
        .read_to_end(&mut head)
        .map_err(read_err)?;
    let bad = |what: &str| {
        ImportError::file(
            file,
            format!("{what}: expected a ROS 1 bag (format 2.0) written to its end"),
        )
    };
    let rest = &head[MAGIC.len()..];
    let Some(n) = rest
        .get(..4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    else {
        return Err(bad("the file ends inside the bag header"));
    };
    let Some(mut fields) = rest.get(4..4 + n as usize) else {
        return Err(bad("the file ends inside the bag header"));
    };
    let start = (MAGIC.len() + 4 + n as usize) as u64;
    while fields.len() >= 4 {
        let k = u32::from_le_bytes([fields[0], fields[1], fields[2], fields[3]]) as usize;
        let Some(field) = fields.get(4..4 + k) else {
            return Err(bad("a field of the bag header runs past the header"));
        };
        if let Some(value) = field.strip_prefix(b"index_pos=") {
            let Ok(v) = <[u8; 8]>::try_from(value) else {
                return Err(bad("index_pos in the bag header is not 8 bytes"));
            };
            let index_pos = u64::from_le_bytes(v);
            if index_pos == 0 {
                return Err(bad(
                    "the bag has no index (index_pos = 0: its recording was not closed); \
                     `rosbag reindex` writes one",
                ));
            }
            if index_pos < start || index_pos > len {
                return Err(bad(&format!(
                    "the bag header puts the index at byte {index_pos}, but the file has {len} \
                     bytes (truncated?)"
                )));
            }
            return Ok(());
        }
        fields = &fields[4 + k..];
    }
    Err(bad("the bag header has no index_pos"))
}

/// Read the bag's chunks in order: every connection counted, every message on `topic` (of
/// type `sensor_msgs/Imu`, else refused) given to `visit` as its bytes.
pub fn read(path: &Path, file: &str, topic: &str, visit: MessageVisitor<'_>) -> TopicCounts {
    check_index_position(path, file)?;
    let bag = RosBag::new(path).map_err(|source| ImportError::read(file, source))?;
    let broken = |e: rosbag::Error| {
        ImportError::file(
            file,
            format!("reading stopped: {e}: expected a whole ROS 1 bag (truncated?)"),
        )
    };
    // Connection id -> its entry in `topics`.
    let mut connections = std::collections::HashMap::<u32, usize>::new();
    let mut topics = Topics::default();
    for record in bag.chunk_records() {
        let ChunkRecord::Chunk(chunk) = record.map_err(broken)? else {
            continue;
        };
        for m in chunk.messages() {
            match m.map_err(broken)? {
                MessageRecord::Connection(c) => {
                    if c.topic == topic && c.tp != IMU_TYPE {
                        return Err(super::wrong_type(file, topic, c.tp, IMU_TYPE));
                    }
                    let md5: String = c.md5sum.iter().map(|b| format!("{b:02x}")).collect();
                    if c.topic == topic && md5 != IMU_MD5 {
                        return Err(ImportError::file(
                            file,
                            format!(
                                "topic {topic}: its sensor_msgs/Imu has the definition MD5 sum \
                                 {md5}: expected {IMU_MD5} (the definition every ROS 1 release \
                                 uses)"
                            ),
                        ));
                    }
                    let at = topics.entry(c.topic, c.tp);
                    connections.insert(c.id, at);
                }
                MessageRecord::MessageData(d) => {
                    let Some(&at) = connections.get(&d.conn_id) else {
                        return Err(ImportError::file(
                            file,
                            format!(
                                "a message of connection {} comes before that connection's \
                                 record: expected a ROS 1 bag as rosbag writes it",
                                d.conn_id
                            ),
                        ));
                    };
                    topics.count(at);
                    if topics.list[at].topic == topic {
                        visit(d.data)?;
                    }
                }
            }
        }
    }
    Ok(topics.list)
}
