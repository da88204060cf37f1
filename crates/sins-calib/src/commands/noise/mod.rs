//! `sins-calib noise`: the sensors' noise from data at rest (the `noise` library): overlapping
//! Allan deviation of every gyro and accelerometer axis with confidence intervals, the fitted
//! noise terms with their uncertainties, the white levels and bias walks of the
//! maximum-likelihood fit with their profile intervals in `[noise]`'s convention, and a
//! `[noise]` block to paste (docs/noise.md).

pub mod consistency;
pub mod json;
pub mod model;
pub mod slow_terms;
mod tables;
mod thermal;

use tables::*;
use thermal::*;

use crate::commands::noise::json::{Recording, json_of};
use crate::commands::noise::model::{ACCEL, AXES, GYRO, Sensor, SensorNoise, configured};
use crate::render::table::{self, Align, Table};
use crate::{Error, load_config};
use ::calib::motion::detect::{DetectorSettings, RateSource, segment_streamed};
use ::noise::AxisNoise;
use ::noise::consistency::AxisCheck;
use ::noise::fit::{NoiseFit, Term};
use ::noise::floor::SlowTerms;
use ::noise::likelihood::{Level, MlFit};
use calib::config::{NoiseConfig, RunConfig};
use calib::io::ImuKind;
use serde_json::{Value, json};
use sins_model::units::DEG_PER_HOUR;
use std::fmt::Write as _;
use std::ops::Range;
use std::path::PathBuf;

/// Arguments of `noise`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The records read.
    #[command(flatten)]
    pub records: crate::args::RecordsArgs,
    /// A run configuration (file, or `paper` / `paper-reconciled`) whose `[noise]` levels are
    /// compared with the measured ones and drawn over them; its `reading` and `angle_arcsec`
    /// go into the printed `[noise]` block.
    #[arg(long, value_name = "FILE|NAME")]
    pub config: Option<String>,
    /// The whole recording is at rest: use every record (split only at gaps) instead of the
    /// static intervals the detector finds (`segment`'s, with the --rest-* options given).
    #[arg(long)]
    pub all_at_rest: bool,
    /// The detector's options (`--rest-*`, as for `segment` and `calibrate`).
    #[command(flatten, next_help_heading = crate::args::heading::REST_DETECTION)]
    pub detector: crate::args::detector::DetectorArgs,
    /// Also write the results to this JSON file: per sensor the levels of every term per axis
    /// with their sigmas, the fit statistics and the Allan deviation curve with its confidence
    /// interval (docs/noise.md).
    #[arg(long, value_name = "FILE", help_heading = crate::args::heading::OUTPUTS)]
    pub json: Option<PathBuf>,
    /// Also plot the Allan deviations to this PNG file: per axis the measured deviation with its
    /// 68 % confidence interval, the fitted terms and their sum, and with --config the
    /// configured noise model.
    #[arg(long, value_name = "FILE", help_heading = crate::args::heading::OUTPUTS)]
    pub plot: Option<PathBuf>,
}

/// The outputs checked before the work: never onto an input, plots as PNG.
fn check_outputs(args: &Args) -> Result<(), Error> {
    let mut inputs: Vec<&std::path::Path> = vec![args.records.imu.as_path()];
    if let Some(c) = args.config.as_deref() {
        inputs.push(std::path::Path::new(c));
    }
    let mut outputs = crate::output::Outputs::new(&inputs);
    if let Some(p) = &args.json {
        outputs.file(p, "--json")?;
    }
    if let Some(p) = &args.plot {
        outputs.png(p, "--plot")?;
    }
    Ok(())
}

