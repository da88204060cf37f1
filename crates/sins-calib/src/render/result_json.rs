//! The JSON result of `calibrate` (docs/formats.md): its [`RunReport`] rendered in SI units.

use crate::Error;
use crate::free_motion::{FreeMotionFigures, NoiseFigures};
use crate::provenance::InputHash;
use crate::render::calibrate_figures::{FitFigures, RunReport, Verdict};
use calib::check::diagnostics::Diagnostics;
use calib::config::UnitIdentity;
use calib::io::{ResultParameter, ResultTemperature};
use calib::model::correction::CorrectionBlock;
use serde::Serialize;
use std::path::Path;

/// The JSON result: the parameters as `calib::io::ResultFile` writes them, plus the fit
/// statistics (readers of `ResultFile` ignore the extra field).
#[derive(Serialize)]
struct ResultJson<'a> {
    /// The unit the data are of (absent: unknown).
    #[serde(skip_serializing_if = "UnitIdentity::is_empty")]
    unit: &'a UnitIdentity,
    /// With --free-motion: every input file with its SHA-256.
    #[serde(skip_serializing_if = "Option::is_none")]
    inputs: Option<&'a [InputHash]>,
    /// What the run assumed for want of an input (e.g. the site's latitude).
    assumptions: &'a [String],
    /// The candidate terms added to the paper's model (`--terms`, `--terms-from`).
    terms: &'a [&'static str],
    parameters: &'a [ResultParameter],
    /// The posterior correlation of the parameters (docs/formats.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    correlation: Option<&'a Vec<Vec<f64>>>,
    /// The estimated model inverted (`calib::model::correction`).
    #[serde(skip_serializing_if = "Option::is_none")]
    correction: Option<&'a CorrectionBlock>,
    /// The records' temperatures and the thermal terms' reference, when the records have a
    /// temperature.
    #[serde(skip_serializing_if = "Option::is_none")]
    temperature: Option<&'a ResultTemperature>,
    /// Whether the model fits the data, with the reasons when it does not.
    verdict: VerdictJson<'a>,
    fit: FitJson<'a>,
    /// The tests of the innovations (`calib::check::diagnostics::Diagnostics`).
    diagnostics: &'a Diagnostics,
    /// What the calibration buys in navigation (`crate::navigation`).
    navigation: crate::navigation::NavigationJson<'a>,
    /// With --free-motion: the noise, the known turns and the held-out rests.
    #[serde(skip_serializing_if = "Option::is_none")]
    free_motion: Option<FreeMotionJson>,
}

/// The verdict in the JSON results of `calibrate` and `diagnose`: `fits` false (and exit
/// status 3) when the data contradict the model.
#[derive(Serialize)]
pub struct VerdictJson<'a> {
    fits: bool,
    exit_status: u8,
    /// One line per reason (empty when the model fits).
    reasons: &'a [String],
    /// What the verdict rests on.
    basis: &'a str,
    /// Whether anything tested the model (false: a hand-turned recording with measured noise,
    /// no held-out rests and no known turns).
    tested: bool,
    /// Findings that do not decide the exit status.
    findings: &'a [String],
}

/// Fit statistics in the JSON result.
#[derive(Serialize)]
struct FitJson<'a> {
    states: usize,
    imu_records: usize,
    final_time_s: f64,
    accel_updates: usize,
    accel_mean_nis: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    turntable: Option<TurntableFitJson>,
    /// Parameters the data leave at their prior (posterior sigma / prior sigma above 0.9).
    unobserved: Vec<UnobservedJson<'a>>,
    /// Standard deviation of the second-order specific-force error carried into the
    /// covariance (m/s^2; 0 when negligible).
    second_order_accel_sigma_m_s2: f64,
    /// Known turns measured (a recording of rests with a section list).
    #[serde(skip_serializing_if = "Option::is_none")]
    known_turns: Option<KnownTurnsJson>,
}

#[derive(Serialize)]
struct KnownTurnsJson {
    updates: usize,
    mean_nis: f64,
}

#[derive(Serialize)]
struct UnobservedJson<'a> {
    name: &'a str,
    sigma_over_prior: f64,
}

#[derive(Serialize)]
struct TurntableFitJson {
    updates: usize,
    mean_nis: f64,
    /// What `mean_nis` averages when the model fits (`FitStatistics::turntable_expected_nis`).
    expected_mean_nis: f64,
    samples_used: usize,
    samples_near_rate_changes: usize,
    samples_without_data: usize,
    record_rate_hz: f64,
}

