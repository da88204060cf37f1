//! The report a laboratory files with a calibration (`calibrate --report DIR`, `diagnose
//! --report DIR`): `DIR/report.md` with PNG plots beside it, in this order: identification
//! (input files with their SHA-256, the configuration with its text, tool version and commit,
//! date, command line), the verdict with its criteria and failing tests, the parameters in the
//! paper's units with 1 sigma, the correlation matrix, the residuals per measurement in
//! physical units, the NIS per segment with the segments' names, and for `diagnose` the
//! model-extension table. The figures come from `calib::report::lab`; this module prints and
//! draws them. The directory is written whole ([`crate::output::DirOutput`]): no plot of an
//! earlier run survives.

pub mod correlation_notes;
pub mod diagnose_section;
pub mod html;

use crate::Error;
use crate::free_motion::{FreeMotionFigures, NoiseFigures};
use crate::output::DirOutput;
use crate::provenance::identification::{Identification, NAMES};
use crate::render::calibrate_figures::Verdict;
use crate::render::table;
use calib::check::diagnostics::{Diagnostics, kind_serde};
use calib::check::stats::p_value_text;
use calib::estimate::Estimate;
use calib::estimate::verdict::MeanNis;
use calib::estimate::verdict::VerdictTest;
use calib::model::MeasurementKind;
use calib::model::correction::CorrectionBlock;
use calib::report::lab::{self, ParameterRow, SegmentRow};
use std::fmt::Write as _;
use std::path::Path;

/// Failing tests listed in the verdict's table; the rest are counted (all are in the JSON).
const FAILING_TESTS_SHOWN: usize = 40;

/// One fit as the report draws it.
pub struct FitView<'a> {
    /// The estimate (innovations, segments, temperatures).
    pub est: &'a Estimate,
    /// Its diagnostics.
    pub diagnostics: &'a Diagnostics,
}

/// Everything a report shows, each figure computed by the command before (the laboratory
/// report renders; `crate::render::calibrate_figures`, `crate::render::diagnose_figures`).
pub struct Report<'a> {
    /// Heading, e.g. "Calibration report".
    pub title: &'static str,
    /// Inputs, configuration, tool, date, command line.
    pub id: &'a Identification,
    /// The verdict.
    pub verdict: &'a Verdict,
    /// The mean NIS of each measurement against its band.
    pub mean_nis: &'a [MeanNis],
    /// A hand-turned recording: its noise, held-out rests and known turns.
    pub hand_turned: Option<&'a FreeMotionFigures>,
    /// The parameters in their report units.
    pub parameters: &'a [ParameterRow],
    /// Parameters the data leave at their prior, with their posterior over prior sigma.
    pub unobserved: &'a [(String, f64)],
    /// Against a truth: the printout's lines on it (NEES, largest error).
    pub truth: Option<String>,
    /// The posterior correlation (names, matrix) and its strongest pairs.
    pub correlation: &'a (Vec<String>, Vec<Vec<f64>>),
    /// See `correlation`.
    pub strongest: &'a [(String, String, f64)],
    /// The NIS of every segment of every measurement.
    pub segments: &'a [SegmentRow],
    /// The reported fit (for `diagnose` the final model), for the plots.
    pub fit: FitView<'a>,
    /// `diagnose` with accepted terms: the paper's model, drawn beside the final one.
    pub base: Option<FitView<'a>>,
    /// `diagnose`: the model-extension section (Markdown).
    pub extension: Option<String>,
    /// What the reported model buys in navigation: its section, with the plot of rho(t).
    pub navigation: Option<&'a crate::navigation::Navigation>,
    /// The reported model inverted (the result file's `correction` block): what `apply`
    /// applies.
    pub correction: Option<&'a CorrectionBlock>,
}