/// The record ranges both fits are taken over: the whole recording split at its gaps, or the
/// detector's static intervals less their edges next to motion ([`settled_rests`]); refused
/// when there is none.
fn intervals_of(
    seg: &::calib::motion::detect::Segmentation,
    whole: bool,
    n: usize,
    settings: &DetectorSettings,
    file: &str,
) -> Result<Vec<Range<usize>>, Error> {
    let intervals: Vec<Range<usize>> = if whole {
        // Every record, split at the gaps (the Allan variance is not defined across one).
        let mut cuts: Vec<usize> = seg.gaps.iter().map(|g| g.record).collect();
        cuts.push(n);
        let mut start = 0;
        cuts.into_iter()
            .map(|c| {
                let r = start..c;
                start = c;
                r
            })
            .filter(|r| r.len() >= 2)
            .collect()
    } else {
        settled_rests(seg, n)
    };
    if intervals.is_empty() {
        return Err(format!(
            "{file}: no static interval of at least {} s found by the detector (std f < {} m/s^2, \
             std w < {} rad/s, |mean w| < {} rad/s over {}-s windows): expected a recording at \
             rest, or one with static intervals; if the whole recording is at rest, say so with \
             --all-at-rest",
            table::compact(settings.min_duration_s),
            table::compact(settings.max_std_f_m_s2),
            table::compact(settings.max_std_w_rad_s),
            table::compact(settings.max_rate_rad_s),
            table::compact(settings.window_s),
        )
        .into());
    }
    Ok(intervals)
}

/// The detector's static intervals as the noise is measured on them: each without one detector
/// window (`window_records`) at an end that records not at rest adjoin (an end at the
/// recording's first or last record, or at a gap, is kept); a rest left with fewer than two
/// records is dropped.
///
/// Why: the detector judges a record by the window centred on it, against thresholds made to
/// find poses (a rate spread of 2.9 deg/s, a mean rate of 5.7 deg/s), far above a sensor's
/// noise, so the first and last window of a rest can still hold the end of the motion before it
/// or the start of the one after. Those records are no noise. The likelihood fit takes every
/// block at its face value: on the Xsens recording one rest that began 0.25 s before its turn
/// had ended (up to 6.9 deg/s, against a noise of 130 deg/h at 1 Hz) put gyro x's white level
/// 20 % up and a walk of 4800 deg/h/sqrt(h) into the fit, whose Allan deviation then lay far
/// above the measured one; the Allan variance, where such a stretch enters a few of its terms,
/// had barely moved (docs/noise.md, "Which records").
fn settled_rests(seg: &::calib::motion::detect::Segmentation, n: usize) -> Vec<Range<usize>> {
    let w = seg.window_records;
    let gap_before = |k: usize| seg.gaps.iter().any(|g| g.record == k);
    seg.static_intervals
        .iter()
        .filter_map(|s| {
            let (first, end) = (s.first_record, s.last_record + 1);
            let start = if first == 0 || gap_before(first) {
                first
            } else {
                first + w
            };
            let stop = if end == n || gap_before(end) {
                end
            } else {
                end.saturating_sub(w)
            };
            (stop >= start + 2).then_some(start..stop)
        })
        .collect()
}

/// Run `noise`.
pub fn run(args: &Args) -> Result<(), Error> {
    check_outputs(args)?;
    let config = args.config.as_deref().map(load_config).transpose()?;
    // The records are read again for every step rather than held (docs/performance.md,
    // "Memory of every command on a long run").
    let mut imu = calib::estimate::FileImu::open(&args.records.imu)?;
    let has_temp = imu.has_temp();
    let file = args.records.imu.display().to_string();
    let mut source = RateSource::new(&mut imu)?;
    let rest = find_rest(args, &mut source, &file)?;
    let fits = fit_levels(&mut source, &rest, has_temp, &file)?;
    let mut out = summary(args, &file, &rest, &fits.sensors);
    out += &tables(&fits, rest.median, &rest.intervals);
    let (base, base_origin) = match &config {
        Some((cfg, origin)) => (cfg.clone(), origin.clone()),
        None => (RunConfig::paper(), String::new()),
    };
    if let Some((cfg, origin)) = &config {
        out += &comparison(cfg, origin, &fits.sensors);
    }
    let block = noise_block(&base.noise, &base_origin, &fits.sensors, &fits.band);
    let _ = writeln!(
        out,
        "\n[noise] block (the largest of the three axes; white levels: the white noise alone, as \
         the sigma of a 1-s average of it):\n"
    );
    out += &block;
    if let Some(path) = &args.plot {
        crate::output::write_with(path, |tmp| {
            crate::plots::allan_deviation::allan_png(
                tmp,
                &file,
                &fits.sensors,
                &fits.band,
                config.as_ref().map(|(c, _)| &c.noise),
            )
        })?;
        let _ = writeln!(out, "\nwrote {}", path.display());
    }
    if let Some(path) = &args.json {
        let recording = Recording {
            file: &file,
            whole: rest.whole,
            intervals: &rest.intervals,
            times: &rest.times,
            records: rest.n,
            median: rest.median,
        };
        let mut json = json_of(&recording, &fits.sensors, &block);
        if let (Some(t), Some(root)) = (&fits.thermal, json.as_object_mut()) {
            root.insert("temperature".into(), thermal_json(t));
        }
        band_json(&mut json, &fits, rest.median);
        let text = calib::io::schema::to_json(calib::io::schema::NOISE, &json)?;
        crate::output::write_file(path, text.as_bytes())?;
        if !crate::output::is_stdout(path) {
            let _ = writeln!(out, "wrote {}", path.display());
        }
    }
    crate::report(&out, args.json.as_deref())
}

