//! The figures of the report a laboratory files with a calibration (`sins-calib calibrate
//! --report`, `sins-calib diagnose --report`), computed here so that the command-line program
//! only prints and draws them:
//!
//! - [`parameter_rows`]: every parameter in its report unit with its 1-sigma (scale factors in
//!   ppm), and against a truth its true value and error in sigmas;
//! - [`segment_rows`]: the NIS of every program segment (or rest) with its name and time span;
//! - [`residuals`]: the innovations in physical units with their 1-sigma from `S`;
//! - [`correlation`] and [`strongest_correlations`]: the posterior correlation of the
//!   parameters.

use crate::check::diagnostics::{Diagnostics, Innovation, Segment};
use crate::estimate::Estimate;
use crate::io::ResultFile;
use crate::model::MeasurementKind;
use crate::model::layout::StateLayout;
use sins_model::terms::STANDARD_GRAVITY;
use sins_model::units::ARCSEC;

/// One parameter of the report, in its report unit.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterRow {
    /// Documented name, e.g. `gyro.theta.xx`.
    pub name: String,
    /// Report unit, e.g. `ppm`, `deg/h`, `arcmin`.
    pub unit: &'static str,
    /// Estimate (report unit).
    pub value: f64,
    /// Posterior 1-sigma (report unit).
    pub sigma: f64,
    /// The true value (report unit), when a truth names the parameter.
    pub truth: Option<f64>,
    /// `(estimate - truth) / sigma`, when a truth names the parameter.
    pub error_sigmas: Option<f64>,
}

/// The parameters of an estimate (the attitude errors left out), in state order, in their
/// report units; with a truth, its value and the error in sigmas.
pub fn parameter_rows(est: &Estimate, truth: Option<&ResultFile>) -> Vec<ParameterRow> {
    (StateLayout::INSTRUMENT..est.names.len())
        .map(|i| {
            let unit = est.units[i];
            let f = unit.report_factor();
            let sigma = est.cov[(i, i)].max(0.0).sqrt();
            let true_value = truth.and_then(|t| t.get(&est.names[i])).map(|p| p.value);
            ParameterRow {
                name: est.names[i].clone(),
                unit: unit.report_name(),
                value: est.values[i] * f,
                sigma: sigma * f,
                truth: true_value.map(|t| t * f),
                error_sigmas: true_value.map(|t| (est.values[i] - t) / sigma),
            }
        })
        .collect()
}

/// An estimate against a truth (a simulation's `truth.json`, or another result file).
#[derive(Clone, Debug, PartialEq)]
pub struct TruthComparison {
    /// Parameters the truth names (the attitude errors left out).
    pub parameters: usize,
    /// The NEES over them, on their joint covariance (`None`: it is not positive definite).
    pub nees: Option<f64>,
    /// Sum of the squared errors in sigmas (the NEES on the diagonal alone).
    pub sum_squared_sigmas: f64,
    /// The largest error: its parameter and its size in sigmas.
    pub largest: (String, f64),
}

/// `est` against `truth` over the parameters the truth names (`None`: it names none).
pub fn truth_comparison(est: &Estimate, truth: &ResultFile) -> Option<TruthComparison> {
    let idx: Vec<usize> = (0..est.names.len())
        .filter(|&i| !est.names[i].starts_with("attitude.") && truth.get(&est.names[i]).is_some())
        .collect();
    let n = idx.len();
    if n == 0 {
        return None;
    }
    let sigma: Vec<f64> = idx
        .iter()
        .map(|&i| est.cov[(i, i)].max(0.0).sqrt())
        .collect();
    let errors: Vec<f64> = idx
        .iter()
        .map(|&i| est.values[i] - truth.get(&est.names[i]).map_or(f64::NAN, |p| p.value))
        .collect();
    let z: Vec<f64> = errors.iter().zip(&sigma).map(|(e, s)| e / s).collect();
    let (worst, worst_z) = z
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map_or((0, f64::NAN), |(k, v)| (idx[k], *v));
    let cov = nalgebra::DMatrix::from_fn(n, n, |a, b| est.cov[(idx[a], idx[b])]);
    Some(TruthComparison {
        parameters: n,
        nees: crate::check::stats::nees(&errors, &cov).filter(|x| x.is_finite()),
        sum_squared_sigmas: z.iter().map(|v| v * v).sum(),
        largest: (est.names[worst].clone(), worst_z),
    })
}

/// The NIS of one segment of one measurement kind.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentRow {
    /// Which measurement.
    pub kind: MeasurementKind,
    /// Segment index (as in the plots).
    pub segment: usize,
    /// Its name: the program piece (`cycle 2, rotation about y, +`, `dwell`) or the rest
    /// (`rest 3`, `motion 3-4`).
    pub label: String,
    /// Its span on the IMU clock (s), when the segment list has it.
    pub span_s: Option<(f64, f64)>,
    /// Updates in it.
    pub updates: usize,
    /// NIS sum over its degrees of freedom (1 expected).
    pub nis_per_dof: f64,
    /// The band of `nis_per_dof` at the verdict's per-test level.
    pub band_per_dof: (f64, f64),
    /// Two-sided p-value of the NIS sum.
    pub p_value: f64,
    /// Whether its test fails at the per-test level (as in the verdict).
    pub fails: bool,
}