/// Write the result JSON of `r` to `path` atomically (or to standard output for `-`).
pub fn write(path: &Path, r: &RunReport) -> Result<(), Error> {
    let p = &r.provenance;
    let v = &r.verdict;
    let json = ResultJson {
        unit: &p.unit,
        inputs: (!p.inputs.is_empty()).then_some(p.inputs.as_slice()),
        assumptions: &r.assumptions,
        terms: &r.terms,
        parameters: &r.result.parameters,
        correlation: r.result.correlation.as_ref(),
        correction: r.result.correction.as_ref(),
        temperature: r.result.temperature.as_ref(),
        verdict: verdict(v),
        fit: fit(&r.fit),
        diagnostics: &r.diagnostics,
        navigation: r.navigation.json(),
        free_motion: r.free_motion.as_ref().map(free_motion),
    };
    let text = calib::io::schema::to_json(calib::io::schema::CALIBRATION, &json)?;
    crate::output::write_file(path, text.as_bytes())
}

/// The verdict's block.
pub fn verdict(v: &Verdict) -> VerdictJson<'_> {
    VerdictJson {
        fits: v.fits(),
        exit_status: v.exit_status(),
        reasons: &v.reasons,
        basis: &v.basis,
        tested: v.tested,
        findings: &v.findings,
    }
}

fn fit(f: &FitFigures) -> FitJson<'_> {
    let accel = &f.mean_nis[0];
    FitJson {
        states: f.states,
        imu_records: f.imu_records,
        final_time_s: f.final_time_s,
        accel_updates: accel.updates,
        accel_mean_nis: accel.mean,
        turntable: f
            .turntable
            .as_ref()
            .zip(f.mean_nis.get(1))
            .map(|(t, m)| TurntableFitJson {
                updates: m.updates,
                mean_nis: m.mean,
                expected_mean_nis: m.expected,
                samples_used: t.used,
                samples_near_rate_changes: t.near_rate_changes,
                samples_without_data: t.missing,
                record_rate_hz: t.record_rate_hz,
            }),
        unobserved: f
            .unobserved
            .iter()
            .map(|(name, sigma_over_prior)| UnobservedJson {
                name,
                sigma_over_prior: *sigma_over_prior,
            })
            .collect(),
        second_order_accel_sigma_m_s2: f.second_order.0,
        known_turns: f
            .known_turns
            .map(|(updates, mean_nis, _)| KnownTurnsJson { updates, mean_nis }),
    }
}

/// The free-motion block of the JSON result (docs/formats.md).
#[derive(Serialize)]
struct FreeMotionJson {
    /// Where the noise came from: `"configured"` or `"measured in the rests"`.
    noise_source: &'static str,
    /// The levels the filter used (sigma of a 1-s mean).
    noise_gyro_deg_h: f64,
    noise_accel_m_s2: f64,
    motion_attitude_noise_deg: f64,
    /// The error the windows of one rest share, weighed (m/s^2; 0: none).
    rest_error_m_s2: f64,
    /// Where it was weighed without `--rest-error`: the p-value of the rests' excess that
    /// made it so.
    #[serde(skip_serializing_if = "Option::is_none")]
    rest_error_unasked_p_value: Option<f64>,
    /// What the rests' |f| = g residuals scatter beyond their white noise (m/s^2).
    #[serde(skip_serializing_if = "Option::is_none")]
    rest_excess_m_s2: Option<f64>,
    /// Its degrees of freedom.
    #[serde(skip_serializing_if = "Option::is_none")]
    rest_excess_dof: Option<f64>,
    /// Measured noise: the rests' scatter and the factor on its specific-force level.
    #[serde(skip_serializing_if = "Option::is_none")]
    measured: Option<MeasuredJson>,
    gravity_m_s2: f64,
    static_intervals: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    held_out_every: Option<usize>,
    /// The grade chosen from the data (without a configuration).
    #[serde(skip_serializing_if = "Option::is_none")]
    grade: Option<GradeJson>,
    terms: Vec<&'static str>,
    turns: Vec<TurnJson>,
    #[serde(skip_serializing_if = "Option::is_none")]
    validation: Option<ValidationJson>,
}

#[derive(Serialize)]
struct MeasuredJson {
    gyro_deg_h: f64,
    accel_m_s2: f64,
    dof: usize,
    accel_factor: f64,
    /// The innovations' variance over the rests' own noise, and its p-value.
    scatter_ratio: f64,
    scatter_p_value: f64,
    motion_attitude_noise_deg: f64,
    motion_windows: usize,
    fits: usize,
}

#[derive(Serialize)]
struct GradeJson {
    grade: &'static str,
    by_noise: &'static str,
    by_rest_rate: &'static str,
    rest_rate_excess_deg_h: f64,
}

