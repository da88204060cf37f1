//! ROS recordings imported into `imu.csv`: a ROS 1 bag (`.bag`) or an MCAP file (ROS 2's
//! default storage) with `sensor_msgs/Imu` messages on one topic ([`import_bag`]).
//!
//! Each message on the topic becomes one record of `imu.csv` (rates: angular velocity in rad/s,
//! linear acceleration in m/s^2, as the message carries them, axes as they are), at the time of
//! its header stamp (not the time the recorder received it). The messages are read and written
//! one at a time; the checks of the profile route (time strictly increasing, the time base,
//! gaps, magnitudes, a stuck sensor, the specific force at rest against g) then read the written
//! `imu.csv` again, as [`crate::import_into`] does. The report records the topic, its message
//! type, the header frame ids, the first message's covariances and whether they change.

mod imu_msg;
mod mcap_file;
mod ros1;

pub use imu_msg::{ImuMessage, decode_cdr, decode_ros1};

use crate::checks::{show_number, show_t};
use crate::profile_import::{Out, Quietest, WrittenImu, read_imu, read_timing, write_reports};
use crate::{
    G_BAND, GapReport, ImportError, ImportOptions, ImportReport, ImportedFiles, InputFile,
    MAX_ACCEL_M_S2, MAX_GYRO_RAD_S, MEDIAN_INTERVAL_RANGE_S, StaticForce,
};
use calib::io::{ImuKind, format_f64};
use profile::{Form, STANDARD_GRAVITY};
use serde::{Deserialize, Serialize};
use sins_model::timing::StreamedIntervalMedian;
use std::path::Path;

use crate::profile;

/// What an import visits of each message on the topic: its bytes.
pub(crate) type MessageVisitor<'a> = &'a mut dyn FnMut(&[u8]) -> Result<(), ImportError>;

/// What a format's reader gives: every topic of the file counted (its messages given to the
/// [`MessageVisitor`] on the way), or the refusal.
pub(crate) type TopicCounts = Result<Vec<TopicCount>, ImportError>;

/// A topic of the file with its message type and how many messages it holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TopicCount {
    /// The topic.
    pub topic: String,
    /// Its message type as the file names it (`sensor_msgs/Imu`, `sensor_msgs/msg/Imu`, ...).
    pub message_type: String,
    /// Messages on it.
    pub messages: usize,
}

/// The topics of a file, in the order they first appear.
#[derive(Default)]
pub(crate) struct Topics {
    list: Vec<TopicCount>,
}

impl Topics {
    /// The entry of a topic with a type (one topic may come from several connections).
    fn entry(&mut self, topic: &str, message_type: &str) -> usize {
        if let Some(at) = self
            .list
            .iter()
            .position(|t| t.topic == topic && t.message_type == message_type)
        {
            return at;
        }
        self.list.push(TopicCount {
            topic: topic.into(),
            message_type: message_type.into(),
            messages: 0,
        });
        self.list.len() - 1
    }

    fn count(&mut self, at: usize) {
        self.list[at].messages += 1;
    }
}

/// The refusal of a topic whose messages are not `sensor_msgs/Imu`.
fn wrong_type(file: &str, topic: &str, found: &str, expected: &str) -> ImportError {
    ImportError::file(
        file,
        format!(
            "topic {topic} carries `{found}` messages: expected {expected} (angular velocity \
             and linear acceleration of an IMU)"
        ),
    )
}

/// The covariances of a `sensor_msgs/Imu` message (row-major 3x3 each, as the message has them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImuCovariance {
    /// Of the orientation (`-1` first: the message has no orientation estimate).
    pub orientation: [f64; 9],
    /// Of the angular velocity ((rad/s)^2; all zero: unknown).
    pub angular_velocity: [f64; 9],
    /// Of the linear acceleration ((m/s^2)^2; all zero: unknown).
    pub linear_acceleration: [f64; 9],
}