/// Where the recording is at rest: its segmentation, the records used and their intervals.
struct AtRest {
    seg: ::calib::motion::detect::Segmentation,
    /// Records in the file and their median interval (s).
    n: usize,
    median: f64,
    /// Whether the whole recording is used (split at gaps only).
    whole: bool,
    /// The intervals used (record ranges) and the time stamps of their first and last records.
    intervals: Vec<Range<usize>>,
    times: Vec<(f64, f64)>,
}

/// The records at rest: the detector's settings checked, the recording checked as `segment`
/// checks it (and with `--all-at-rest` that it is at rest), segmented, and the intervals used.
fn find_rest(args: &Args, source: &mut RateSource<'_>, file: &str) -> Result<AtRest, Error> {
    let n = source.records;
    let settings = args
        .detector
        .settings()
        .map_err(|e| format!("noise: {e}"))?;
    crate::args::detector::check_span_streamed(
        &settings,
        source,
        file,
        &crate::args::detector::option_name,
    )?;
    // The units `segment` checks (time stamps in seconds, specific force in m/s^2, gyro and
    // accelerometer columns in their places): noise levels of misread records are wrong by
    // the factor of the misreading.
    crate::recording_checks::check_plausible_streamed(source, file, settings.window_s)?;
    let seg = segment_streamed(source, &settings).map_err(|e| format!("{file}: {e}"))?;
    crate::recording_checks::check_static_force(&seg, file)?;
    if args.all_at_rest {
        crate::recording_checks::check_at_rest_streamed(
            source,
            file,
            seg.window_records,
            seg.settings.window_s,
        )?;
    }
    let whole = args.all_at_rest
        || (seg.static_intervals.len() == 1
            && seg.static_intervals[0].first_record == 0
            && seg.static_intervals[0].last_record + 1 == n);
    let intervals = intervals_of(&seg, whole, n, &settings, file)?;
    let times = interval_times(source, &intervals)?;
    Ok(AtRest {
        n,
        median: seg.median_interval_s,
        whole,
        intervals,
        times,
        seg,
    })
}

/// The time stamps of the intervals' first and last records (for the JSON file).
fn interval_times(
    source: &mut RateSource<'_>,
    intervals: &[Range<usize>],
) -> Result<Vec<(f64, f64)>, Error> {
    let mut times = vec![(f64::NAN, f64::NAN); intervals.len()];
    let mut at = 0;
    let mut k = 0;
    source.read(&mut |t, _, _| {
        while at < intervals.len() && intervals[at].end <= k {
            at += 1;
        }
        if let Some(r) = intervals.get(at) {
            if k == r.start {
                times[at].0 = t;
            }
            if k + 1 == r.end {
                times[at].1 = t;
            }
        }
        k += 1;
    })?;
    Ok(times)
}

/// The levels of both sensors, and what the temperature explains of them.
struct Fitted {
    /// The regression on the temperature (a recording with a `temp` column that moves).
    thermal: Option<Thermal>,
    /// The thermal coefficients removed before the fits (0: the axis as it is).
    removed: [f64; 6],
    /// The fits of the records as they are, where a thermal part was removed from any axis.
    as_measured: Option<Vec<SensorNoise>>,
    /// The fits reported.
    sensors: Vec<SensorNoise>,
    /// The likelihood model against the measured Allan deviation, and per axis (gyro x .. accel
    /// z) the split of the rests where it leaves the band.
    band: ::noise::consistency::FamilyCheck,
    splits: Vec<Option<::noise::consistency::Split>>,
}

