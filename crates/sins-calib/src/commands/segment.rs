//! `sins-calib segment`: an `imu.csv` split into static intervals and motion by the `import`
//! crate's static detector.

use crate::recording_checks;
use crate::render::table::{self, Align, Table};
use crate::{Error, output};
use ::calib::motion::detect::{DetectorSettings, RateSource, Segmentation, segment_streamed};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `segment`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The records read.
    #[command(flatten)]
    pub records: crate::args::RecordsArgs,
    /// The detector's options (`--rest-*`, as for `calibrate`).
    #[command(flatten, next_help_heading = crate::args::heading::REST_DETECTION)]
    pub detector: crate::args::detector::DetectorArgs,
    /// An interval between records longer than this many median intervals is a gap; static
    /// intervals end at gaps.
    #[arg(long, value_name = "FACTOR", default_value_t = DetectorSettings::default().gap_factor)]
    pub gap_factor: f64,
    /// Also write the segmentation to this JSON file: the settings, every static interval (start,
    /// end, duration, records, mean specific force and |f|, mean rate, deviations), the motion
    /// between them and any gaps (docs/formats.md "Segment file").
    #[arg(long, value_name = "FILE", help_heading = crate::args::heading::OUTPUTS)]
    pub json: Option<PathBuf>,
}

/// The JSON file: the segmentation with the file it is of.
#[derive(Serialize)]
struct SegmentJson<'a> {
    imu: String,
    #[serde(flatten)]
    segmentation: &'a Segmentation,
    /// With a `temp` column: each static interval's mean temperature (deg C), in the order of
    /// `static_intervals`.
    #[serde(skip_serializing_if = "Option::is_none")]
    interval_temp_c: Option<Vec<f64>>,
}

/// A setting to three significant digits, without trailing zeros (1, 0.1, 0.563).
fn short(x: f64) -> String {
    table::compact(table::significant(x, 3).parse().unwrap_or(x))
}

/// How the window and the minimum duration were chosen, as a line of the printout.
fn chosen(seg: &Segmentation) -> String {
    use ::calib::motion::detect::Source;
    let a = &seg.adaptation;
    let sig = table::significant;
    let why = |source: Source, what: &str, fraction: &str, lower: &str| match source {
        Source::Given => format!("{what} given"),
        Source::Default => match a.typical_rest_s {
            Some(_) => format!("{what} the default (the rests are long enough for it)"),
            None => format!("{what} the default (no quiet stretch to adapt to)"),
        },
        Source::Rests => format!("{what} {fraction} of the typical rest"),
        Source::LowerBound => format!("{what} at its lower bound ({lower})"),
    };
    let mut line = format!(
        "    chosen: {}; {}",
        why(a.window, "window", "a quarter", "the first pass's window"),
        why(
            a.min_duration,
            "minimum",
            "half",
            &format!(
                "the window, or {} s for a usable mean",
                sig(a.noise_min_duration_s, 2)
            )
        )
    );
    if seg.settings.adapt_window || seg.settings.adapt_min_duration {
        match a.typical_rest_s {
            Some(d) => {
                let _ = write!(
                    line,
                    "; typical rest {} s (lower quartile of {} quiet stretch{} at a {}-s window)",
                    sig(d, 3),
                    a.quiet_stretches,
                    if a.quiet_stretches == 1 { "" } else { "es" },
                    sig(a.first_pass_window_s, 2)
                );
            }
            None => {
                let _ = write!(
                    line,
                    "; no quiet stretch at a {}-s window",
                    sig(a.first_pass_window_s, 2)
                );
            }
        }
    }
    line
}

/// `segment`'s command line resolved: the detector's settings checked and the output path.
struct Request {
    /// The detector's settings.
    settings: DetectorSettings,
    /// The IMU file.
    imu: PathBuf,
    /// `--json`, checked.
    json: Option<PathBuf>,
}

/// Resolve the command line: the settings checked (messages name the option), the output
/// checked before any work.
fn resolve(args: &Args) -> Result<Request, Error> {
    let base = DetectorSettings {
        gap_factor: args.gap_factor,
        ..DetectorSettings::default()
    };
    let settings = args
        .detector
        .settings_over(base)
        .map_err(|e| format!("segment: {e}"))?;
    if let Some(path) = &args.json {
        output::Outputs::new(&[&args.records.imu]).file(path, "--json")?;
    }
    Ok(Request {
        settings,
        imu: args.records.imu.clone(),
        json: args.json.clone(),
    })
}