/// Every segment's NIS of every measurement kind, kinds in the diagnostics' order, segments in
/// time order.
pub fn segment_rows(d: &Diagnostics, segments: &[Segment]) -> Vec<SegmentRow> {
    d.kinds
        .iter()
        .flat_map(|k| {
            k.segments.iter().map(move |s| {
                let dof = s.nis.dof.max(1.0);
                SegmentRow {
                    kind: k.kind,
                    segment: s.segment,
                    label: s.label.clone(),
                    span_s: segments.get(s.segment).map(|g| (g.t0, g.t1)),
                    updates: s.nis.updates,
                    nis_per_dof: s.nis.sum / dof,
                    band_per_dof: (s.nis.band.0 / dof, s.nis.band.1 / dof),
                    p_value: s.nis.p_value,
                    fails: s.nis.p_value.is_nan() || s.nis.p_value < d.per_test_level,
                }
            })
        })
        .collect()
}

/// The unit residuals of a measurement kind are shown in: its name and the factor from SI.
/// Specific force in micro-g (1 ug = 9.80665e-6 m/s^2), turntable angles in arcsec.
pub fn residual_unit(kind: MeasurementKind) -> (&'static str, f64) {
    match kind {
        MeasurementKind::Accel => ("ug", 1e6 / STANDARD_GRAVITY),
        MeasurementKind::Turntable => ("arcsec", 1.0 / ARCSEC),
    }
}

/// One innovation in physical units ([`residual_unit`]), East, North and Up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residual {
    /// IMU time (s).
    pub t: f64,
    /// The innovation `z - H x` per axis.
    pub value: [f64; 3],
    /// Its 1-sigma under the model, `sqrt(S_ii)`.
    pub sigma: [f64; 3],
    /// The segment it belongs to.
    pub segment: usize,
}

/// The innovations of one kind in physical units with their 1-sigma, in update order; updates
/// with a value that is not finite (or a negative variance) are left out.
pub fn residuals(innovations: &[Innovation], kind: MeasurementKind) -> Vec<Residual> {
    let (_, f) = residual_unit(kind);
    innovations
        .iter()
        .filter(|i| i.kind == kind)
        .filter_map(|i| {
            let value = [i.nu[0] * f, i.nu[1] * f, i.nu[2] * f];
            let var = [i.s[(0, 0)], i.s[(1, 1)], i.s[(2, 2)]];
            let ok = i.t.is_finite()
                && value.iter().all(|v| v.is_finite())
                && var.iter().all(|v| v.is_finite() && *v >= 0.0);
            ok.then(|| Residual {
                t: i.t,
                value,
                sigma: var.map(|v| v.sqrt() * f),
                segment: i.segment,
            })
        })
        .collect()
}

/// The parameters' names and their posterior correlation matrix (attitude errors left out),
/// as the result file holds it ([`crate::io::posterior::correlation`]).
pub fn correlation(est: &Estimate) -> (Vec<String>, Vec<Vec<f64>>) {
    let range = StateLayout::INSTRUMENT..est.names.len();
    let names = est.names[range.clone()].to_vec();
    let r = crate::io::posterior::correlation(est.names.len(), range, |i, j| est.cov[(i, j)]);
    (names, r)
}

/// The `count` largest correlations in magnitude (pairs above the diagonal), largest first.
pub fn strongest_correlations(
    names: &[String],
    r: &[Vec<f64>],
    count: usize,
) -> Vec<(String, String, f64)> {
    let mut pairs: Vec<(usize, usize, f64)> = (0..r.len())
        .flat_map(|i| (i + 1..r.len()).map(move |j| (i, j)))
        .map(|(i, j)| (i, j, r[i][j]))
        .filter(|p| p.2.is_finite())
        .collect();
    pairs.sort_by(|a, b| b.2.abs().total_cmp(&a.2.abs()));
    pairs
        .into_iter()
        .take(count)
        .map(|(i, j, c)| (names[i].clone(), names[j].clone(), c))
        .collect()
}

/// Correlations listed in a report ([`Figures::strongest`]).
pub const STRONGEST_CORRELATIONS: usize = 8;

/// A calibration's figures in their report units, computed once here for every output that
/// shows them (the printout, the JSON result, the laboratory report).
#[derive(Clone, Debug)]
pub struct Figures {
    /// The parameters in their report units, with a truth's values.
    pub parameters: Vec<ParameterRow>,
    /// Against a truth, when one was given and names an estimated parameter.
    pub truth: Option<TruthComparison>,
    /// The parameters in SI with their correlation, the correction and the temperature: the
    /// result file.
    pub result: ResultFile,
    /// The mean NIS of each measurement against its band.
    pub mean_nis: Vec<crate::estimate::verdict::MeanNis>,
    /// The known turns measured: updates, mean NIS, half-width of its band about 1
    /// ([`crate::estimate::verdict::known_turn_figures`]).
    pub known_turns: Option<(usize, f64, f64)>,
    /// Parameters the data leave at their prior, with their posterior over prior sigma.
    pub unobserved: Vec<(String, f64)>,
    /// The parameters' posterior correlation (names, matrix).
    pub correlation: (Vec<String>, Vec<Vec<f64>>),
    /// Its [`STRONGEST_CORRELATIONS`] strongest pairs.
    pub strongest: Vec<(String, String, f64)>,
    /// The NIS of every segment of every measurement.
    pub segments: Vec<SegmentRow>,
}

