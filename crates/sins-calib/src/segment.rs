//! `sins-calib segment`: an `imu.csv` split into static intervals and motion by the `import`
//! crate's static detector.

use crate::table::{self, Align, Table};
use crate::{Error, print};
use ::import::detect::{DetectorSettings, Segmentation, segment};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `segment`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// IMU records (imu.csv, rates or increments; as written by `import` or `simulate`).
    #[arg(long, value_name = "FILE")]
    pub imu: PathBuf,
    /// Also write the segmentation to this JSON file: the settings, every static interval (start,
    /// end, duration, records, mean specific force and |f|, mean rate, deviations), the motion
    /// between them and any gaps (docs/formats.md "Segment file").
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Length of the sliding window centred on each record, in seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = DetectorSettings::default().window_s)]
    pub window: f64,
    /// Largest standard deviation of the specific force over the window (root of the summed
    /// variances of the three axes), m/s^2.
    #[arg(long, value_name = "M_S2", default_value_t = DetectorSettings::default().max_std_f_m_s2)]
    pub max_std_f: f64,
    /// Largest standard deviation of the angular rate over the window, rad/s.
    #[arg(long, value_name = "RAD_S", default_value_t = DetectorSettings::default().max_std_w_rad_s)]
    pub max_std_w: f64,
    /// Largest magnitude of the mean angular rate over the window, rad/s (keeps a steady
    /// rotation from passing for rest; above any plausible gyro bias).
    #[arg(long, value_name = "RAD_S", default_value_t = DetectorSettings::default().max_rate_rad_s)]
    pub max_rate: f64,
    /// Shortest static interval, in seconds (first to last record).
    #[arg(long, value_name = "SECONDS", default_value_t = DetectorSettings::default().min_duration_s)]
    pub min_duration: f64,
    /// An interval between records longer than this many median intervals is a gap; static
    /// intervals end at gaps.
    #[arg(long, value_name = "FACTOR", default_value_t = DetectorSettings::default().gap_factor)]
    pub gap_factor: f64,
}

/// The JSON file: the segmentation with the file it is of.
#[derive(Serialize)]
struct SegmentJson<'a> {
    imu: String,
    #[serde(flatten)]
    segmentation: &'a Segmentation,
}

/// Run `segment`.
pub fn run(args: &Args) -> Result<(), Error> {
    let settings = DetectorSettings {
        window_s: args.window,
        max_std_f_m_s2: args.max_std_f,
        max_std_w_rad_s: args.max_std_w,
        max_rate_rad_s: args.max_rate,
        min_duration_s: args.min_duration,
        gap_factor: args.gap_factor,
        ..DetectorSettings::default()
    };
    settings
        .check()
        .map_err(|e| format!("segment: detector setting {e}"))?;
    let data = calib::io::read_imu_csv(&args.imu)?;
    let file = args.imu.display().to_string();
    let seg = segment(&data, &settings).map_err(|e| format!("{file}: {e}"))?;
    let c = table::compact;
    let sig = table::significant;

    let mut s = String::new();
    let _ = writeln!(
        s,
        "sins-calib segment: {file}: {} records, t = {} .. {} s, median interval {} s",
        seg.records,
        c(seg.t_first_s),
        c(seg.t_last_s),
        c(seg.median_interval_s)
    );
    let _ = writeln!(
        s,
        "  detector: window {} s ({} records), std f < {} m/s^2, std w < {} rad/s, |mean w| < {} \
         rad/s, at least {} s",
        c(settings.window_s),
        seg.window_records,
        c(settings.max_std_f_m_s2),
        c(settings.max_std_w_rad_s),
        c(settings.max_rate_rad_s),
        c(settings.min_duration_s)
    );
    let n = seg.static_intervals.len();
    let durations: Vec<f64> = seg.static_intervals.iter().map(|x| x.duration_s).collect();
    let (lo, hi) = durations
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), d| {
            (a.min(*d), b.max(*d))
        });
    let _ = writeln!(
        s,
        "  {n} static interval{}, {} s at rest{}; {} stretch{} of motion; {}",
        if n == 1 { "" } else { "s" },
        sig(seg.static_s(), 4),
        if n > 0 {
            format!(" (each {} .. {} s)", sig(lo, 3), sig(hi, 3))
        } else {
            String::new()
        },
        seg.motion.len(),
        if seg.motion.len() == 1 { "" } else { "es" },
        match seg.gaps.len() {
            0 => "no gaps".to_string(),
            1 => "1 gap".to_string(),
            k => format!("{k} gaps"),
        }
    );
    if n > 0 {
        s.push('\n');
        let mut t = Table::new(&[
            ("#", Align::Right),
            ("start [s]", Align::Right),
            ("end [s]", Align::Right),
            ("duration [s]", Align::Right),
            ("records", Align::Right),
            ("mean fx", Align::Right),
            ("mean fy", Align::Right),
            ("mean fz [m/s^2]", Align::Right),
            ("|f| [m/s^2]", Align::Right),
        ]);
        for (i, x) in seg.static_intervals.iter().enumerate() {
            let f = x.mean_f_m_s2;
            t.row(vec![
                (i + 1).to_string(),
                format!("{:.3}", x.start_s),
                format!("{:.3}", x.end_s),
                format!("{:.2}", x.duration_s),
                x.records.to_string(),
                format!("{:.4}", f[0]),
                format!("{:.4}", f[1]),
                format!("{:.4}", f[2]),
                format!("{:.4}", x.norm_f_m_s2),
            ]);
        }
        s += &t.render();
    }
    for g in &seg.gaps {
        let _ = writeln!(
            s,
            "  gap: {} s between t = {} s and t = {} s (before line {} of {file})",
            c(g.length_s),
            c(g.t_before_s),
            c(g.t_after_s),
            g.record + 2
        );
    }
    if let Some(path) = &args.json {
        let json = SegmentJson {
            imu: file.clone(),
            segmentation: &seg,
        };
        let text = serde_json::to_string_pretty(&json)? + "\n";
        std::fs::write(path, text).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
        let _ = writeln!(s, "\nwrote {}", path.display());
    }
    print(&s)
}