/// Both fits of the six axes from two more readings ([`::noise::stream`]): the levels reported
/// are the exact likelihood of the data, each static interval its own filter, on block means
/// above the sensor's correlation time (docs/noise.md, "The maximum-likelihood fit"); the Allan
/// fit above the same correlation time: below it the sensor's own filter shapes the curve, which
/// no term describes.
fn fit_levels(
    source: &mut RateSource<'_>,
    rest: &AtRest,
    has_temp: bool,
    file: &str,
) -> Result<Fitted, Error> {
    let (intervals, n, median) = (&rest.intervals, rest.n, rest.median);
    let thermal = if has_temp {
        thermal_fit(source, intervals, median)?
    } else {
        None
    };
    // A slow change that follows the temperature is no random walk: where an axis's thermal
    // coefficient stands clear of its sigma, the levels are fitted again with the thermal part
    // removed, and those are the ones reported (docs/temperature.md).
    let removed = thermal
        .as_ref()
        .map(Thermal::significant)
        .unwrap_or_default();
    let as_measured = if removed.iter().any(|c| *c != 0.0) {
        Some(fit_sensors(source, intervals, n, median, None, file)?)
    } else {
        None
    };
    let thermal_part = thermal
        .as_ref()
        .filter(|_| as_measured.is_some())
        .map(|t| (removed, t.interval_means.as_slice()));
    let sensors = fit_sensors(source, intervals, n, median, thermal_part, file)?;
    // The likelihood model against the Allan curve at every averaging time; where it leaves
    // the band, the rests split by length from the same increments (one more reading).
    let band = crate::commands::noise::consistency::check(&sensors);
    let splits =
        crate::commands::noise::consistency::splits(&band, &sensors, intervals, median, |visit| {
            read_increments(source, intervals, median, thermal_part, visit)
        })?;
    Ok(Fitted {
        thermal,
        removed,
        as_measured,
        sensors,
        band,
        splits,
    })
}

/// The first lines of the report: the recording and the records used.
fn summary(args: &Args, file: &str, rest: &AtRest, sensors: &[SensorNoise]) -> String {
    let (seg, median, intervals) = (&rest.seg, rest.median, &rest.intervals);
    let used: usize = intervals.iter().map(|r| r.len()).sum();
    let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
    let c = table::compact;
    let rests = format!(
        "static intervals found by the detector, less a detector window ({} s) at each end \
         next to motion",
        c(seg.settings.window_s)
    );
    let mut out = String::new();
    let _ = writeln!(
        out,
        "sins-calib noise: {file}: {} records, t = {} .. {} s, median interval {} s ({} Hz)",
        rest.n,
        c(seg.t_first_s),
        c(seg.t_last_s),
        c(median),
        table::significant(1.0 / median, 4)
    );
    let _ = writeln!(
        out,
        "  {}: {} interval{}, {used} records ({} s), the longest {} s (longest tau {} s)",
        if rest.whole {
            if args.all_at_rest {
                "the whole recording (--all-at-rest)"
            } else {
                "the whole recording (at rest throughout)"
            }
        } else {
            &rests
        },
        intervals.len(),
        if intervals.len() == 1 { "" } else { "s" },
        table::significant(used as f64 * median, 4),
        table::significant(longest as f64 * median, 4),
        table::significant(
            sensors[0].axes[0]
                .curve
                .points
                .last()
                .map_or(0.0, |p| p.tau_s),
            4
        ),
    );
    out
}

/// Which fit an axis's `[noise]` levels come from: only one that passed its check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Basis {
    /// The maximum-likelihood fit, its whiteness check and its band check passed.
    Likelihood,
    /// The Allan fit, its chi-square and band check passed (the likelihood's failed).
    Allan,
    /// A walk fitted with the floor or the flat excess the curve shows under it
    /// (`noise::floor::walk_beyond_floor`, `noise::floor::floor_under_walk`).
    BesideFloor,
}

/// What one axis gives the `[noise]` block: its white level and its walk (SI), each with the
/// fit it comes from, or why the axis gives none.
struct AxisLevels {
    white: Result<(f64, Basis), String>,
    walk: Result<(f64, Basis), String>,
}