/// Write the report into `dir` (checked before the work with [`crate::output::check_dir`] and
/// [`NAMES`]), replacing an earlier report whole. Returns the number of plots.
pub fn write(dir: &Path, report: &Report<'_>) -> Result<usize, Error> {
    let out = DirOutput::begin(dir, &NAMES)?;
    let tmp = out.tmp_dir();
    let mut md = format!("# {}\n\n", report.title);
    md += &identification_md(report.id, dir);
    md += &verdict_md(report);
    md += &parameters_md(report);
    md += &correction_md(report.correction);
    let mut plots = 0;
    md += &correlation_md(tmp, report, &mut plots)?;
    md += &residuals_md(tmp, report, &mut plots)?;
    md += &segments_md(tmp, report, &mut plots)?;
    if let Some(ext) = &report.extension {
        md += ext;
    }
    if let Some(nav) = report.navigation {
        md += &nav.report_md(tmp, &mut plots)?;
    }
    md += &further_plots_md(tmp, report, &mut plots)?;
    let path = out.path("report.md");
    std::fs::write(&path, &md).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    // The same report as one self-contained page, its plots embedded.
    let html = crate::render::lab_report::html::html_of(&md, report.title, tmp)?;
    let path = out.path("report.html");
    std::fs::write(&path, html).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    out.commit()?;
    Ok(plots)
}

/// `path` relative to the report directory `dir` (`../imu.csv` for a report in `run/report`),
/// so that the report names its inputs wherever the run's directory is moved; the absolute
/// forms of both are compared, with links resolved where the files exist.
pub fn relative_to_report(dir: &Path, path: &Path) -> String {
    let resolved = |p: &Path| -> std::path::PathBuf {
        if let Ok(c) = p.canonicalize() {
            return c;
        }
        let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
        match (abs.parent(), abs.file_name()) {
            (Some(parent), Some(name)) => parent
                .canonicalize()
                .unwrap_or_else(|_| parent.to_path_buf())
                .join(name),
            _ => abs,
        }
    };
    let (d, f) = (resolved(dir), resolved(path));
    let (dc, fc): (Vec<_>, Vec<_>) = (d.components().collect(), f.components().collect());
    let common = dc.iter().zip(&fc).take_while(|(a, b)| a == b).count();
    let mut rel = std::path::PathBuf::new();
    for _ in common..dc.len() {
        rel.push("..");
    }
    for c in &fc[common..] {
        rel.push(c);
    }
    rel.display().to_string()
}

fn identification_md(id: &Identification, dir: &Path) -> String {
    let mut s = String::from("## 1. Identification\n\n");
    let _ = writeln!(
        s,
        "| | |\n|---|---|\n| unit | {} |\n| tool | sins-calib {} (git commit {}) |\n| date | {} \
         |\n| command | `{}` |\n",
        id.unit.describe().replace('|', "\\|"),
        env!("CARGO_PKG_VERSION"),
        env!("SINS_CALIB_GIT_COMMIT"),
        id.date_utc,
        id.command_line.replace('|', "\\|").replace('`', "'")
    );
    for a in &id.assumptions {
        let _ = writeln!(s, "**Assumed:** {a}\n");
    }
    let _ = writeln!(
        s,
        "Input files (paths relative to this report's directory):\n\n| role | file | bytes | \
         SHA-256 |\n|---|---|---:|---|"
    );
    for f in &id.inputs {
        let _ = writeln!(
            s,
            "| {} | `{}` | {} | `{}` |",
            f.role,
            relative_to_report(dir, &f.path).replace('|', "\\|"),
            f.bytes,
            f.sha256
        );
    }
    let _ = writeln!(
        s,
        "\nConfiguration `{}`, SHA-256 `{}`:\n\n```toml\n{}{}```\n",
        id.config_shown,
        id.config_sha256,
        id.config_text,
        if id.config_text.ends_with('\n') {
            ""
        } else {
            "\n"
        }
    );
    s
}

fn verdict_md(report: &Report<'_>) -> String {
    let v = report.verdict;
    let mut s = String::from("## 2. Verdict\n\n");
    let headline = if !v.fits() {
        "**THE MODEL DOES NOT FIT THESE DATA**"
    } else if !v.tested {
        "**The model was not tested**"
    } else if !v.tests.is_empty() {
        "**Nothing contradicts the model**"
    } else {
        "**The model fits these data**"
    };
    let _ = writeln!(
        s,
        "{headline} (exit status {}){} {}\n",
        v.exit_status(),
        if v.fits() {
            "."
        } else {
            ": the estimates below are not to be trusted."
        },
        v.rule
    );
    let _ = writeln!(s, "The verdict rests on {}.\n", v.basis);
    if !v.fits() {
        for r in &v.reasons {
            let _ = writeln!(s, "- {r}");
        }
        s.push('\n');
    }
    if !v.findings.is_empty() {
        let _ = writeln!(s, "Findings (they inform, they do not decide):\n");
        for f in &v.findings {
            let _ = writeln!(s, "- {f}");
        }
        s.push('\n');
    }
    if let Some(f) = report.hand_turned {
        s += &noise_md(f);
        s += &held_out_md(f, &v.tests);
        s += &turns_md(f);
    }
    s += &mean_nis_md(report.mean_nis);
    s += &failing_tests_md(report.fit.diagnostics);
    s
}

