//! `sins-calib import --bag FILE --topic TOPIC`: the `sensor_msgs/Imu` messages of a ROS 1 bag
//! or an MCAP file turned into `imu.csv`; the work is the `import` crate's
//! (`import::import_bag`).

use super::{Args, gap_lines, import_atomically, static_force_line};
use crate::provenance::{ImportProvenance, InputHash};
use crate::render::table;
use crate::{Error, print};
use ::import::ImportOptions;
use std::fmt::Write as _;
use std::path::Path;

/// Run `import --bag`.
pub fn run(bag: &Path, topic: &str, args: &Args) -> Result<(), Error> {
    let options = ImportOptions {
        allow_gaps: args.allow_gaps,
    };
    let (out, imported) = import_atomically(&args.out, &[bag], |dir| {
        ::import::import_bag(bag, topic, &options, dir)
    })?;
    stamp_report(bag, &imported)?;
    let (imu_final, report_final) = (out.final_path("imu.csv"), out.final_path("import.json"));
    out.commit()?;

    let r = &imported.report;
    print(&printout(bag, topic, r, &imu_final, &report_final))
}

/// Write `import.json` again, with the schema stamp first and the SHA-256 of the bag and of
/// `imu.csv` (`crate::provenance::ImportProvenance`): a calibration of the records names them.
fn stamp_report(bag: &Path, imported: &::import::ImportedFiles) -> Result<(), Error> {
    let r = &imported.report;
    let source = r.bag.as_ref().expect("a bag's report");
    // import.json again, with the schema stamp first and the SHA-256 of the bag and of imu.csv.
    #[derive(serde::Serialize)]
    struct ImportJson<'a> {
        #[serde(flatten)]
        report: &'a ::import::ImportReport,
        #[serde(flatten)]
        provenance: ImportProvenance,
    }
    let role = format!(
        "{} file",
        if source.format == "ros1" {
            "ROS 1 bag"
        } else {
            "MCAP"
        }
    );
    let mut output_sha256 = std::collections::BTreeMap::new();
    output_sha256.insert(
        "imu.csv".to_string(),
        crate::provenance::sha256::of_file(&imported.written.imu)?.0,
    );
    let json = ImportJson {
        report: r,
        provenance: ImportProvenance {
            unit: Default::default(),
            input_files: vec![InputHash::of(&role, bag)?],
            output_sha256,
        },
    };
    let report_path = &imported.written.report;
    std::fs::write(
        report_path,
        calib::io::schema::to_json(calib::io::schema::IMPORT, &json)?,
    )
    .map_err(|e| format!("{}: cannot write: {e}", report_path.display()))?;
    Ok(())
}

/// What `import --bag` prints.
fn printout(
    bag: &Path,
    topic: &str,
    r: &::import::ImportReport,
    imu_final: &Path,
    report_final: &Path,
) -> String {
    let source = r.bag.as_ref().expect("a bag's report");
    let c = table::compact;
    let mut s = String::new();
    let _ = writeln!(s, "sins-calib import: {} (topic {topic})", bag.display());
    let _ = writeln!(
        s,
        "  read {} ({}): {} messages of {} on {topic}, header frame id{} {}{}",
        bag.display(),
        if source.format == "ros1" {
            "ROS 1 bag"
        } else {
            "MCAP, ROS 2 CDR"
        },
        r.records,
        source.message_type,
        if source.frame_ids.len() == 1 { "" } else { "s" },
        source
            .frame_ids
            .iter()
            .map(|f| format!("`{f}`"))
            .collect::<Vec<_>>()
            .join(", "),
        if source.more_frame_ids { ", ..." } else { "" }
    );
    let other: Vec<String> = source
        .topics
        .iter()
        .filter(|t| t.topic != topic)
        .map(|t| format!("{} ({}, {})", t.topic, t.message_type, t.messages))
        .collect();
    if !other.is_empty() {
        let _ = writeln!(s, "  other topics, not read: {}", other.join(", "));
    }
    let tm = &r.timing;
    let _ = writeln!(
        s,
        "  time: header stamps t = {} .. {} s, median interval {} s ({} Hz), intervals {} .. \
         {} s (each record keeps its own stamp)",
        c(r.t_first_s),
        c(r.t_last_s),
        c(tm.median_interval_s),
        c(1.0 / tm.median_interval_s),
        c(tm.min_interval_s),
        c(tm.max_interval_s)
    );
    s += &gap_lines(r);
    let v = &source.covariance_varies;
    let _ = writeln!(
        s,
        "  covariances (first message; recorded in import.json): angular velocity {}, linear \
         acceleration {}, orientation {}{}",
        describe_covariance(&source.covariance.angular_velocity),
        describe_covariance(&source.covariance.linear_acceleration),
        if source.covariance.orientation[0] == -1.0 {
            "none (-1: no orientation estimate)".to_string()
        } else {
            describe_covariance(&source.covariance.orientation)
        },
        if v.orientation || v.angular_velocity || v.linear_acceleration {
            "; they change from message to message"
        } else {
            "; the same in every message"
        }
    );
    let _ = writeln!(
        s,
        "  saturation: not checked (a sensor_msgs/Imu message carries no sensor range)"
    );
    s += &static_force_line(r);
    let _ = writeln!(
        s,
        "  wrote {}: {} records, rates (rad/s, m/s^2)",
        imu_final.display(),
        r.records
    );
    let _ = writeln!(s, "  wrote {}", report_final.display());
    s
}

/// A covariance for the printout: `unknown (zeros)`, its diagonal, or `full`.
fn describe_covariance(m: &[f64; 9]) -> String {
    if m.iter().all(|x| *x == 0.0) {
        return "unknown (zeros)".into();
    }
    let off_diagonal_zero = [1, 2, 3, 5, 6, 7].iter().all(|&k| m[k] == 0.0);
    let d = [m[0], m[4], m[8]].map(|x| table::significant(x, 4));
    if off_diagonal_zero {
        format!("diagonal [{}, {}, {}]", d[0], d[1], d[2])
    } else {
        format!("full, diagonal [{}, {}, {}]", d[0], d[1], d[2])
    }
}