/// The `[noise]` levels of one axis: the maximum-likelihood ones where that model passes both
/// its checks (the whiteness of its innovations and the band of the measured Allan deviation),
/// else the Allan fit's where it passes its own (its walk only where it has the term), else
/// none, with why. A likelihood walk counts only where it is significantly above 0 (the lower
/// end of its interval above 0); a walk the rests are too short to tell is left out
/// ([`::noise::floor::slow_terms`]).
fn axis_levels(axis: &AxisNoise, m: &MlFit, band: &AxisCheck, slow: &SlowTerms) -> AxisLevels {
    let p = calib::check::stats::p_value_text;
    let basis = if m.passes() && band.passes() {
        let walk = if m.walk.lower > 0.0 {
            m.walk.value
        } else {
            0.0
        };
        Ok((m.white.value, walk, Basis::Likelihood))
    } else if axis.fit.passes() {
        let w = axis.fit.term(Term::RandomWalk);
        let walk = if w.included { w.value } else { 0.0 };
        Ok((axis.fit.term(Term::White).value, walk, Basis::Allan))
    } else {
        let ml_why = if !m.passes() {
            m.whiteness
                .map_or("too few blocks to check it".to_string(), |w| {
                    format!("its whiteness check p {}", p(w.p_value))
                })
        } else {
            let w = band.worst();
            w.map_or(String::new(), |w| {
                format!(
                    "its model leaves the Allan band at {} s, x{}",
                    table::significant(w.tau_s, 3),
                    table::significant(w.ratio, 2)
                )
            })
        };
        Err(format!(
            "the likelihood fails ({ml_why}) and so does the Allan fit (chi-square p {})",
            p(axis.fit.p_value)
        ))
    };
    let walk = match &basis {
        Ok(_) if slow.walk_contradicted_at.is_some() => {
            Err("not determined: the curve at longer averaging times lies below it".to_string())
        }
        Ok(_) if !slow.walk => Err(format!(
            "not determined: the longest rest, {} s, is too short to tell a walk",
            table::significant(slow.longest_rest_s, 3)
        )),
        // Beside a floor, the walk fitted with it: the likelihood's model has no floor, and
        // its walk takes the floor's slow power in (`noise::floor::WalkBeyondFloor`).
        Ok((_, k, b)) => match &slow.walk_beyond_floor {
            Some(w) if w.lower > 0.0 => Ok((w.value, Basis::BesideFloor)),
            Some(_) => Ok((0.0, *b)),
            None => Ok((*k, *b)),
        },
        Err(e) => Err(e.clone()),
    };
    AxisLevels {
        white: basis.map(|(n, _, b)| (n, b)),
        walk,
    }
}

/// One `[noise]` field of a sensor: the largest level over the axes that give one (`per`),
/// with a comment naming the fits and the axes left out and why; commented out where no axis
/// gives one (with `guess`, the failed Allan fit's figure, for orientation only where a
/// failed check is why).
fn block_field(key: &str, per: &[Result<(f64, Basis), String>], guess: f64, factor: f64) -> String {
    let sig = |x: f64| {
        if x > 0.0 {
            table::significant(x, 3)
        } else {
            "0".into()
        }
    };
    let names = |b: Basis| -> Vec<&str> {
        per.iter()
            .enumerate()
            .filter(|(_, p)| p.as_ref().is_ok_and(|x| x.1 == b))
            .map(|(i, _)| AXES[i])
            .collect()
    };
    // The axes left out, those with the same reason together.
    let mut why: Vec<(&str, Vec<&str>)> = Vec::new();
    for (i, p) in per.iter().enumerate() {
        if let Err(e) = p {
            match why.iter_mut().find(|w| w.0 == e.as_str()) {
                Some(w) => w.1.push(AXES[i]),
                None => why.push((e.as_str(), vec![AXES[i]])),
            }
        }
    }
    let out: Vec<String> = why
        .iter()
        .map(|(e, axes)| format!("{} ({e})", axes.join(", ")))
        .collect();
    if per.iter().all(Result::is_err) {
        let undetermined = per
            .iter()
            .all(|p| p.as_ref().is_err_and(|e| e.starts_with("not determined")));
        if undetermined {
            return format!("# {key} not set: {}\n", out.join("; "));
        }
        return format!(
            "# {key} = {}  # not set: no fit passes its check on any axis (the likelihood's \
             whiteness and band, the Allan fit's chi-square and band); the figure is the failed \
             Allan fit's, for orientation only: set yours\n",
            sig(guess * factor)
        );
    }
    let value = per.iter().flatten().map(|x| x.0).fold(0.0, f64::max) * factor;
    let mut from = Vec::new();
    for (b, name) in [
        (Basis::Likelihood, "maximum likelihood"),
        (Basis::Allan, "Allan fit"),
        (Basis::BesideFloor, "the curve's floor and walk"),
    ] {
        let n = names(b);
        if !n.is_empty() {
            from.push(format!("{name} on {}", n.join(", ")));
        }
    }
    let mut comment = format!("measured ({})", from.join("; "));
    if !out.is_empty() {
        let _ = write!(comment, "; left out: {}", out.join("; "));
    }
    if value == 0.0 {
        // A 0 from the axes kept says nothing of an axis whose rests could not tell its walk.
        if why.iter().any(|w| w.0.starts_with("not determined")) {
            return format!(
                "# {key} not set: {comment}; on the others none significantly above 0\n"
            );
        }
        comment += "; none significantly above 0";
    }
    format!("{key} = {}  # {comment}\n", sig(value))
}

