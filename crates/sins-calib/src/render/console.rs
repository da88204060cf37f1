//! The printout of `calibrate`: its [`RunReport`] rendered as text, in the paper's units.

use crate::free_motion::{FreeMotionFigures, NoiseFigures};
use crate::render::calibrate_figures::{
    Configuration, FitFigures, Header, RunReport, Start, TruthFigures, Verdict,
};
use crate::render::table::{self, Align, Table};
use calib::estimate::verdict::MeanNis;
use calib::io::ImuKind;
use calib::report::lab::ParameterRow;
use std::fmt::Write as _;
use std::path::PathBuf;

/// What a run wrote, for the printout's last lines.
#[derive(Default)]
pub struct Written {
    /// The diagnostic plots (`--diagnostics DIR`): the directory and the number of files.
    pub diagnostics: Option<(PathBuf, usize)>,
    /// The JSON result, when not on standard output.
    pub json: Option<PathBuf>,
    /// The `--plot` PNG.
    pub plot: Option<PathBuf>,
    /// The report directory and its number of plots.
    pub report: Option<(PathBuf, usize)>,
}

/// The printout of `r`.
pub fn render(r: &RunReport, written: &Written) -> String {
    let mut s = header(&r.header);
    if let Some(f) = &r.free_motion {
        s += &free_motion_header(f);
    }
    s += &provenance(r);
    s.push('\n');
    s += &parameters(&r.parameters, r.truth.is_some());
    s.push('\n');
    s += &fit(&r.fit);
    s += &observability(&r.fit);
    if let Some(f) = &r.free_motion {
        s += &evaluation(f);
    }
    let _ = writeln!(s, "\n{}", r.navigation.line());
    if let Some(t) = &r.truth {
        s.push('\n');
        s += &truth(t);
    }
    let _ = writeln!(s, "\nDiagnostics (docs/estimation.md, \"Diagnostics\")");
    s.push_str(&r.diagnostics.summary());
    if let Some((dir, files)) = &written.diagnostics {
        let _ = writeln!(s, "  plots: {files} files in {}", dir.display());
    }
    s += &verdict(&r.verdict);
    if let Some(path) = &written.json {
        let _ = writeln!(s, "\nwrote {}", path.display());
    }
    if let Some(path) = &written.plot {
        let _ = writeln!(s, "wrote {}", path.display());
    }
    if let Some((dir, plots)) = &written.report {
        let _ = writeln!(s, "wrote the report {} ({plots} plots)", dir.display());
    }
    s
}

/// The message on standard error when the data contradict the model.
pub fn misfit_message(v: &Verdict) -> String {
    format!(
        "\nTHE MODEL DOES NOT FIT THESE DATA (exit status {}): {}",
        v.exit_status(),
        v.advice.replace("{}", &v.reasons.join("\n  "))
    )
}

/// The head: configuration, data, model, program start or rests.
fn header(h: &Header) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "sins-calib calibrate");
    let _ = match &h.configuration {
        Configuration::Program(origin, name, duration) => writeln!(
            s,
            "  configuration   {origin}: program \"{name}\" ({} s)",
            table::compact(*duration)
        ),
        Configuration::MadeFromRecording => writeln!(
            s,
            "  configuration   none: a hand-turned recording without a program (--free-motion)"
        ),
        Configuration::Rests(origin) => writeln!(
            s,
            "  configuration   {origin}: no program (a recording of rests)"
        ),
    };
    let (t0, t1) = h.imu_span;
    let _ = writeln!(
        s,
        "  IMU data        {}: {} records of {}, t = {} .. {} s",
        h.imu_file,
        h.imu_records,
        match h.imu_kind {
            ImuKind::Increments => "increments",
            ImuKind::Rates => "rates",
        },
        table::compact(t0),
        table::compact(t1),
    );
    s += &temperature_line(h.temperature.as_ref());
    if let Some(tt) = &h.turntable {
        let _ = writeln!(
            s,
            "  turntable data  {}: {} records, t = {} .. {} s on its clock ({} .. {} s on the \
             IMU clock)",
            tt.file,
            tt.count,
            table::compact(tt.span.0),
            table::compact(tt.span.1),
            table::compact(tt.imu_span.0),
            table::compact(tt.imu_span.1),
        );
    }
    let _ = writeln!(
        s,
        "  model           {} states ({} parameters and the attitude error)",
        h.states,
        h.states - 3
    );
    s += &start(&h.start);
    s.push('\n');
    for line in &h.missed_rests {
        let _ = writeln!(s, "  missed rests    {line}");
    }
    s
}