/// Whether a covariance of a later message differs from the first message's (bit for bit).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CovarianceVaries {
    /// The orientation covariance.
    pub orientation: bool,
    /// The angular velocity covariance.
    pub angular_velocity: bool,
    /// The linear acceleration covariance.
    pub linear_acceleration: bool,
}

/// At most this many distinct header frame ids are listed.
pub const MAX_FRAME_IDS: usize = 16;

/// What `import.json` records of a ROS recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BagSource {
    /// `"ros1"` (a ROS 1 bag) or `"mcap"` (an MCAP file of ROS 2 messages in CDR).
    pub format: String,
    /// The topic imported.
    pub topic: String,
    /// Its message type as the file names it.
    pub message_type: String,
    /// The distinct header frame ids of its messages, in order of appearance (at most
    /// [`MAX_FRAME_IDS`]).
    pub frame_ids: Vec<String>,
    /// Whether more distinct frame ids came than are listed.
    pub more_frame_ids: bool,
    /// The first message's covariances.
    pub covariance: ImuCovariance,
    /// Which covariances change after the first message.
    pub covariance_varies: CovarianceVaries,
    /// Every topic of the file with its type and message count.
    pub topics: Vec<TopicCount>,
}

/// The format of a ROS recording, from its first bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BagFormat {
    /// A ROS 1 bag, format 2.0.
    Ros1,
    /// An MCAP file.
    Mcap,
}

impl BagFormat {
    /// The format of the file at `path`, from its magic bytes; refused when it is neither.
    pub fn of(path: &Path) -> Result<Self, ImportError> {
        use std::io::Read;
        let file = path.display().to_string();
        // A named pipe or a device would block or never end: only a file is read.
        if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) && path.exists() {
            return Err(ImportError::file(
                &file,
                "is not a regular file: expected a ROS 1 bag (.bag) or an MCAP file (.mcap)",
            ));
        }
        let mut head = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(16).read_to_end(&mut head))
            .map_err(|source| ImportError::read(&file, source))?;
        if head.starts_with(ros1::MAGIC) {
            Ok(Self::Ros1)
        } else if head.starts_with(mcap_file::MAGIC) {
            Ok(Self::Mcap)
        } else {
            Err(ImportError::file(
                &file,
                "the file starts with neither `#ROSBAG V2.0` (a ROS 1 bag) nor the MCAP magic \
                 bytes: expected a ROS 1 bag (.bag) or an MCAP file (.mcap)",
            ))
        }
    }

    /// `"ros1"` or `"mcap"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Ros1 => "ros1",
            Self::Mcap => "mcap",
        }
    }

    /// The message type the format names `sensor_msgs/Imu` by.
    pub fn imu_type(self) -> &'static str {
        match self {
            Self::Ros1 => ros1::IMU_TYPE,
            Self::Mcap => mcap_file::IMU_TYPE,
        }
    }
}

/// The messages of the topic written to `imu.csv` as they come.
struct Writing<'a> {
    file: &'a str,
    topic: &'a str,
    decode: fn(&[u8]) -> Result<ImuMessage, String>,
    imu: Out,
    line: String,
    records: usize,
    t_first: f64,
    t_last: f64,
    median: StreamedIntervalMedian,
    frame_ids: Vec<String>,
    more_frame_ids: bool,
    covariance: Option<ImuCovariance>,
    varies: CovarianceVaries,
}