/// Where the noise came from: the level the innovations are judged against (a hand-turned
/// recording).
fn noise_md(f: &FreeMotionFigures) -> String {
    let mut s = String::from("Noise: ");
    match f.noise {
        NoiseFigures::Configured => {
            let _ = write!(
                s,
                "configured, gyro {} deg/h and specific force {} m/s^2 (1-s means)",
                table::significant(f.noise_gyro_deg_h, 3),
                table::significant(f.noise_accel_m_s2, 3)
            );
        }
        NoiseFigures::Measured(m) => {
            let _ = write!(
                s,
                "measured in the rests (1-s means, {} degrees of freedom), gyro {} deg/h and \
                 specific force {} m/s^2; the specific force's level scaled by {} to {} m/s^2, \
                 the scatter of the fit's innovations, whose variance is {} times the rests' own \
                 noise (p = {:.2e}: {}); the motion noise measured from {} motions in {} fit{}",
                m.dof,
                table::significant(m.gyro_deg_h, 3),
                table::significant(m.accel_m_s2, 3),
                table::significant(m.accel_factor, 3),
                table::significant(f.noise_accel_m_s2, 3),
                table::significant(m.scatter_ratio, 3),
                m.scatter_p_value,
                if m.scatter_significant {
                    "significantly more than the rests' noise, a mismatch the held-out rests \
                     weigh"
                } else {
                    "consistent with it"
                },
                m.motion_windows,
                m.fits,
                if m.fits == 1 { "" } else { "s" }
            );
        }
    }
    let _ = write!(
        s,
        "; {} deg of attitude noise per motion",
        table::significant(f.motion_attitude_noise_deg, 3)
    );
    if f.rest_error_m_s2 > 0.0 {
        let _ = write!(
            s,
            "; {} m/s^2 of specific-force error shared by the windows of each rest{}",
            table::significant(f.rest_error_m_s2, 3),
            match f.rest_error_unasked {
                Some(e) => format!(
                    " (the rests' excess, weighed unasked: p = {:.2e} over {:.1} degrees of \
                     freedom)",
                    e.p_value, e.dof
                ),
                None => String::new(),
            }
        );
    }
    let _ = writeln!(s, ".\n");
    s
}

/// The held-out tests with their figures, and the held-out rests before and after
/// calibration.
fn held_out_md(f: &FreeMotionFigures, tests: &[VerdictTest]) -> String {
    let mut s = String::new();
    if !tests.is_empty() {
        let _ = writeln!(
            s,
            "| test | statistic | p | decides | result |\n|---|---:|---:|---|---|"
        );
        for t in tests {
            let _ = writeln!(
                s,
                "| {} | {:.3} | {} | {} | {} |",
                t.name,
                t.statistic,
                p_value_text(t.p_value),
                if t.decides { "yes" } else { "no (informs)" },
                if t.fails { "**fails**" } else { "passes" }
            );
        }
        s.push('\n');
    }
    let Some(h) = &f.validation else {
        let _ = writeln!(
            s,
            "No rest was held out (`--holdout K` predicts every K-th rest from the others).\n"
        );
        return s;
    };
    let _ = writeln!(
        s,
        "Held-out rests: {} (every {}-th), {} pairs of consecutive ones.\n\n| figure | before \
         calibration | after |\n|---|---:|---:|\n| static \\|f\\| - g RMS [m/s^2] | {:.5} | \
         {:.5} |\n| rotation (gravity direction) RMS [deg] | {:.3} | {:.3} |\n",
        h.intervals,
        f.holdout.unwrap_or(0),
        h.rotation_pairs,
        h.static_rms_m_s2.0,
        h.static_rms_m_s2.1,
        h.rotation_rms_deg.0,
        h.rotation_rms_deg.1,
    );
    let _ = writeln!(
        s,
        "After calibration, against the fitted rests: static \\|f\\| - g RMS {:.5} m/s^2 over \
         {} fitted rests; gravity direction over single motions {:.3} deg into or out of \
         held-out rests ({}) and {:.3} deg between fitted ones ({}){}.\n",
        h.fitted_static_rms_m_s2,
        h.fitted_intervals,
        h.held_out_motion_rms_deg,
        h.held_out_motions,
        h.fitted_motion_rms_deg,
        h.fitted_motions,
        match h.earth_rate_floor_deg {
            None => "; the Earth's rotation taken out".to_string(),
            Some(floor) => format!(
                "; the Earth's rotation not taken out (the gyros do not resolve the heading): it \
                 adds up to {floor:.3} deg RMS"
            ),
        }
    );
    s
}