/// The header's line of the records' temperatures and the thermal terms' reference (empty
/// without a temperature).
fn temperature_line(t: Option<&calib::io::ResultTemperature>) -> String {
    let Some(t) = t else {
        return String::new();
    };
    let span = match (t.min_c, t.max_c) {
        (Some(a), Some(b)) => format!("{a:.2} .. {b:.2} deg C"),
        _ => "unknown".into(),
    };
    format!(
        "  temperature     {span}; thermal terms about {:.2} deg C ({})\n",
        t.reference_c, t.reference_reason
    )
}

/// Where the program starts, or the rests and the start attitude.
fn start(start: &Start) -> String {
    let mut s = String::new();
    match start {
        Start::Program(t, found) => {
            let _ = writeln!(
                s,
                "  program start   t = {} s on the IMU clock ({})",
                table::compact(*t),
                if *found {
                    "found from the data"
                } else {
                    "given, checked against the data"
                }
            );
        }
        Start::Rests(r) => {
            let _ = writeln!(
                s,
                "  rests           {} found in the data, {} s in all; the specific force is \
                 measured in them only ({} windows with motion left out)",
                r.count,
                table::compact(r.at_rest_s),
                r.windows_in_motion
            );
            let sigma = table::compact(r.gyrocompass_sigma_deg);
            let _ = writeln!(
                s,
                "  start attitude  levelled in the first rest; heading {}",
                if r.gyrocompassed {
                    format!(
                        "from the Earth rate (gyrocompassing, sigma {sigma} deg from the gyro \
                         priors)"
                    )
                } else {
                    format!(
                        "free (the gyro priors allow {sigma} deg of gyrocompassing error): not \
                         observed"
                    )
                }
            );
        }
    }
    s
}

/// The head lines that only a hand-turned recording has: the noise and the model.
fn free_motion_header(f: &FreeMotionFigures) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "  settings        {}", f.origin);
    if let Some(g) = &f.grade {
        let _ = writeln!(s, "  grade           {}", g.describe());
    }
    s += &noise_lines(f);
    let _ = writeln!(
        s,
        "  motions         {} deg of attitude noise per motion (what the gyros' model misses \
         in a hand turn; filter.motion_attitude_noise_deg)",
        table::significant(f.motion_attitude_noise_deg, 3)
    );
    if let Some((excess, dof)) = f.rest_excess_m_s2 {
        let _ = writeln!(
            s,
            "  rests' excess   {} m/s^2 ({dof:.1} degrees of freedom): what the rests' |f| = g \
             residuals scatter beyond their white noise, an error each rest's windows share \
             (settling, placement, drift){}",
            table::significant(excess, 3),
            if f.rest_error_m_s2 > 0.0 || excess == 0.0 {
                String::new()
            } else {
                format!(
                    "; taken as independent (--rest-error {} weighs it)",
                    table::significant(excess, 2)
                )
            }
        );
    }
    if let (true, Some(e)) = (f.rest_error_m_s2 > 0.0, f.rest_error_unasked) {
        let _ = writeln!(
            s,
            "  rests' error    {} m/s^2 shared by the windows of each rest, weighed unasked: the \
             rests' excess is significant (p = {:.2e} over {:.1} degrees of freedom); a long \
             rest counts at most as one measurement of it (--rest-error 0 takes the windows as \
             independent)",
            table::significant(f.rest_error_m_s2, 3),
            e.p_value,
            e.dof
        );
    } else if f.rest_error_m_s2 > 0.0 {
        let _ = writeln!(
            s,
            "  rests' error    {} m/s^2 shared by the windows of each rest, weighed: a long rest \
             counts at most as one measurement of it (--rest-error, filter.rest_error_m_s2)",
            table::significant(f.rest_error_m_s2, 3)
        );
    }
    let _ = writeln!(
        s,
        "  gravity         {} m/s^2",
        table::significant(f.gravity_m_s2, 7)
    );
    let _ = writeln!(
        s,
        "  terms           {} (at {}-grade priors)",
        if f.terms.is_empty() {
            "the paper's model only (--terms or --terms-from adds others)".to_string()
        } else {
            format!("the paper's model and {}", f.terms.join(", "))
        },
        f.grade_name
    );
    if let Some(k) = f.holdout {
        let _ = writeln!(
            s,
            "  held out        every {k}-th rest: its measurements are predicted, not used"
        );
    }
    s
}

