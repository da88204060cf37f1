//! The bag route on MCAP files written here with the `mcap` crate's writer (zstd and LZ4
//! chunks) and messages serialized with the `cdr` crate: gaps, frame ids and covariances,
//! magnitudes and the specific force at rest.

use super::imu_msg::{Ros2Header as Header, Ros2Imu as Imu, Ros2Time as Time};
use super::*;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// A message at `stamp_ns` at rest (gravity along z, a small deterministic wobble so that no
/// triad is constant).
fn at_rest(k: usize, stamp_ns: i64) -> Imu {
    let wobble = (k as f64 * 0.7).sin() * 1e-3;
    Imu {
        header: Header {
            stamp: Time {
                sec: (stamp_ns.div_euclid(1_000_000_000)) as i32,
                nanosec: stamp_ns.rem_euclid(1_000_000_000) as u32,
            },
            frame_id: "imu".into(),
        },
        orientation: [0.0, 0.0, 0.0, 1.0],
        orientation_covariance: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        angular_velocity: [wobble, -wobble, 0.5 * wobble],
        angular_velocity_covariance: [0.0; 9],
        linear_acceleration: [wobble, 2.0 * wobble, 9.81 + wobble],
        linear_acceleration_covariance: [0.0; 9],
    }
}

/// Write `messages` on `/imu` (and two on `/other`) to a fresh MCAP file.
fn write_mcap(name: &str, compression: mcap::Compression, messages: &[Imu]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("import-bag-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join(format!("{name}.mcap"));
    let file = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
    let mut w = mcap::WriteOptions::new()
        .compression(Some(compression))
        .chunk_size(Some(4096))
        .create(file)
        .expect("writer");
    let schema = w
        .add_schema("sensor_msgs/msg/Imu", "ros2msg", b"")
        .expect("schema");
    let imu = w
        .add_channel(schema, "/imu", "cdr", &BTreeMap::new())
        .expect("channel");
    let other_schema = w
        .add_schema("std_msgs/msg/String", "ros2msg", b"")
        .expect("schema");
    let other = w
        .add_channel(other_schema, "/other", "cdr", &BTreeMap::new())
        .expect("channel");
    for (k, m) in messages.iter().enumerate() {
        let data = cdr::serialize::<_, _, cdr::CdrLe>(m, cdr::Infinite).expect("cdr");
        let header = mcap::records::MessageHeader {
            channel_id: imu,
            sequence: k as u32,
            log_time: k as u64,
            publish_time: k as u64,
        };
        w.write_to_known_channel(&header, &data).expect("write");
        if k < 2 {
            let header = mcap::records::MessageHeader {
                channel_id: other,
                ..header
            };
            w.write_to_known_channel(&header, &[0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0])
                .expect("write");
        }
    }
    w.finish().expect("finish");
    path
}

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join(format!("import-bag-tests-{}", std::process::id()))
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    dir
}

/// 300 messages at 100 Hz from 5 s, those of `skip` left out.
fn recording(skip: std::ops::Range<usize>) -> Vec<Imu> {
    (0..300)
        .filter(|k| !skip.contains(k))
        .map(|k| at_rest(k, 5_000_000_000 + 10_000_000 * k as i64))
        .collect()
}