impl Figures {
    /// The figures of the calibration `c`, against `truth` where one is given.
    pub fn of(c: &crate::estimate::calibration::Calibration, truth: Option<&ResultFile>) -> Self {
        let est = &c.estimate;
        // The result file holds the parameters' correlation ([`correlation`]'s): taken from
        // it rather than computed twice.
        let result = c.result_file();
        let names: Vec<String> = result.parameters.iter().map(|p| p.name.clone()).collect();
        let correlation = (names, result.correlation.clone().unwrap_or_default());
        let strongest =
            strongest_correlations(&correlation.0, &correlation.1, STRONGEST_CORRELATIONS);
        Self {
            parameters: parameter_rows(est, truth),
            truth: truth.and_then(|t| truth_comparison(est, t)),
            result,
            mean_nis: crate::estimate::verdict::mean_nis_figures(&est.stats, est.with_turntable()),
            known_turns: crate::estimate::verdict::known_turn_figures(&est.stats),
            unobserved: est.unobserved(),
            correlation,
            strongest,
            segments: segment_rows(&c.diagnostics, &est.segments),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::diagnostics::{DiagnosticSettings, diagnose};
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn residuals_are_in_physical_units_with_their_sigma() {
        let g = 9.80665e-6; // 1 ug
        let i = Innovation {
            t: 1.0,
            kind: MeasurementKind::Accel,
            nu: Vector3::new(2.0 * g, -g, 0.0),
            s: Matrix3::from_diagonal(&Vector3::new((3.0 * g).powi(2), (4.0 * g).powi(2), g * g)),
            segment: 2,
            held_out: false,
            c_body_to_enu: None,
        };
        let mut bad = i;
        bad.nu[1] = f64::NAN;
        let mut tt = i;
        tt.kind = MeasurementKind::Turntable;
        tt.nu = Vector3::new(ARCSEC, 0.0, 0.0);
        let r = residuals(&[i, bad, tt], MeasurementKind::Accel);
        assert_eq!(r.len(), 1);
        for (a, b) in r[0].value.iter().zip([2.0, -1.0, 0.0]) {
            assert!((a - b).abs() < 1e-9, "{:?}", r[0]);
        }
        for (a, b) in r[0].sigma.iter().zip([3.0, 4.0, 1.0]) {
            assert!((a - b).abs() < 1e-9, "{:?}", r[0]);
        }
        let r = residuals(&[i, tt], MeasurementKind::Turntable);
        assert!((r[0].value[0] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn segment_rows_carry_names_and_fail_as_the_verdict_does() {
        // Segment 1 scatters three times as much as the model says.
        let innov: Vec<Innovation> = (0..600)
            .map(|k| {
                let seg = k / 300;
                let x = ((k as f64) * 0.7).sin() * if seg == 1 { 3.0 } else { 1.2 };
                Innovation {
                    t: k as f64,
                    kind: MeasurementKind::Accel,
                    nu: Vector3::new(x, -x, 0.5 * x),
                    s: Matrix3::identity(),
                    segment: seg,
                    held_out: false,
                    c_body_to_enu: None,
                }
            })
            .collect();
        let segments: Vec<Segment> = (0..2)
            .map(|k| Segment {
                levels_start: false,
                index: k,
                cycle: None,
                label: format!("rest {}", k + 1),
                t0: 300.0 * k as f64,
                t1: 300.0 * (k + 1) as f64,
                rotation_hz: 0.0,
            })
            .collect();
        let d = diagnose(&innov, &segments, &DiagnosticSettings::default());
        let rows = segment_rows(&d, &segments);
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].label, "rest 2");
        assert_eq!(rows[1].span_s, Some((300.0, 600.0)));
        assert!(rows[1].fails && rows[1].nis_per_dof > 2.0, "{:?}", rows[1]);
        let failing_names: Vec<&str> = d
            .tests
            .iter()
            .filter(|t| t.fails)
            .map(|t| t.name.as_str())
            .collect();
        assert!(
            failing_names
                .iter()
                .any(|n| n.contains("segment 1 (rest 2)")),
            "{failing_names:?}"
        );
    }

    #[test]
    fn strongest_correlations_come_first() {
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let r = vec![
            vec![1.0, 0.2, -0.9],
            vec![0.2, 1.0, 0.5],
            vec![-0.9, 0.5, 1.0],
        ];
        let s = strongest_correlations(&names, &r, 2);
        assert_eq!(s[0], ("a".into(), "c".into(), -0.9));
        assert_eq!(s[1], ("b".into(), "c".into(), 0.5));
    }
}