/// Where the noise came from, and what was measured.
fn noise_lines(f: &FreeMotionFigures) -> String {
    let mut s = String::new();
    let m = match f.noise {
        NoiseFigures::Configured => {
            let _ = writeln!(
                s,
                "  noise           configured: gyro {} deg/h, specific force {} m/s^2 (1-s means)",
                table::significant(f.noise_gyro_deg_h, 3),
                table::significant(f.noise_accel_m_s2, 3)
            );
            return s;
        }
        NoiseFigures::Measured(m) => m,
    };
    let _ = writeln!(
        s,
        "  noise           measured in the rests (1-s means, {} degrees of freedom): gyro {} \
         deg/h, specific force {} m/s^2",
        m.dof,
        table::significant(m.gyro_deg_h, 3),
        table::significant(m.accel_m_s2, 3)
    );
    let _ = writeln!(
        s,
        "                  specific force scaled by {} to {} m/s^2, the scatter of the fit's \
         innovations ({} the rests' own noise: variance ratio {}, p = {:.2e})",
        table::significant(m.accel_factor, 3),
        table::significant(f.noise_accel_m_s2, 3),
        if m.scatter_significant {
            "significantly more than"
        } else {
            "consistent with"
        },
        table::significant(m.scatter_ratio, 3),
        m.scatter_p_value
    );
    let _ = writeln!(
        s,
        "                  motion noise measured from the first window after each of {} \
         motions; {} fit{} to bring both to the innovations",
        m.motion_windows,
        m.fits,
        if m.fits == 1 { "" } else { "s" }
    );
    s
}

/// The lines on the unit, the inputs' SHA-256 (with --free-motion) and the assumptions.
fn provenance(r: &RunReport) -> String {
    let p = &r.provenance;
    let mut s = String::new();
    if p.unit.is_empty() {
        let _ = writeln!(
            s,
            "  unit            unknown (no [unit] in the configuration or import profile; \
             --unit-model, --unit-serial)"
        );
    } else {
        let _ = writeln!(
            s,
            "  unit            {} (from {})",
            p.unit.describe(),
            p.unit_sources.join(", ")
        );
    }
    for f in &p.inputs {
        let _ = writeln!(
            s,
            "  input           {}: {} ({} bytes, SHA-256 {})",
            f.role, f.path, f.bytes, f.sha256
        );
    }
    for note in &p.notes {
        let _ = writeln!(s, "  note            {note}");
    }
    for a in &r.assumptions {
        let _ = writeln!(s, "  ASSUMED         {a}");
    }
    s
}

/// The estimates by group in the paper's units; with a truth also the true value and the error
/// in sigmas.
fn parameters(rows: &[ParameterRow], with_truth: bool) -> String {
    let mut columns = vec![
        ("parameter", Align::Left),
        ("value", Align::Right),
        ("sigma", Align::Right),
        ("unit", Align::Left),
    ];
    if with_truth {
        columns.extend([("truth", Align::Right), ("error/sigma", Align::Right)]);
    }
    let mut t = Table::new(&columns);
    let names: Vec<String> = rows.iter().map(|r| r.name.clone()).collect();
    for (title, members) in table::grouped(&names) {
        t.section(title);
        for r in members.into_iter().map(|i| &rows[i]) {
            let mut cells = vec![
                format!("  {}", r.name),
                table::with_precision_of(r.value, r.sigma),
                table::sigma(r.sigma),
                r.unit.to_string(),
            ];
            if with_truth {
                match (r.truth, r.error_sigmas) {
                    (Some(t), Some(e)) => {
                        cells.push(table::with_precision_of(t, r.sigma));
                        cells.push(format!("{e:+.2}"));
                    }
                    _ => cells.extend(["-".to_string(), "-".to_string()]),
                }
            }
            t.row(cells);
        }
    }
    t.render()
}