fn comparison(cfg: &RunConfig, origin: &str, sensors: &[SensorNoise]) -> String {
    let mut s = format!("\nagainst [noise] of {origin} (measured / configured, each axis)\n");
    for ((sensor, sn), gyro) in [&GYRO, &ACCEL].into_iter().zip(sensors).zip([true, false]) {
        for (j, (_, v)) in [1usize, 3].into_iter().zip(configured(&cfg.noise, gyro)) {
            let ratios: Vec<String> = sn
                .ml
                .iter()
                .map(|m| {
                    let e = if j == 1 { m.white } else { m.walk };
                    if v > 0.0 {
                        table::significant(e.value / v, 3)
                    } else {
                        "-".into()
                    }
                })
                .collect();
            let _ = writeln!(
                s,
                "  {} {}: configured {}, measured/configured {}",
                sensor.name,
                sensor.labels[j],
                table::significant(v * sensor.factors[j], 3),
                ratios.join(", ")
            );
        }
    }
    s
}

/// The `[noise]` block: the measured white levels and walks (largest axis), the reading and
/// the angle-sensor noise from the configuration (or the paper's, said so).
fn noise_block(
    base: &NoiseConfig,
    origin: &str,
    sensors: &[SensorNoise],
    band: &::noise::consistency::FamilyCheck,
) -> String {
    let from = if origin.is_empty() {
        "not measured here: the paper's value, set yours".to_string()
    } else {
        format!("from {origin}, not measured here")
    };
    let reading = match base.reading {
        calib::config::NoiseReading::Average => "average",
        calib::config::NoiseReading::Sample => "sample",
    };
    let levels: Vec<Vec<AxisLevels>> = sensors
        .iter()
        .enumerate()
        .map(|(i, sn)| {
            let slow = crate::commands::noise::slow_terms::slow_terms(sn);
            (0..sn.axes.len())
                .map(|a| axis_levels(&sn.axes[a], &sn.ml[a], &band.axes[3 * i + a], &slow[a]))
                .collect()
        })
        .collect();
    let field = |i: usize, key: &str, walk: bool, factor: f64| {
        let per: Vec<_> = levels[i]
            .iter()
            .map(|l| {
                if walk {
                    l.walk.clone()
                } else {
                    l.white.clone()
                }
            })
            .collect();
        let term = if walk { Term::RandomWalk } else { Term::White };
        let guess = sensors[i]
            .axes
            .iter()
            .map(|a| a.fit.term(term).value)
            .fold(0.0, f64::max);
        block_field(key, &per, guess, factor)
    };
    let mut s = String::new();
    let _ = writeln!(s, "[noise]");
    let _ = writeln!(s, "reading = \"{reading}\"  # {from}");
    s += &field(0, "gyro_deg_h", false, 1.0 / DEG_PER_HOUR);
    s += &field(1, "accel_m_s2", false, 1.0);
    let _ = writeln!(
        s,
        "angle_arcsec = {}  # {from}",
        table::compact(base.angle_arcsec)
    );
    s += &field(0, "gyro_bias_walk_deg_h_sqrt_h", true, 60.0 / DEG_PER_HOUR);
    s += &field(1, "accel_bias_walk_m_s2_sqrt_s", true, 1.0);
    s
}