impl Writing<'_> {
    /// The refusal of message `n` (1-based, on the topic).
    fn refuse(&self, n: usize, message: String) -> ImportError {
        ImportError::file(
            self.file,
            format!("topic {}, message {n}: {message}", self.topic),
        )
    }

    fn push(&mut self, bytes: &[u8]) -> Result<(), ImportError> {
        let n = self.records + 1;
        let m = (self.decode)(bytes).map_err(|e| self.refuse(n, e))?;
        if m.stamp_nanosec >= 1_000_000_000 {
            return Err(self.refuse(
                n,
                format!(
                    "header stamp nanoseconds = {}: expected 0 .. 999999999",
                    m.stamp_nanosec
                ),
            ));
        }
        let t = stamp_seconds(m.stamp_sec, m.stamp_nanosec);
        for (name, v) in [
            ("angular_velocity", m.angular_velocity),
            ("linear_acceleration", m.linear_acceleration),
        ] {
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(self.refuse(
                    n,
                    format!(
                        "{name}.{} = {} (t = {} s): expected a finite number",
                        ["x", "y", "z"][k],
                        v[k],
                        show_t(t)
                    ),
                ));
            }
        }
        if self.records > 0 && t.partial_cmp(&self.t_last) != Some(std::cmp::Ordering::Greater) {
            return Err(self.refuse(
                n,
                format!(
                    "header stamp t = {} s is not after message {}'s t = {} s: expected strictly \
                     increasing header stamps (the recorder's receive times are not used)",
                    show_t(t),
                    n - 1,
                    show_t(self.t_last)
                ),
            ));
        }
        self.line.clear();
        self.line += &format_f64(t);
        for v in m.angular_velocity.iter().chain(&m.linear_acceleration) {
            self.line.push(',');
            self.line += &format_f64(*v);
        }
        self.line.push('\n');
        self.imu.write(&self.line)?;
        self.note(&m);
        if self.records == 0 {
            self.t_first = t;
        }
        self.t_last = t;
        self.median.push(t);
        self.records += 1;
        Ok(())
    }

    /// The frame id and covariances of a message noted.
    fn note(&mut self, m: &ImuMessage) {
        if !self.frame_ids.contains(&m.frame_id) {
            if self.frame_ids.len() < MAX_FRAME_IDS {
                self.frame_ids.push(m.frame_id.clone());
            } else {
                self.more_frame_ids = true;
            }
        }
        let same =
            |a: &[f64; 9], b: &[f64; 9]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        match &self.covariance {
            None => {
                self.covariance = Some(ImuCovariance {
                    orientation: m.orientation_covariance,
                    angular_velocity: m.angular_velocity_covariance,
                    linear_acceleration: m.linear_acceleration_covariance,
                });
            }
            Some(c) => {
                self.varies.orientation |= !same(&c.orientation, &m.orientation_covariance);
                self.varies.angular_velocity |=
                    !same(&c.angular_velocity, &m.angular_velocity_covariance);
                self.varies.linear_acceleration |=
                    !same(&c.linear_acceleration, &m.linear_acceleration_covariance);
            }
        }
    }
}

/// A header stamp in seconds: correctly rounded below 2^53 ns (104 days; a stamp counted from
/// the start of a recording, or a simulated clock), within one unit in the last place above it
/// (a wall-clock stamp since 1970, which a double holds to about 0.2 us).
pub fn stamp_seconds(sec: i64, nanosec: u32) -> f64 {
    let ns = i128::from(sec) * 1_000_000_000 + i128::from(nanosec);
    if ns.unsigned_abs() < 1 << 53 {
        ns as f64 / 1e9
    } else {
        sec as f64 + f64::from(nanosec) / 1e9
    }
}