/// One line on a mean NIS: is it consistent with what it averages when the model fits (3, or
/// a little less for the turntable angles)?
fn nis_line(m: &MeanNis) -> String {
    if m.updates == 0 {
        return "no updates".into();
    }
    let head = format!("mean NIS {:.3} over {} updates", m.mean, m.updates);
    let centre = if m.expected == 3.0 {
        "3".to_string()
    } else {
        format!("{:.3}", m.expected)
    };
    let band_text = format!("{centre} +- {}", table::significant(m.half_band, 2));
    if m.consistent() {
        format!("{head}: consistent with {centre} (expected {band_text})")
    } else if m.mean > m.expected {
        format!(
            "{head}: larger than expected ({band_text}); the data scatter more than the \
             noise levels and priors the fit used allow (noise levels too low, or errors the \
             model lacks)"
        )
    } else {
        format!(
            "{head}: smaller than expected ({band_text}); the noise levels the fit used are \
             larger than the data's (the sigmas are conservative)"
        )
    }
}

/// The fit's mean NIS and counts.
fn fit(f: &FitFigures) -> String {
    let mut s = String::from("Fit\n");
    for m in &f.mean_nis {
        let _ = writeln!(s, "  {:<17} {}", m.label, nis_line(m));
    }
    if let Some((updates, mean, half)) = f.known_turns {
        let _ = writeln!(
            s,
            "  known turns       mean NIS {mean:.3} over {updates} turns (expected 1 +- {})",
            table::significant(half, 2)
        );
    }
    let _ = writeln!(s, "  IMU records       {} integrated", f.imu_records);
    if let Some(t) = &f.turntable {
        let _ = writeln!(
            s,
            "  turntable samples {} used, {} left out near rate changes, {} without turntable \
             data; records at {} Hz on the IMU clock",
            t.used,
            t.near_rate_changes,
            t.missing,
            table::compact(t.record_rate_hz)
        );
    }
    s
}

/// Which parameters the run leaves at their prior, and the second-order error carried.
fn observability(f: &FitFigures) -> String {
    let mut s = String::new();
    if f.unobserved.is_empty() {
        let _ = writeln!(
            s,
            "  observability     every parameter is observed by this run"
        );
    } else {
        let _ = writeln!(
            s,
            "  not observed      {} of {} parameters keep more than {:.0} % of their prior sigma (estimate = prior, sigma honest): {}",
            f.unobserved.len(),
            f.states - 3,
            100.0 * calib::estimate::UNOBSERVED_SIGMA_RATIO,
            unobserved_list(&f.unobserved)
        );
    }
    let (sigma, directions) = f.second_order;
    if directions > 0 {
        let _ = writeln!(
            s,
            "  second order      beta x (C df) is {} m/s^2 (1 sigma) on this run: carried into the covariance ({directions} directions)",
            table::significant(sigma, 2),
        );
    }
    s
}