/// The gyro bias random walk a `sins-calib noise --json` file identified (rad/s/sqrt(s)): the
/// largest axis's value and the ends of its 68 % profile interval (`None`: an unbounded
/// upper end), for `diagnose --noise`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct IdentifiedWalk {
    pub value: f64,
    pub lower: f64,
    pub upper: Option<f64>,
}

impl IdentifiedWalk {
    /// The intensities the walk candidate is tried at: the interval's lower end, the value and
    /// the upper end, those above 0 (a walk identified as 0: half the upper end and the upper
    /// end); empty when the file bounds no walk above 0.
    pub(crate) fn grid(&self) -> Vec<f64> {
        let mut g: Vec<f64> = if self.value > 0.0 {
            [Some(self.lower), Some(self.value), self.upper]
                .into_iter()
                .flatten()
                .filter(|q| *q > 0.0)
                .collect()
        } else {
            self.upper.map_or(Vec::new(), |u| vec![0.5 * u, u])
        };
        g.retain(|q| q.is_finite() && *q > 0.0);
        g.dedup();
        g
    }
}

/// The JSON of `sins-calib noise --json` at `path` (read within the size bound, its schema
/// checked), with the file's name for messages.
pub(crate) fn read_noise_json(path: &std::path::Path) -> Result<(String, Value), Error> {
    let file = path.display().to_string();
    let text = sins_model::text::read_text_bounded(
        path,
        sins_model::text::RESULT_MAX_BYTES,
        "noise result JSON",
    )
    .map_err(|e| format!("{file}: cannot read: {e}"))?;
    let root: Value = serde_json::from_str(&text).map_err(|e| {
        format!(
            "{file}: line {}: {e}: expected the JSON that `sins-calib noise --json` writes",
            e.line()
        )
    })?;
    calib::io::schema::check(
        &file,
        root.get("schema"),
        &[calib::io::schema::NOISE],
        "the JSON that `sins-calib noise --json` writes",
    )?;
    Ok((file, root))
}

/// Read the identified gyro bias walk from the JSON of `sins-calib noise --json`: the keys
/// `gyro.bias_walk_deg_h_sqrt_h`, `..._lower` and `..._upper` (three axes each). The axis with
/// the largest value is taken, as the `[noise]` block takes it.
pub(crate) fn read_identified_walk(path: &std::path::Path) -> Result<IdentifiedWalk, Error> {
    let (file, root) = read_noise_json(path)?;
    let key = "bias_walk_deg_h_sqrt_h";
    let axes = |suffix: &str| -> Result<Vec<Option<f64>>, Error> {
        let k = format!("{key}{suffix}");
        let v = root
            .get("gyro")
            .and_then(|g| g.get(&k))
            .and_then(Value::as_array)
            .filter(|a| a.len() == 3)
            .ok_or_else(|| {
                format!(
                    "{file}: expected `gyro.{k}`, three numbers (deg/h/sqrt(h)), as `sins-calib \
                     noise --json` writes them"
                )
            })?;
        v.iter()
            .map(|x| match x {
                Value::Null => Ok(None),
                x => x
                    .as_f64()
                    .filter(|x| x.is_finite() && (0.0..=calib::config::SIGMA_MAX).contains(x))
                    .map(Some)
                    .ok_or_else(|| {
                        format!(
                            "{file}: `gyro.{k}`: {x} is not a walk: expected a number in 0 .. \
                             {:e} deg/h/sqrt(h) (as the configuration's [noise] walks)",
                            calib::config::SIGMA_MAX
                        )
                        .into()
                    }),
            })
            .collect()
    };
    let (value, lower, upper) = (axes("")?, axes("_lower")?, axes("_upper")?);
    let axis = (0..3)
        .max_by(|&a, &b| value[a].unwrap_or(0.0).total_cmp(&value[b].unwrap_or(0.0)))
        .expect("three axes");
    let unit = DEG_PER_HOUR / 60.0;
    let value = value[axis].ok_or_else(|| format!("{file}: `gyro.{key}` has no value"))?;
    Ok(IdentifiedWalk {
        value: value * unit,
        lower: lower[axis].unwrap_or(0.0) * unit,
        upper: upper[axis].map(|u| u * unit),
    })
}