/// Import the `sensor_msgs/Imu` messages on `topic` of the ROS 1 bag or MCAP file at `path`
/// into `dir` (which must exist): `imu.csv` and `import.json` (with [`ImportReport::bag`]),
/// in memory independent of the recording's length. A refusal names the file, the topic and
/// the message; files written into `dir` before it are left there (write into a fresh
/// directory and remove it on an error).
pub fn import_bag(
    path: &Path,
    topic: &str,
    options: &ImportOptions,
    dir: &Path,
) -> Result<ImportedFiles, ImportError> {
    let format = BagFormat::of(path)?;
    let file = path.display().to_string();
    let imu_path = dir.join("imu.csv");
    let mut imu = Out::create(imu_path.clone())?;
    imu.write(&format!("t,{}\n", ImuKind::Rates.columns().join(",")))?;
    let mut w = Writing {
        file: &file,
        topic,
        decode: match format {
            BagFormat::Ros1 => decode_ros1,
            BagFormat::Mcap => decode_cdr,
        },
        imu,
        line: String::new(),
        records: 0,
        t_first: f64::NAN,
        t_last: f64::NAN,
        median: StreamedIntervalMedian::new(),
        frame_ids: Vec::new(),
        more_frame_ids: false,
        covariance: None,
        varies: CovarianceVaries::default(),
    };
    let mut visit = |bytes: &[u8]| w.push(bytes);
    let topics = match format {
        BagFormat::Ros1 => ros1::read(path, &file, topic, &mut visit)?,
        BagFormat::Mcap => mcap_file::read(path, &file, topic, &mut visit)?,
    };
    let Some(found) = topics.iter().find(|t| t.topic == topic) else {
        return Err(missing_topic(&file, topic, &topics));
    };
    if w.records < 2 {
        return Err(ImportError::file(
            &file,
            format!(
                "topic {topic} has {} message{}: expected at least two (a recording)",
                w.records,
                if w.records == 1 { "" } else { "s" }
            ),
        ));
    }
    let message_type = found.message_type.clone();
    let source = BagSource {
        format: format.name().into(),
        topic: topic.into(),
        message_type,
        frame_ids: std::mem::take(&mut w.frame_ids),
        more_frame_ids: w.more_frame_ids,
        covariance: w.covariance.take().expect("two messages"),
        covariance_varies: w.varies,
        topics,
    };
    let (records, t_first, t_last) = (w.records, w.t_first, w.t_last);
    let median = w.median;
    w.imu.finish()?;
    let median = median.finish(|visit| read_imu(&imu_path, |r| visit(r.t)))?;
    let imu = WrittenImu {
        path: imu_path,
        kind: ImuKind::Rates,
        records,
        median,
    };
    let checked = check_written(&file, topic, options, &imu)?;
    let report = ImportReport {
        profile: None,
        description: None,
        inputs: vec![InputFile {
            role: format!("{} {topic}", format.name()),
            file: file.clone(),
            rows: records,
            first_line: 1,
            last_line: records,
        }],
        form: "rates".into(),
        records,
        t_first_s: t_first,
        t_last_s: t_last,
        timing: checked.timing,
        gaps: checked.gaps,
        saturation: Vec::new(),
        static_force: checked.static_force,
        turntable: false,
        sections: None,
        bag: Some(source),
    };
    let written = write_reports(dir, &report, None, imu.path, None)?;
    Ok(ImportedFiles {
        report,
        sections: None,
        written,
    })
}

/// The refusal of a topic the file does not have, listing those it has.
fn missing_topic(file: &str, topic: &str, topics: &[TopicCount]) -> ImportError {
    let listed: Vec<String> = topics
        .iter()
        .map(|t| format!("{} ({}, {} messages)", t.topic, t.message_type, t.messages))
        .collect();
    ImportError::file(
        file,
        format!(
            "no topic {topic}: expected one of the file's topics: {}",
            if listed.is_empty() {
                "(none: the file holds no messages)".to_string()
            } else {
                listed.join(", ")
            }
        ),
    )
}

/// What the checks of the written records found.
struct Checked {
    timing: calib::io::timing::Timing,
    gaps: Vec<GapReport>,
    static_force: StaticForce,
}