/// Unobserved parameters with their share of the prior sigma.
pub fn unobserved_list(unobserved: &[(String, f64)]) -> String {
    unobserved
        .iter()
        .map(|(n, r)| format!("{n} ({:.0} %)", 100.0 * r))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The turns and the held-out validation of a hand-turned recording.
fn evaluation(f: &FreeMotionFigures) -> String {
    let mut s = String::new();
    for t in &f.turns {
        let _ = writeln!(
            s,
            "  turn {}: expected {:.1} deg, raw gyro {:.2} deg, calibrated {:.2} deg",
            t.name, t.expected_deg, t.before_deg, t.after_deg
        );
    }
    let _ = writeln!(
        s,
        "  static |f| - g RMS over the {} fitted rests: before {:.5} m/s^2, after {:.5} m/s^2",
        f.fitted_rests, f.fitted_static_rms_m_s2.0, f.fitted_static_rms_m_s2.1
    );
    if let Some(v) = &f.validation {
        let _ = writeln!(
            s,
            "\nHeld-out validation ({} rests, {} pairs of consecutive ones)\n  static |f| - g \
             RMS        before {:.5} m/s^2, after {:.5} m/s^2\n  rotation (gravity direction) \
             RMS  before {:.3} deg, after {:.3} deg{}\n  over single motions     into or out of \
             held-out rests {:.3} deg ({}), between fitted rests {:.3} deg ({})",
            v.intervals,
            v.rotation_pairs,
            v.static_rms_m_s2.0,
            v.static_rms_m_s2.1,
            v.rotation_rms_deg.0,
            v.rotation_rms_deg.1,
            match v.earth_rate_floor_deg {
                None => " (the Earth's rotation taken out)".to_string(),
                Some(floor) => format!(
                    " (the Earth's rotation not taken out: the gyros do not resolve the \
                     heading; it adds up to {floor:.3} deg RMS over these pairs)"
                ),
            },
            v.held_out_motion_rms_deg,
            v.held_out_motions,
            v.fitted_motion_rms_deg,
            v.fitted_motions
        );
        if let Some((held_out, fitted)) = v.baseline_static_rms_m_s2 {
            let _ = writeln!(
                s,
                "  least-squares baseline  static |f| - g RMS {held_out:.5} m/s^2 held out, \
                 {fitted:.5} m/s^2 fitted (the nine accelerometer parameters fitted to |f| = g \
                 at the same rests alone; held-out ratio of this calibration to it {:.2})",
                v.static_rms_m_s2.1 / held_out
            );
        } else {
            let _ = writeln!(
                s,
                "  least-squares baseline  not fitted: {} fitted rests for its nine parameters \
                 (it needs more than nine)",
                f.fitted_rests
            );
        }
    }
    s
}

/// NEES over the parameters that the truth knows, with the full covariance (also the text
/// the laboratory report quotes).
pub fn truth(t: &TruthFigures) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "Against the truth in {}", t.path.display());
    let Some(c) = &t.comparison else {
        let _ = writeln!(s, "  no estimated parameter is named in the truth file");
        return s;
    };
    let (n, diagonal) = (c.parameters, c.sum_squared_sigmas);
    let expected = format!(
        "a consistent filter gives {n} on average, standard deviation {}",
        table::significant((2.0 * n as f64).sqrt(), 2)
    );
    match c.nees {
        Some(nees) => {
            let _ = writeln!(
                s,
                "  NEES {nees:.1} over {n} parameters ({expected}); sum of squared errors in \
                 sigmas {diagonal:.1}"
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  NEES: the covariance is not positive definite; sum of squared errors in sigmas \
                 {diagonal:.1} over {n} parameters ({expected})"
            );
        }
    }
    let _ = writeln!(
        s,
        "  largest error {:+.2} sigma ({})",
        c.largest.1, c.largest.0
    );
    for (name, value, configured, what) in &t.clock_notes {
        let _ = writeln!(
            s,
            "  note: the truth's {name} = {value} differs from the configuration's {what} = \
             {configured}: the estimated delay absorbs the difference",
        );
    }
    s
}

/// The verdict's block: what it rests on, and what informs without deciding.
fn verdict(v: &Verdict) -> String {
    let mut s = format!("\nVerdict\n  rests on        {}\n", v.basis);
    for line in &v.findings {
        let _ = writeln!(s, "  finding         {line}");
    }
    let _ = writeln!(
        s,
        "  {}",
        if !v.fits() {
            "the data contradict the model (exit status 3)"
        } else if v.tested {
            "nothing contradicts the model"
        } else {
            "the model was not tested"
        }
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib::model::MeasurementKind;

    fn nis(mean: f64, expected: f64, n: usize) -> String {
        nis_line(&MeanNis {
            kind: MeasurementKind::Accel,
            label: "specific force",
            updates: n,
            mean,
            expected,
            half_band: calib::estimate::verdict::mean_nis_half_band(n),
        })
    }

    #[test]
    fn verdicts() {
        assert!(nis(3.05, 3.0, 2727).contains("consistent"));
        assert!(nis(3.5, 3.0, 2727).contains("larger"));
        assert!(nis(2.5, 3.0, 2727).contains("smaller"));
        assert!(nis(3.5, 3.0, 30).contains("consistent"));
        // About the expected mean: 2.944 over a 10-h run's updates is 1.4 bands below 3 but
        // inside the band about 2.97.
        assert!(nis(2.944, 3.0, 35559).contains("smaller"));
        let v = nis(2.944, 2.97, 35559);
        assert!(v.contains("consistent with 2.970"), "{v}");
    }
}