/// The known turns of the section list, expected against the raw and calibrated gyros.
fn turns_md(f: &FreeMotionFigures) -> String {
    let Some((updates, mean, half)) = f.known_turns else {
        return String::new();
    };
    let mut s = format!(
        "Known turns: mean NIS {mean:.3} over {updates} turns (expected 1 +- {}).\n\n| turn | expected [deg] | raw gyros [deg] | calibrated [deg] \
         |\n|---|---:|---:|---:|\n",
        table::significant(half, 2)
    );
    for t in &f.turns {
        let _ = writeln!(
            s,
            "| {} | {:.1} | {:.2} | {:.2} |",
            t.name, t.expected_deg, t.before_deg, t.after_deg
        );
    }
    s.push('\n');
    s
}

/// The mean NIS of each measurement against its band.
fn mean_nis_md(mean_nis: &[MeanNis]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Mean NIS per measurement (3 expected: three components per update, for the turntable \
         angles a little less, docs/estimation.md; band: three standard deviations of the mean, \
         3 sqrt(6/n)):\n\n| measurement | updates | mean NIS | band | inside |\n|---|---:|---:|---|---|"
    );
    for m in mean_nis {
        let _ = writeln!(
            s,
            "| {} | {} | {:.3} | {} +- {} | {} |",
            m.label,
            m.updates,
            m.mean,
            if m.expected == 3.0 {
                "3".to_string()
            } else {
                format!("{:.3}", m.expected)
            },
            table::significant(m.half_band, 2),
            if m.consistent() { "yes" } else { "**no**" }
        );
    }
    s
}

fn failing_tests_md(d: &Diagnostics) -> String {
    let mut s = String::new();
    let failing: Vec<_> = d.tests.iter().filter(|t| t.fails).collect();
    let _ = writeln!(
        s,
        "\nTests of the innovations (docs/estimation.md, \"Diagnostics\"): {} tests at the \
         family-wise level {} %, each at p < {} (Bonferroni); {} fail.\n",
        d.tests.len(),
        100.0 * d.settings.alpha,
        p_value_text(d.per_test_level),
        failing.len()
    );
    if failing.is_empty() {
        return s;
    }
    let _ = writeln!(
        s,
        "| failing test | statistic | dof | p |\n|---|---:|---:|---:|"
    );
    for t in failing.iter().take(FAILING_TESTS_SHOWN) {
        let _ = writeln!(
            s,
            "| {} | {:.1} | {} | {} |",
            t.name,
            t.statistic,
            t.dof,
            p_value_text(t.p_value)
        );
    }
    if failing.len() > FAILING_TESTS_SHOWN {
        let _ = writeln!(
            s,
            "\n... and {} more (every test is in the JSON's `diagnostics`).",
            failing.len() - FAILING_TESTS_SHOWN
        );
    }
    s.push('\n');
    s
}

fn parameters_md(report: &Report<'_>) -> String {
    let rows = report.parameters;
    let truth = report.truth.as_ref();
    let mut s = String::from(
        "## 3. Parameters\n\nIn the paper's units (scale factors in ppm), with the posterior \
         1-sigma",
    );
    s += if truth.is_some() {
        "; against the truth, the error in sigmas.\n\n| parameter | value | 1 sigma | unit | \
         truth | error/sigma |\n|---|---:|---:|---|---:|---:|\n"
    } else {
        ".\n\n| parameter | value | 1 sigma | unit |\n|---|---:|---:|---|\n"
    };
    let names: Vec<String> = rows.iter().map(|r| r.name.clone()).collect();
    for (title, members) in table::grouped(&names) {
        let _ = writeln!(
            s,
            "| **{title}** | | | |{}",
            if truth.is_some() { " | |" } else { "" }
        );
        for i in members {
            let r = &rows[i];
            let _ = write!(
                s,
                "| {} | {} | {} | {} |",
                r.name,
                table::with_precision_of(r.value, r.sigma),
                table::sigma(r.sigma),
                r.unit
            );
            if truth.is_some() {
                let _ = write!(
                    s,
                    " {} | {} |",
                    r.truth
                        .map_or("-".into(), |t| table::with_precision_of(t, r.sigma)),
                    r.error_sigmas.map_or("-".into(), |e| format!("{e:+.2}"))
                );
            }
            s.push('\n');
        }
    }
    if !report.unobserved.is_empty() {
        let _ = writeln!(
            s,
            "\nNot observed by this run (posterior sigma above {:.0} % of the prior: estimate = \
             prior): {}.",
            100.0 * calib::estimate::UNOBSERVED_SIGMA_RATIO,
            crate::render::console::unobserved_list(report.unobserved)
        );
    }
    if let Some(text) = &report.truth {
        let _ = writeln!(s, "\n```text\n{text}```");
    }
    s.push('\n');
    s
}