/// Both fits of the six axes ([`::noise::stream::fit_axes_streamed`]), from the records as they
/// are or with a thermal part removed: per axis a coefficient (rate per K; 0 keeps the axis as
/// it is) times the record's temperature less its interval's mean.
fn fit_sensors(
    source: &mut RateSource<'_>,
    intervals: &[Range<usize>],
    n: usize,
    median: f64,
    thermal: Option<([f64; 6], &[f64])>,
    file: &str,
) -> Result<Vec<SensorNoise>, Error> {
    let fits = ::noise::stream::fit_axes_streamed(6, n, median, intervals, |visit| {
        read_increments(source, intervals, median, thermal, visit)
    })?;
    let mut fits = fits.into_iter();
    let mut sensors = Vec::new();
    for s in [&GYRO, &ACCEL] {
        let mut axes = Vec::new();
        let mut mls = Vec::new();
        for axis_name in AXES.iter() {
            let f = fits.next().expect("six axes");
            let ml =
                f.ml.map_err(|e| format!("{file}: {} {axis_name}: {e}", s.name))?;
            let axis = f
                .allan
                .map_err(|e| format!("{file}: {} {axis_name}: {e}", s.name))?;
            axes.push(axis);
            mls.push(ml);
        }
        sensors.push(SensorNoise { axes, ml: mls });
    }
    Ok(sensors)
}

/// Visit the increments of every record as `(record index, six values)`: as they are, or rate
/// times the median interval, with the thermal part removed where `thermal` gives a coefficient.
///
/// The records are taken as evenly spaced at the median interval (the Allan variance needs a
/// fixed tau0; gaps end the intervals): a rate times its record's jittered interval would add
/// the jitter times the rate, which for an accelerometer axis along g (a 0.3-ms jitter, 3 mm/s
/// per record) is far above its noise, while jittered time stamps of a sensor sampled on its
/// own clock say nothing of its samples.
fn read_increments(
    source: &mut RateSource<'_>,
    intervals: &[Range<usize>],
    median: f64,
    thermal: Option<([f64; 6], &[f64])>,
    visit: &mut dyn FnMut(usize, &[f64]),
) -> Result<(), String> {
    let kind = source.kind();
    let increment = move |v: f64| match kind {
        ImuKind::Increments => v,
        ImuKind::Rates => v * median,
    };
    let (mut k, mut at) = (0usize, 0usize);
    source.records_of(&mut |r, _| {
        while at < intervals.len() && intervals[at].end <= k {
            at += 1;
        }
        let mut v = [
            increment(r.gyro[0]),
            increment(r.gyro[1]),
            increment(r.gyro[2]),
            increment(r.accel[0]),
            increment(r.accel[1]),
            increment(r.accel[2]),
        ];
        if let (Some((c, means)), Some(temp)) = (thermal, r.temp)
            && let Some(mean) = means.get(at)
        {
            for (x, b) in v.iter_mut().zip(c) {
                *x -= b * (temp - mean) * median;
            }
        }
        visit(k, &v);
        k += 1;
    })
}

/// The check of the likelihood model against the Allan curve in the JSON: the family's level
/// at the top (`ml_band`) and each sensor's axes (`gyro.ml_band`, `accel.ml_band`).
fn band_json(json: &mut Value, fits: &Fitted, median: f64) {
    let Some(root) = json.as_object_mut() else {
        return;
    };
    root.insert(
        "ml_band".into(),
        crate::commands::noise::consistency::family_json(&fits.band),
    );
    for (first, s) in [(0, &GYRO), (3, &ACCEL)] {
        let v = crate::commands::noise::consistency::sensor_json(
            s,
            &fits.band,
            &fits.splits,
            first,
            median,
        );
        if let Some(o) = root.get_mut(s.key).and_then(Value::as_object_mut) {
            o.insert("ml_band".into(), v);
        }
    }
}