#[test]
fn a_gap_is_refused_at_its_message_or_kept_with_allow_gaps() {
    let path = write_mcap("gap", mcap::Compression::Zstd, &recording(100..110));
    let e = import_bag(&path, "/imu", &ImportOptions::default(), &out_dir("gap1"))
        .expect_err("a gap")
        .to_string();
    assert!(
        e.contains("topic /imu: message 101: a gap of 0.11 s (11.0 median intervals of 0.01 s) between t = 5.99 s (message 100) and t = 6.1 s"),
        "{e}"
    );
    let options = ImportOptions { allow_gaps: true };
    let done = import_bag(&path, "/imu", &options, &out_dir("gap2")).expect("imports");
    let r = &done.report;
    assert_eq!(r.records, 290);
    assert_eq!(
        (r.gaps.len(), r.gaps[0].record, r.gaps[0].line),
        (1, 100, 101)
    );
    assert_eq!((r.t_first_s, r.t_last_s), (5.0, 7.99));
    let bag = r.bag.as_ref().expect("bag");
    assert_eq!(bag.format, "mcap");
    assert_eq!(bag.message_type, "sensor_msgs/msg/Imu");
    assert_eq!(bag.topics.len(), 2);
    assert_eq!(
        (bag.topics[1].topic.as_str(), bag.topics[1].messages),
        ("/other", 2)
    );
    let text = std::fs::read_to_string(&done.written.imu).expect("imu.csv");
    assert_eq!(text.lines().count(), 291);
    assert!(
        text.starts_with("t,wx,wy,wz,fx,fy,fz\n5,0,-0,0,0,0,9.81\n"),
        "{text:.80}"
    );
}

#[test]
fn frame_ids_and_changing_covariances_are_recorded() {
    let mut messages = recording(0..0);
    messages[7].header.frame_id = "other_frame".into();
    messages[9].linear_acceleration_covariance[4] = 1e-4;
    let path = write_mcap("frames", mcap::Compression::Lz4, &messages);
    let done =
        import_bag(&path, "/imu", &ImportOptions::default(), &out_dir("frames")).expect("imports");
    let bag = done.report.bag.expect("bag");
    assert_eq!(bag.frame_ids, ["imu", "other_frame"]);
    assert!(!bag.more_frame_ids);
    assert_eq!(bag.covariance.orientation[0], -1.0);
    assert_eq!(bag.covariance.linear_acceleration, [0.0; 9]);
    let v = bag.covariance_varies;
    assert!(
        v.linear_acceleration && !v.angular_velocity && !v.orientation,
        "{v:?}"
    );
}

#[test]
fn implausible_values_are_refused_naming_the_message() {
    let mut messages = recording(0..0);
    messages[41].angular_velocity[1] = 250.0;
    let path = write_mcap("fast", mcap::Compression::Zstd, &messages);
    let e = import_bag(&path, "/imu", &ImportOptions::default(), &out_dir("fast"))
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("topic /imu: message 42: angular_velocity.y = 2.5000e2 rad/s: expected a magnitude below 100 rad/s"),
        "{e}"
    );
    // An accelerometer in g: 1 instead of 9.81.
    let messages: Vec<Imu> = recording(0..0)
        .into_iter()
        .map(|mut m| {
            m.linear_acceleration[2] -= 8.81;
            m
        })
        .collect();
    let path = write_mcap("in_g", mcap::Compression::Zstd, &messages);
    let e = import_bag(&path, "/imu", &ImportOptions::default(), &out_dir("in_g"))
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("the specific force at rest has a median magnitude of 1"),
        "{e}"
    );
    assert!(e.contains("over messages"), "{e}");
}

#[test]
fn stamps_before_1970_are_kept() {
    // ROS 2 seconds are signed: -1 s + 5 ms steps, t = -1 .. -0.005 .. 0 .. 0.995 s.
    let messages: Vec<Imu> = (0..400)
        .map(|k| at_rest(k, -1_000_000_000 + 5_000_000 * k as i64))
        .collect();
    let path = write_mcap("negative", mcap::Compression::Zstd, &messages);
    let done = import_bag(
        &path,
        "/imu",
        &ImportOptions::default(),
        &out_dir("negative"),
    )
    .expect("imports");
    assert_eq!((done.report.t_first_s, done.report.t_last_s), (-1.0, 0.995));
    // The intervals are differences of rounded seconds: 5 ms to within rounding.
    assert!((done.report.timing.median_interval_s - 0.005).abs() < 1e-15);
    let text = std::fs::read_to_string(&done.written.imu).expect("imu.csv");
    assert!(
        text.lines().nth(201).expect("line").starts_with("0,"),
        "{text:.80}"
    );
}