fn correlation_md(dir: &Path, report: &Report<'_>, plots: &mut usize) -> Result<String, Error> {
    let (names, r) = report.correlation;
    crate::plots::lab_report::correlation_png(&dir.join("correlation.png"), names, r)?;
    *plots += 1;
    let mut s = String::from(
        "## 4. Correlation of the estimates\n\n![posterior correlation matrix](correlation.png)\n\n\
         The strongest correlations:\n\n| parameter | parameter | correlation |\n|---|---|---:|\n",
    );
    for (a, b, c) in report.strongest {
        let _ = writeln!(s, "| {a} | {b} | {c:+.4} |");
    }
    s.push('\n');
    let notes = crate::render::lab_report::correlation_notes::sentences(report.strongest);
    if notes.is_empty() {
        let _ = writeln!(
            s,
            "No two estimates are correlated at {} or more in magnitude.\n",
            crate::render::lab_report::correlation_notes::EXPLAINED_ABOVE
        );
    } else {
        let _ = writeln!(
            s,
            "The correlations of {} or more in magnitude:\n",
            crate::render::lab_report::correlation_notes::EXPLAINED_ABOVE
        );
        for n in notes {
            let _ = writeln!(s, "- {n}");
        }
        s.push('\n');
    }
    Ok(s)
}

/// The measurement kinds the fit has, in report order.
fn kinds_of(d: &Diagnostics) -> Vec<MeasurementKind> {
    [MeasurementKind::Accel, MeasurementKind::Turntable]
        .into_iter()
        .filter(|k| d.kind(*k).is_some())
        .collect()
}