/// Run `segment`.
pub fn run(args: &Args) -> Result<(), Error> {
    let req = resolve(args)?;
    let settings = &req.settings;
    // The records are read again for every step rather than held (docs/performance.md,
    // "Memory of every command on a long run").
    let mut imu = calib::estimate::FileImu::open(&req.imu)?;
    let has_temp = imu.has_temp();
    let file = req.imu.display().to_string();
    let mut source = RateSource::new(&mut imu)?;
    recording_checks::check_plausible_streamed(&mut source, &file, settings.window_s)?;
    crate::args::detector::check_span_streamed(
        settings,
        &mut source,
        &file,
        &crate::args::detector::option_name,
    )?;
    let seg = segment_streamed(&mut source, settings).map_err(|e| format!("{file}: {e}"))?;
    recording_checks::check_static_force(&seg, &file)?;
    // The records' temperature, where they have one: each static interval's mean (a thermal
    // drift between rests shows in their biases, docs/temperature.md).
    let interval_temp_c = if has_temp {
        interval_temperatures(&mut source, &seg)?
    } else {
        None
    };
    let mut s = summary(&seg, &file);
    s += &intervals_table(&seg, interval_temp_c.as_deref());
    s += &missed_and_gaps(&seg, &file);
    if let Some(path) = &req.json {
        let json = SegmentJson {
            imu: file.clone(),
            segmentation: &seg,
            interval_temp_c,
        };
        let text = calib::io::schema::to_json(calib::io::schema::SEGMENTATION, &json)?;
        output::write_file(path, text.as_bytes())?;
        if !output::is_stdout(path) {
            let _ = writeln!(s, "\nwrote {}", path.display());
        }
    }
    crate::report(&s, req.json.as_deref())
}

/// The printout's head: the records, the detector's settings as used, the intervals in all.
fn summary(seg: &Segmentation, file: &str) -> String {
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
    let used = &seg.settings;
    let _ = writeln!(
        s,
        "  detector: window {} s ({} records), std f < {} m/s^2, std w < {} rad/s, |mean w| < {} \
         rad/s, at least {} s",
        short(used.window_s),
        seg.window_records,
        short(seg.threshold_std_f_m_s2),
        short(seg.threshold_std_w_rad_s),
        c(used.max_rate_rad_s),
        short(used.min_duration_s)
    );
    let _ = writeln!(s, "{}", chosen(seg));
    let raised: Vec<String> = [
        ("std f", seg.threshold_std_f_m_s2, used.max_std_f_m_s2),
        ("std w", seg.threshold_std_w_rad_s, used.max_std_w_rad_s),
    ]
    .iter()
    .filter(|(_, t, given)| t > given)
    .map(|(what, _, given)| format!("{what} (from {})", c(*given)))
    .collect();
    if !raised.is_empty() {
        let _ = writeln!(
            s,
            "    thresholds raised to {} x the noise floor: {}",
            c(used.noise_factor),
            raised.join(", ")
        );
    }
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
    s
}

/// The static intervals as a table (with their mean temperatures where the records have one).
fn intervals_table(seg: &Segmentation, interval_temp_c: Option<&[f64]>) -> String {
    if seg.static_intervals.is_empty() {
        return String::new();
    }
    let mut columns = vec![
        ("#", Align::Right),
        ("start [s]", Align::Right),
        ("end [s]", Align::Right),
        ("duration [s]", Align::Right),
        ("records", Align::Right),
        ("mean fx", Align::Right),
        ("mean fy", Align::Right),
        ("mean fz [m/s^2]", Align::Right),
        ("|f| [m/s^2]", Align::Right),
    ];
    if interval_temp_c.is_some() {
        columns.push(("temp [deg C]", Align::Right));
    }
    let mut t = Table::new(&columns);
    for (i, x) in seg.static_intervals.iter().enumerate() {
        let f = x.mean_f_m_s2;
        let mut row = vec![
            (i + 1).to_string(),
            format!("{:.3}", x.start_s),
            format!("{:.3}", x.end_s),
            format!("{:.2}", x.duration_s),
            x.records.to_string(),
            format!("{:.4}", f[0]),
            format!("{:.4}", f[1]),
            format!("{:.4}", f[2]),
            format!("{:.4}", x.norm_f_m_s2),
        ];
        if let Some(temps) = interval_temp_c {
            row.push(format!("{:.2}", temps[i]));
        }
        t.row(row);
    }
    format!("\n{}", t.render())
}

/// The rests the detector may have missed, and the gaps of the records.
fn missed_and_gaps(seg: &Segmentation, file: &str) -> String {
    let mut s = String::new();
    if let Some(lines) = seg.missed_report(crate::args::detector::option_name) {
        s.push('\n');
        for line in lines {
            let _ = writeln!(s, "  {line}");
        }
    }
    for g in &seg.gaps {
        let _ = writeln!(
            s,
            "  gap: {} s between t = {} s and t = {} s (before line {} of {file})",
            table::compact(g.length_s),
            table::compact(g.t_before_s),
            table::compact(g.t_after_s),
            g.record + 2
        );
    }
    s
}

/// Each static interval's mean temperature (deg C), from one more reading of the records;
/// `None` when no record of an interval has one.
fn interval_temperatures(
    source: &mut RateSource,
    seg: &Segmentation,
) -> Result<Option<Vec<f64>>, Error> {
    let intervals = &seg.static_intervals;
    let mut sums = vec![(0.0, 0usize); intervals.len()];
    let (mut k, mut at) = (0usize, 0usize);
    source.records_of(&mut |r, _| {
        while at < intervals.len() && intervals[at].last_record < k {
            at += 1;
        }
        if let (Some(x), Some(temp)) = (intervals.get(at), r.temp)
            && x.first_record <= k
        {
            sums[at].0 += temp;
            sums[at].1 += 1;
        }
        k += 1;
    })?;
    Ok(sums
        .iter()
        .any(|(_, n)| *n > 0)
        .then(|| sums.iter().map(|(t, n)| t / *n as f64).collect()))
}