/// The checks of the profile route on the written `imu.csv`: the time base, the gaps, the
/// magnitudes, a stuck sensor and the specific force at rest. Messages are named by their
/// 1-based number on the topic.
fn check_written(
    file: &str,
    topic: &str,
    options: &ImportOptions,
    imu: &WrittenImu,
) -> Result<Checked, ImportError> {
    let refuse = |message: String| ImportError::file(file, format!("topic {topic}: {message}"));
    let (lo, hi) = MEDIAN_INTERVAL_RANGE_S;
    if !(lo..=hi).contains(&imu.median) {
        return Err(refuse(format!(
            "the header stamps advance by a median {} s ({} Hz) between messages: expected \
             {lo} .. {hi} s, an IMU recording at 1 Hz or more",
            show_number(imu.median),
            show_number(1.0 / imu.median)
        )));
    }
    let gap_factor = profile::Checks::default().gap_factor;
    let read = read_timing(gap_factor, Form::Rates, imu)?;
    let gaps: Vec<GapReport> = read
        .gaps
        .iter()
        .map(|g| GapReport {
            record: g.index,
            file: file.to_string(),
            line: g.index + 1,
            t_before_s: g.t_before_s,
            t_after_s: g.t_after_s,
            length_s: g.length_s(),
            median_intervals: g.length_s() / imu.median,
        })
        .collect();
    if let (Some(g), false) = (gaps.first(), options.allow_gaps) {
        return Err(refuse(format!(
            "message {}: a gap of {} s ({:.1} median intervals of {} s) between t = {} s \
             (message {}) and t = {} s: expected intervals of at most {gap_factor} median \
             intervals ({} gap{} in all); gaps are never bridged: import with gaps allowed \
             (sins-calib import --allow-gaps) to keep the records as they are with the gaps \
             recorded in import.json",
            g.line,
            show_number(g.length_s),
            g.median_intervals,
            show_number(imu.median),
            show_t(g.t_before_s),
            g.line - 1,
            show_t(g.t_after_s),
            gaps.len(),
            if gaps.len() == 1 { "" } else { "s" }
        )));
    }
    if let Some((k, s, i, v)) = read.beyond {
        let (name, max, unit) = if s == 0 {
            ("angular_velocity", MAX_GYRO_RAD_S, "rad/s")
        } else {
            ("linear_acceleration", MAX_ACCEL_M_S2, "m/s^2")
        };
        return Err(refuse(format!(
            "message {}: {name}.{} = {v:.4e} {unit}: expected a magnitude below {max} {unit} \
             (sensor_msgs/Imu is in rad/s and m/s^2: a value beyond is another unit or a \
             corrupt message)",
            k + 1,
            ["x", "y", "z"][i]
        )));
    }
    read.stuck
        .check(1, imu.records)
        .map_err(|m| refuse(m.replacen("lines", "messages", 1)))?;
    let static_force = check_force_at_rest(imu, read.quiet, &refuse)?;
    Ok(Checked {
        timing: read.timing,
        gaps,
        static_force,
    })
}

/// The quietest second's specific force against g.
fn check_force_at_rest(
    imu: &WrittenImu,
    quiet: Quietest,
    refuse: &dyn Fn(String) -> ImportError,
) -> Result<StaticForce, ImportError> {
    let q = crate::profile_import::quietest_window(imu, quiet)?;
    let ratio = q.median_norm / STANDARD_GRAVITY;
    if (G_BAND.0..=G_BAND.1).contains(&ratio) {
        return Ok(StaticForce {
            median_norm_m_s2: q.median_norm,
            ratio_to_g: ratio,
            window_s: q.window_s,
            std_m_s2: q.std,
        });
    }
    Err(refuse(format!(
        "the specific force at rest has a median magnitude of {} m/s^2 ({} g) over messages \
         {}..{} (t = {} .. {} s, the quietest {} s of the recording): expected g = {} m/s^2 \
         within {} to {} g; sensor_msgs/Imu carries linear_acceleration in m/s^2: check that \
         the topic is an IMU's (an accelerometer given in g would read about 0.1 g)",
        show_number(q.median_norm),
        show_number(ratio),
        q.records.0 + 1,
        q.records.1 + 1,
        show_t(q.window_s[0]),
        show_t(q.window_s[1]),
        crate::QUIET_WINDOW_S,
        STANDARD_GRAVITY,
        G_BAND.0,
        G_BAND.1
    )))
}

#[cfg(test)]
mod tests;