fn residuals_md(dir: &Path, report: &Report<'_>, plots: &mut usize) -> Result<String, Error> {
    let (est, d) = (report.fit.est, report.fit.diagnostics);
    let mut s = String::from(
        "## 5. Residuals\n\nThe innovations `z - H x` of every update of the reported fit, per \
         axis of the local frame (East, North, Up), in physical units, with the band of one \
         standard deviation that the model gives them (the square root of the diagonal of the \
         innovation covariance S). Segments are shaded alternately and numbered as in section \
         6; a segment whose NIS test fails is shaded red.\n\n",
    );
    let rows = report.segments;
    for kind in kinds_of(d) {
        let failing: Vec<usize> = rows
            .iter()
            .filter(|r| r.kind == kind && r.fails)
            .map(|r| r.segment)
            .collect();
        let name = format!("residuals_{}.png", kind_serde::name(kind));
        let residuals = lab::residuals(&est.innovations, kind);
        let marks = crate::plots::lab_report::SegmentMarks {
            segments: &est.segments,
            failing: &failing,
        };
        crate::plots::lab_report::residuals_png(&dir.join(&name), kind, &residuals, &marks)?;
        *plots += 1;
        let (unit, _) = lab::residual_unit(kind);
        let _ = writeln!(
            s,
            "![{} residuals in {unit}]({name})\n",
            calib::check::diagnostics::kind_label(kind)
        );
    }
    if let Some(t) = &est.temperature
        && !est.temperature_series.is_empty()
    {
        // In the instrument's axes, where a sensor's thermal error stays on its own axis
        // (in the local frame a turning unit spreads it over all three).
        let (_, factor) = lab::residual_unit(MeasurementKind::Accel);
        let accel: Vec<&calib::check::diagnostics::Innovation> = est
            .innovations
            .iter()
            .filter(|i| i.kind == MeasurementKind::Accel && i.nu.iter().all(|x| x.is_finite()))
            .collect();
        // Updates with a typical band only (at most twice the median): the first ones of a fit,
        // or those after a motion between rests, are the prior's, not the temperature's.
        let width = |i: &calib::check::diagnostics::Innovation| (i.s.trace() / 3.0).max(0.0).sqrt();
        let mut widths: Vec<f64> = accel.iter().map(|i| width(i)).collect();
        widths.sort_by(f64::total_cmp);
        let median = widths.get(widths.len() / 2).copied().unwrap_or(0.0);
        let body: Vec<(f64, [f64; 3])> = accel
            .into_iter()
            .filter(|i| width(i) <= 2.0 * median)
            .filter_map(|i| {
                let c = i.c_body_to_enu?;
                let r = c.transpose() * i.nu * factor;
                Some((i.t, [r.x, r.y, r.z]))
            })
            .collect();
        crate::plots::lab_report::temperature_png(
            &dir.join("temperature.png"),
            &est.temperature_series,
            t.reference_c,
            &body,
        )?;
        *plots += 1;
        let thermal: Vec<&str> = est
            .names
            .iter()
            .filter(|n| n.contains(".tbias.") || n.contains(".tscale."))
            .map(String::as_str)
            .collect();
        let _ = writeln!(
            s,
            "### Against temperature\n\nThe records' temperature (1-s means) and the \
             specific-force residuals against it in the instrument's axes (each update's \
             residual turned by the computed attitude), with their means in bins of \
             temperature (red, +-1 standard error). The thermal terms are about {:.2} deg C ({}); \
             this model has {}. A bias that follows the temperature and is not modelled shows \
             as residuals that spread or tilt away from the reference.\n\n\
             ![temperature and residuals against it](temperature.png)\n",
            t.reference_c,
            t.reference_reason,
            if thermal.is_empty() {
                "no thermal term".to_string()
            } else {
                format!("the thermal terms ({})", thermal.join(", "))
            }
        );
    }
    Ok(s)
}

fn segments_md(dir: &Path, report: &Report<'_>, plots: &mut usize) -> Result<String, Error> {
    let mut s = String::from(
        "## 6. NIS per segment\n\nThe NIS summed over each segment, over its degrees of freedom \
         (1 expected), against its band at the per-test level of the verdict",
    );
    s += if report.base.is_some() {
        "; the plot shows the paper's model beside the extended one, the table the extended \
         one.\n\n"
    } else {
        ".\n\n"
    };
    let files = diagnostic_plots(dir, report, &["nis_segments"])?;
    *plots += files.len();
    for f in &files {
        let _ = writeln!(s, "![NIS per segment]({f})\n");
    }
    let d = report.fit.diagnostics;
    for kind in kinds_of(d) {
        let _ = writeln!(
            s,
            "{}:\n\n| # | segment | IMU time [s] | updates | NIS/dof | band | p | test \
             |\n|---:|---|---|---:|---:|---|---:|---|",
            calib::check::diagnostics::kind_label(kind)
        );
        for r in report.segments.iter().filter(|r| r.kind == kind) {
            let span = r.span_s.map_or("-".into(), |(a, b)| {
                format!("{} .. {}", seconds(a), seconds(b))
            });
            let _ = writeln!(
                s,
                "| {} | {} | {span} | {} | {:.3} | {:.3} .. {:.3} | {} | {} |",
                r.segment,
                r.label,
                r.updates,
                r.nis_per_dof,
                r.band_per_dof.0,
                r.band_per_dof.1,
                p_value_text(r.p_value),
                if r.fails { "**fails**" } else { "passes" }
            );
        }
        s.push('\n');
    }
    Ok(s)
}

/// A time on the IMU clock to the millisecond, without trailing zeros.
fn seconds(t: f64) -> String {
    table::compact((t * 1e3).round() / 1e3 + 0.0)
}

/// Diagnostic plots of the reported fit (and the paper's model beside it) into `dir`; their
/// file names.
fn diagnostic_plots(dir: &Path, report: &Report<'_>, which: &[&str]) -> Result<Vec<String>, Error> {
    let (before, after) = match &report.base {
        Some(base) => (base, Some(&report.fit)),
        None => (&report.fit, None),
    };
    let files = crate::plots::innovation_diagnostics::write_plots(
        dir,
        which,
        (800, 560),
        before.diagnostics,
        &before.est.innovations,
        after.map(|a| (a.diagnostics, a.est.innovations.as_slice())),
    )?;
    Ok(files
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect())
}