#[derive(Serialize)]
struct TurnJson {
    name: String,
    expected_deg: f64,
    before_deg: f64,
    after_deg: f64,
}

#[derive(Serialize)]
struct BeforeAfter {
    before: f64,
    after: f64,
}

#[derive(Serialize)]
struct ValidationJson {
    static_rms_m_s2: BeforeAfter,
    rotation_rms_deg: BeforeAfter,
    intervals: usize,
    rotation_pairs: usize,
    /// Whether the rotation figure takes the Earth's rotation out, and the floor it leaves
    /// where it cannot (deg).
    earth_rate_compensated: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    earth_rate_floor_deg: Option<f64>,
    fitted_static_rms_m_s2: f64,
    fitted_intervals: usize,
    held_out_motion_rms_deg: f64,
    held_out_motions: usize,
    fitted_motion_rms_deg: f64,
    fitted_motions: usize,
    /// The least-squares `|f| = g` baseline's `|f| - g` RMS on the same split (m/s^2).
    #[serde(skip_serializing_if = "Option::is_none")]
    baseline: Option<BaselineJson>,
}

#[derive(Serialize)]
struct BaselineJson {
    held_out_static_rms_m_s2: f64,
    fitted_static_rms_m_s2: f64,
}

fn before_after((before, after): (f64, f64)) -> BeforeAfter {
    BeforeAfter { before, after }
}

/// The free-motion block of `f`.
fn free_motion(f: &FreeMotionFigures) -> FreeMotionJson {
    let measured = match f.noise {
        NoiseFigures::Configured => None,
        NoiseFigures::Measured(m) => Some(MeasuredJson {
            gyro_deg_h: m.gyro_deg_h,
            accel_m_s2: m.accel_m_s2,
            dof: m.dof,
            accel_factor: m.accel_factor,
            scatter_ratio: m.scatter_ratio,
            scatter_p_value: m.scatter_p_value,
            motion_attitude_noise_deg: m.motion_noise_deg,
            motion_windows: m.motion_windows,
            fits: m.fits,
        }),
    };
    FreeMotionJson {
        noise_source: match f.noise {
            NoiseFigures::Configured => "configured",
            NoiseFigures::Measured(_) => "measured in the rests",
        },
        noise_gyro_deg_h: f.noise_gyro_deg_h,
        noise_accel_m_s2: f.noise_accel_m_s2,
        motion_attitude_noise_deg: f.motion_attitude_noise_deg,
        rest_error_m_s2: f.rest_error_m_s2,
        rest_error_unasked_p_value: f.rest_error_unasked.map(|e| e.p_value),
        rest_excess_m_s2: f.rest_excess_m_s2.map(|(x, _)| x),
        rest_excess_dof: f.rest_excess_m_s2.map(|(_, d)| d),
        measured,
        gravity_m_s2: f.gravity_m_s2,
        static_intervals: f.static_intervals,
        held_out_every: f.holdout,
        grade: f.grade.map(|g| GradeJson {
            grade: g.grade.name(),
            by_noise: g.by_noise.name(),
            by_rest_rate: g.by_rest_rate.name(),
            rest_rate_excess_deg_h: g.rest_rate_excess_deg_h,
        }),
        terms: f.terms.clone(),
        turns: f
            .turns
            .iter()
            .map(|t| TurnJson {
                name: t.name.clone(),
                expected_deg: t.expected_deg,
                before_deg: t.before_deg,
                after_deg: t.after_deg,
            })
            .collect(),
        validation: f.validation.map(|v| ValidationJson {
            static_rms_m_s2: before_after(v.static_rms_m_s2),
            rotation_rms_deg: before_after(v.rotation_rms_deg),
            intervals: v.intervals,
            rotation_pairs: v.rotation_pairs,
            earth_rate_compensated: v.earth_rate_floor_deg.is_none(),
            earth_rate_floor_deg: v.earth_rate_floor_deg,
            fitted_static_rms_m_s2: v.fitted_static_rms_m_s2,
            fitted_intervals: v.fitted_intervals,
            held_out_motion_rms_deg: v.held_out_motion_rms_deg,
            held_out_motions: v.held_out_motions,
            fitted_motion_rms_deg: v.fitted_motion_rms_deg,
            fitted_motions: v.fitted_motions,
            baseline: v
                .baseline_static_rms_m_s2
                .map(|(held_out, fitted)| BaselineJson {
                    held_out_static_rms_m_s2: held_out,
                    fitted_static_rms_m_s2: fitted,
                }),
        }),
    }
}