fn further_plots_md(dir: &Path, report: &Report<'_>, plots: &mut usize) -> Result<String, Error> {
    let mut s = String::from(
        "## Further diagnostics\n\nThe periodograms of the whitened innovations (1 = white \
         noise; triangles: the program's frequencies, line: the level a line must pass to fail) \
         and their autocorrelations with the 95 % band of white noise.\n\n",
    );
    let files = diagnostic_plots(dir, report, &["spectrum", "autocorrelation"])?;
    *plots += files.len();
    for f in files {
        let _ = writeln!(s, "![{}]({f})\n", f.trim_end_matches(".png"));
    }
    Ok(s)
}

/// A number of the correction tables: 12 decimals for the matrices' entries (their
/// deviations from 1 are parts per million), otherwise 6 significant digits.
fn entry(x: f64, matrix: bool) -> String {
    if matrix {
        format!("{:.12}", x + 0.0)
    } else if x == 0.0 {
        "0".into()
    } else {
        format!("{x:.5e}")
    }
}

/// One triad's table: rows x, y, z; the matrix's three columns (when there is one), then the
/// vectors.
fn triad_table(matrix: Option<(&[[f64; 3]; 3], &str)>, vectors: &[(&str, [f64; 3])]) -> String {
    let mut s = String::from("| |");
    let mut rule = String::from("|---|");
    if let Some((_, name)) = matrix {
        let _ = write!(s, " {name} x | {name} y | {name} z |");
        rule += "---:|---:|---:|";
    }
    for (name, _) in vectors {
        let _ = write!(s, " {name} |");
        rule += "---:|";
    }
    let _ = writeln!(s, "\n{rule}");
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        let _ = write!(s, "| **{axis}** |");
        if let Some((m, _)) = matrix {
            for v in m[i] {
                let _ = write!(s, " {} |", entry(v, true));
            }
        }
        for (_, v) in vectors {
            let _ = write!(s, " {} |", entry(v[i], false));
        }
        s.push('\n');
    }
    s.push('\n');
    s
}
/// The reported model inverted: the matrices and offsets `apply` applies (the result file's
/// `correction` block, in SI), with the formulas they belong to.
fn correction_md(c: Option<&CorrectionBlock>) -> String {
    let Some(c) = c else {
        return String::new();
    };
    let mut s = format!(
        "### The correction\n\nThe estimated model inverted, as `sins-calib apply` applies it \
         to raw records (SI; docs/formats.md, \"Correction\"): `{}`.\n\n",
        c.convention
    );
    let mut gyro = vec![("b_g [rad/s]", c.gyro.offset)];
    if let Some(a) = c.gyro.asym {
        gyro.push(("a", a));
    }
    s += "Gyros:\n\n";
    s += &triad_table(Some((&c.gyro.matrix, "M_g")), &gyro);
    if let Some(g) = &c.gyro.gsens {
        s += "g-sensitivity G [rad/s per m/s^2]:\n\n";
        s += &triad_table(Some((g, "G")), &[]);
    }
    let mut accel = vec![("b_a [m/s^2]", c.accel.offset)];
    if let Some(k2) = c.accel.k2 {
        accel.push(("k2 [1/(m/s^2)]", k2));
    }
    s += "Accelerometers:\n\n";
    s += &triad_table(Some((&c.accel.matrix, "M_a")), &accel);
    if let Some(l) = &c.accel.lever {
        s += "Size effect, row i the offset r_i of accelerometer i [m]:\n\n";
        s += &triad_table(Some((l, "r")), &[]);
    }
    if let Some(d) = c.accel.time_offset_s {
        let _ = writeln!(
            s,
            "Time offset d of the accelerometers: {} s.\n",
            entry(d, false)
        );
    }
    if let Some(t) = &c.thermal {
        let _ = writeln!(
            s,
            "The matrices and offsets hold at {} deg C; per kelvin from it:\n",
            t.reference_c
        );
        s += &triad_table(
            None,
            &[
                ("gyro bias [rad/s/K]", t.gyro_bias),
                ("accel bias [m/s^2/K]", t.accel_bias),
                ("gyro scale [1/K]", t.gyro_scale),
                ("accel scale [1/K]", t.accel_scale),
            ],
        );
    }
    s
}
