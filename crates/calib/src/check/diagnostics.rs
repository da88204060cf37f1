//! Diagnostics of a fit from its innovations (docs/estimation.md, "Diagnostics").
//!
//! The estimation logs every update of the reported pass ([`Innovation`]: time, kind,
//! innovation `nu`, its covariance `S`, program segment). Under the model the whitened
//! innovations `L^-1 nu` (`S = L L^T`) are independent standard normal vectors, and every
//! statistic here has a known distribution:
//!
//! - NIS sums over the whole fit and per program segment: chi-square with 3 per update;
//! - whiteness: the autocorrelation of each whitened axis in update order, and its Ljung-Box
//!   statistic: chi-square with as many degrees of freedom as lags;
//! - lines: the periodogram of each whitened axis at the program's frequencies (cycle and
//!   segment periods, rotation rates, their harmonics) and at frequency 0 (the mean),
//!   chi-square with 2 (1) degrees of freedom ([`spectrum`]);
//! - the log-likelihood of the innovations.
//!
//! [`diagnose`] makes every test and gives a verdict at a family-wise level with a Bonferroni
//! correction; [`regression_test`] tests candidate regressors (unmodelled terms).

use crate::check::stats::p_value_text;
use crate::model::MeasurementKind;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use statrs::distribution::{ChiSquared, ContinuousCDF};

mod regression;
mod segments;
pub mod spectrum;
mod whiteness;

pub use regression::{RegressionTest, regression_test};
pub use segments::{Segment, assign_segments, segment_of, segments};
pub use whiteness::{autocorrelation, ljung_box};

/// One measurement update of the filter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Innovation {
    /// IMU time of the update (s).
    pub t: f64,
    /// Which measurement.
    #[serde(with = "kind_serde")]
    pub kind: MeasurementKind,
    /// Innovation `nu = z - H x_prior` (m/s^2 or rad).
    pub nu: Vector3<f64>,
    /// Innovation covariance `S = H P_prior H^T + R`.
    pub s: Matrix3<f64>,
    /// Index of the program segment holding `t` ([`segments`], [`segment_of`]).
    pub segment: usize,
    /// A held-out measurement (`filter.hold_out_every`): predicted from the data before it,
    /// not used.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub held_out: bool,
    /// The computed attitude (body to ENU) at the update, where the fit records it: what turns
    /// a specific-force residual into the instrument's axes (the report's residuals against
    /// temperature). Not in files.
    #[serde(skip)]
    pub c_body_to_enu: Option<nalgebra::Matrix3<f64>>,
}

/// Serde for [`MeasurementKind`] (which lives in `model`, free of serde): `"accel"`,
/// `"turntable"`.
pub mod kind_serde {
    use crate::model::MeasurementKind;
    use serde::{Deserialize, Deserializer, Serializer};

    /// The name of a kind in files.
    pub fn name(kind: MeasurementKind) -> &'static str {
        match kind {
            MeasurementKind::Accel => "accel",
            MeasurementKind::Turntable => "turntable",
        }
    }

    /// Serialize as its name.
    pub fn serialize<S: Serializer>(kind: &MeasurementKind, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(name(*kind))
    }

    /// Deserialize from its name.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<MeasurementKind, D::Error> {
        let text = String::deserialize(d)?;
        match text.as_str() {
            "accel" => Ok(MeasurementKind::Accel),
            "turntable" => Ok(MeasurementKind::Turntable),
            other => Err(serde::de::Error::custom(format!(
                "unknown measurement kind `{other}`: expected `accel` or `turntable`"
            ))),
        }
    }
}

/// Human name of a measurement kind.
pub fn kind_label(kind: MeasurementKind) -> &'static str {
    match kind {
        MeasurementKind::Accel => "specific force",
        MeasurementKind::Turntable => "turntable angles",
    }
}

/// Errors of the diagnostics.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiagnosticsError {
    /// No regressor column given.
    #[error("regression test: expected at least one regressor column")]
    NoRegressors,
    /// A regressor column does not have one entry per innovation.
    #[error(
        "regression test: regressor column {column} has {len} rows, expected {expected} (one per innovation)"
    )]
    LengthMismatch {
        /// Column index.
        column: usize,
        /// Its length.
        len: usize,
        /// The number of innovations.
        expected: usize,
    },
    /// A regressor entry is not finite.
    #[error("regression test: a regressor is not finite at innovation {row}")]
    NonFiniteRegressor {
        /// Innovation index.
        row: usize,
    },
    /// No innovation has a positive definite covariance.
    #[error("regression test: no innovation with a positive definite covariance")]
    NoUsableInnovations,
    /// The normal matrix is singular (regressors linearly dependent or zero).
    #[error(
        "regression test: the regressors are linearly dependent (or zero) over these innovations"
    )]
    Singular,
}

/// Settings of [`diagnose`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticSettings {
    /// Family-wise level of the verdict (default 0.01).
    pub alpha: f64,
    /// Lags of the autocorrelation and the Ljung-Box test (default 20).
    pub max_lag: usize,
    /// Harmonics of each program frequency tested (default 3).
    pub harmonics: usize,
    /// Most program frequencies tested per kind (default 48, lowest-priority ones dropped).
    pub max_lines: usize,
    /// Frequencies of the periodogram kept for plots (default 200, log-spaced).
    pub spectrum_points: usize,
}

impl Default for DiagnosticSettings {
    fn default() -> Self {
        Self {
            alpha: 0.01,
            max_lag: 20,
            harmonics: 3,
            max_lines: 48,
            spectrum_points: 200,
        }
    }
}

/// One statistical test and its outcome.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TestResult {
    /// What was tested, e.g. `"specific force: Ljung-Box, axis x"`.
    pub name: String,
    /// The statistic.
    pub statistic: f64,
    /// Degrees of freedom of its chi-square distribution under the model.
    pub dof: f64,
    /// p-value (two-sided for NIS sums, upper tail otherwise).
    pub p_value: f64,
    /// Whether it is below the per-test level (`alpha / tests`).
    pub fails: bool,
}

/// A NIS sum against its chi-square distribution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NisTest {
    /// Updates summed.
    pub updates: usize,
    /// Sum of the NIS.
    pub sum: f64,
    /// Degrees of freedom (3 per update).
    pub dof: f64,
    /// Two-sided band at the per-test level of the verdict (`alpha / tests`).
    pub band: (f64, f64),
    /// Two-sided p-value, `2 min(F, 1 - F)`.
    pub p_value: f64,
}

/// The NIS of one program segment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentNis {
    /// Segment index.
    pub segment: usize,
    /// Segment label.
    pub label: String,
    /// The test.
    pub nis: NisTest,
}

/// Whiteness of one whitened axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AxisWhiteness {
    /// Autocorrelation at lags 1, 2, ... (update order).
    pub autocorrelation: Vec<f64>,
    /// The 95 % band of one autocorrelation of white noise, `1.96 / sqrt(N)`.
    pub band_95: f64,
    /// Ljung-Box statistic.
    pub ljung_box: f64,
    /// Its degrees of freedom (the lags).
    pub dof: usize,
    /// Its p-value.
    pub p_value: f64,
}

/// A periodogram line at a program frequency.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpectralLine {
    /// Frequency (Hz; 0 = the mean).
    pub frequency_hz: f64,
    /// Where the frequency comes from, e.g. `"cycle 1 period (900 s), harmonic 2"`.
    pub source: String,
    /// `Q / dof` of each whitened axis (the periodogram ordinate; 1 on average under the
    /// model).
    pub power: [f64; 3],
    /// Degrees of freedom of `Q` (2; 1 at frequency 0).
    pub dof: usize,
    /// p-value of each axis.
    pub p_value: [f64; 3],
}

/// The periodogram of the whitened axes on a frequency grid (for plots).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// Frequencies (Hz).
    pub frequency_hz: Vec<f64>,
    /// Ordinate of each axis at each frequency (`Q / 2`: exponential with mean 1 under the
    /// model).
    pub power: Vec<[f64; 3]>,
}

/// The diagnostics of one measurement kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KindDiagnostics {
    /// Which measurement.
    #[serde(with = "kind_serde")]
    pub kind: MeasurementKind,
    /// Updates with a usable (finite, positive definite) innovation covariance.
    pub updates: usize,
    /// Updates left out (innovation or covariance not finite, covariance not positive
    /// definite).
    pub unusable: usize,
    /// Median interval between updates (s).
    pub update_interval_s: f64,
    /// The NIS of the whole fit.
    pub nis: NisTest,
    /// The NIS of each segment with updates.
    pub segments: Vec<SegmentNis>,
    /// Whiteness of each whitened axis.
    pub whiteness: Vec<AxisWhiteness>,
    /// Lines at the mean and the program's frequencies.
    pub lines: Vec<SpectralLine>,
    /// The periodogram on a grid.
    pub spectrum: Spectrum,
    /// Log-likelihood of this kind's innovations.
    pub log_likelihood: f64,
}

/// Diagnostics of a fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// The settings used.
    pub settings: DiagnosticSettings,
    /// Per measurement kind.
    pub kinds: Vec<KindDiagnostics>,
    /// `-1/2 sum (nu^T S^-1 nu + ln det S + m ln 2 pi)` over all usable updates.
    pub log_likelihood: f64,
    /// Every test made.
    pub tests: Vec<TestResult>,
    /// The per-test level, `alpha / tests.len()` (Bonferroni).
    pub per_test_level: f64,
    /// No test fails at the per-test level: the model fits at the family-wise level `alpha`.
    pub fits: bool,
    /// The failing tests, one line each.
    pub failures: Vec<String>,
}

/// The lower Cholesky factor of `S` (symmetrised), if finite and positive definite.
pub(crate) fn whitening_factor(s: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if !s.iter().all(|v| v.is_finite()) {
        return None;
    }
    let sym = (s + s.transpose()) * 0.5;
    let l = sym.cholesky()?.l();
    (0..3).all(|i| l[(i, i)] > 0.0).then_some(l)
}

/// The whitened innovation `L^-1 nu` (`S = L L^T`): independent standard normal components
/// under the model. `None` when `S` is not positive definite or a value is not finite.
pub fn whiten(innov: &Innovation) -> Option<Vector3<f64>> {
    let l = whitening_factor(&innov.s)?;
    l.solve_lower_triangular(&innov.nu)
        .filter(|w| w.iter().all(|v| v.is_finite()))
}

/// The whitened innovations of one kind in update order, with their log-likelihood terms.
struct Series {
    t: Vec<f64>,
    w: Vec<[f64; 3]>,
    segment: Vec<usize>,
    log_lik: f64,
    unusable: usize,
}

fn series(innov: &[Innovation], kind: MeasurementKind) -> Series {
    let mut out = Series {
        t: vec![],
        w: vec![],
        segment: vec![],
        log_lik: 0.0,
        unusable: 0,
    };
    let ln_2pi = (2.0 * std::f64::consts::PI).ln();
    for i in innov.iter().filter(|i| i.kind == kind) {
        let Some(l) = whitening_factor(&i.s) else {
            out.unusable += 1;
            continue;
        };
        let w = l.solve_lower_triangular(&i.nu);
        match w {
            Some(w) if w.iter().all(|v| v.is_finite()) && i.t.is_finite() => {
                let log_det: f64 = (0..3).map(|k| 2.0 * l[(k, k)].ln()).sum();
                out.log_lik -= 0.5 * (w.norm_squared() + log_det + 3.0 * ln_2pi);
                out.t.push(i.t);
                out.w.push([w[0], w[1], w[2]]);
                out.segment.push(i.segment);
            }
            _ => out.unusable += 1,
        }
    }
    out
}

/// Two-sided p-value of a chi-square statistic.
fn two_sided(q: f64, dof: f64) -> f64 {
    ChiSquared::new(dof).map_or(f64::NAN, |d| (2.0 * d.cdf(q).min(d.sf(q))).min(1.0))
}

fn nis_test(w: &[[f64; 3]]) -> NisTest {
    let sum: f64 = w
        .iter()
        .map(|v| v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        .sum();
    let dof = 3.0 * w.len() as f64;
    NisTest {
        updates: w.len(),
        sum,
        dof,
        band: (f64::NAN, f64::NAN),
        p_value: two_sided(sum, dof),
    }
}

/// Candidate frequencies (Hz) with their sources, from the program's structure: each cycle's
/// period, each rotation segment's duration and rotation frequency, with harmonics; merged
/// where equal, in that order of priority.
fn program_frequencies(segments: &[Segment], settings: &DiagnosticSettings) -> Vec<(f64, String)> {
    let mut base: Vec<(f64, String)> = vec![];
    let mut cycles: Vec<(usize, f64, f64)> = vec![];
    for s in segments {
        if let Some(c) = s.cycle {
            match cycles.iter_mut().find(|e| e.0 == c) {
                Some(e) => e.2 = s.t1,
                None => cycles.push((c, s.t0, s.t1)),
            }
        }
    }
    for (c, t0, t1) in &cycles {
        base.push((
            1.0 / (t1 - t0),
            format!("cycle {c} period ({:.4} s)", t1 - t0),
        ));
    }
    for s in segments.iter().filter(|s| s.rotation_hz > 0.0) {
        base.push((
            1.0 / s.duration(),
            format!("segment {} duration ({:.4} s)", s.index, s.duration()),
        ));
    }
    for s in segments.iter().filter(|s| s.rotation_hz > 0.0) {
        base.push((
            s.rotation_hz,
            format!(
                "rotation rate of segment {} ({:.4} Hz)",
                s.index, s.rotation_hz
            ),
        ));
    }
    let mut out: Vec<(f64, String)> = vec![];
    for h in 1..=settings.harmonics.max(1) {
        for (f, src) in &base {
            let fh = f * h as f64;
            if !(fh.is_finite() && fh > 0.0) {
                continue;
            }
            if out.iter().any(|(g, _)| (g - fh).abs() <= 1e-6 * fh) {
                continue;
            }
            let label = if h == 1 {
                src.clone()
            } else {
                format!("{src}, harmonic {h}")
            };
            out.push((fh, label));
        }
    }
    out
}

/// Diagnose one kind; the tests are collected in `tests` (fails decided by the caller).
fn diagnose_kind(
    innov: &[Innovation],
    kind: MeasurementKind,
    segments: &[Segment],
    settings: &DiagnosticSettings,
    tests: &mut Vec<TestResult>,
) -> Option<KindDiagnostics> {
    let s = series(innov, kind);
    if s.w.is_empty() && s.unusable == 0 {
        return None;
    }
    let name = kind_label(kind);
    let mut test = |what: String, statistic: f64, dof: f64, p_value: f64| {
        tests.push(TestResult {
            name: format!("{name}: {what}"),
            statistic,
            dof,
            p_value,
            fails: false,
        });
    };
    let nis = nis_test(&s.w);
    if nis.updates > 0 {
        test("NIS sum".into(), nis.sum, nis.dof, nis.p_value);
    }
    let seg_nis = segment_nis(&s, segments, &mut test);
    let whiteness = whiteness_tests(&s, settings, &mut test);
    let dt = sins_model::timing::median_interval(&s.t);
    let lines = spectral_lines(&s, segments, settings, dt, &mut test);
    let spectrum = plotting_spectrum(&s, settings, dt);
    Some(KindDiagnostics {
        kind,
        updates: s.w.len(),
        unusable: s.unusable,
        update_interval_s: dt,
        nis,
        segments: seg_nis,
        whiteness,
        lines,
        spectrum,
        log_likelihood: s.log_lik,
    })
}

/// A test made: (what, statistic, dof, p-value).
type TestSink<'a> = dyn FnMut(String, f64, f64, f64) + 'a;

/// The NIS of each segment (the series is in time order, so each segment is contiguous or
/// nearly so).
fn segment_nis(s: &Series, segments: &[Segment], test: &mut TestSink) -> Vec<SegmentNis> {
    let mut seg_nis = vec![];
    let mut ids: Vec<usize> = s.segment.clone();
    ids.sort_unstable();
    ids.dedup();
    for id in ids {
        let w: Vec<[f64; 3]> =
            s.w.iter()
                .zip(&s.segment)
                .filter(|(_, g)| **g == id)
                .map(|(w, _)| *w)
                .collect();
        let label = segments
            .get(id)
            .map_or_else(|| format!("segment {id}"), |g| g.label.clone());
        let mut t = nis_test(&w);
        if segments.get(id).is_some_and(|g| g.levels_start) {
            t.p_value = ChiSquared::new(t.dof).map_or(f64::NAN, |d| d.sf(t.sum));
        }
        test(
            format!("NIS in segment {id} ({label})"),
            t.sum,
            t.dof,
            t.p_value,
        );
        seg_nis.push(SegmentNis {
            segment: id,
            label,
            nis: t,
        });
    }
    seg_nis
}

/// Autocorrelation and Ljung-Box test of each whitened axis.
fn whiteness_tests(
    s: &Series,
    settings: &DiagnosticSettings,
    test: &mut TestSink,
) -> Vec<AxisWhiteness> {
    let n = s.w.len();
    let mut whiteness = vec![];
    for (a, axis) in ["x", "y", "z"].iter().enumerate() {
        let x: Vec<f64> = s.w.iter().map(|w| w[a]).collect();
        let r = autocorrelation(&x, settings.max_lag);
        let (q, p) = ljung_box(&r, n);
        if !r.is_empty() {
            test(
                format!("Ljung-Box ({} lags), axis {axis}", r.len()),
                q,
                r.len() as f64,
                p,
            );
        }
        whiteness.push(AxisWhiteness {
            band_95: 1.96 / (n.max(1) as f64).sqrt(),
            dof: r.len(),
            autocorrelation: r,
            ljung_box: q,
            p_value: p,
        });
    }
    whiteness
}

/// The periodogram at the mean and the program's frequencies (below Nyquist), each tested
/// against white noise.
fn spectral_lines(
    s: &Series,
    segments: &[Segment],
    settings: &DiagnosticSettings,
    dt: f64,
    test: &mut TestSink,
) -> Vec<SpectralLine> {
    let nyquist = 0.5 / dt;
    let mut freqs = vec![(0.0, "mean".to_string())];
    freqs.extend(
        program_frequencies(segments, settings)
            .into_iter()
            .filter(|(f, _)| *f < nyquist * (1.0 - 1e-9))
            .take(settings.max_lines),
    );
    let mut lines = vec![];
    if s.w.len() < 2 {
        return lines;
    }
    for (f, source) in freqs {
        let o = spectrum::ordinate(&s.t, &s.w, f);
        if o.dof == 0 {
            continue;
        }
        let d = ChiSquared::new(o.dof as f64).ok();
        let p = o.q.map(|q| d.as_ref().map_or(f64::NAN, |d| d.sf(q)));
        for (a, axis) in ["x", "y", "z"].iter().enumerate() {
            test(
                format!("line at {f:.5} Hz ({source}), axis {axis}"),
                o.q[a],
                o.dof as f64,
                p[a],
            );
        }
        lines.push(SpectralLine {
            frequency_hz: f,
            source,
            power: o.q.map(|q| q / o.dof as f64),
            dof: o.dof,
            p_value: p,
        });
    }
    lines
}

/// The periodogram on a log grid from 1/span to Nyquist, for the plots (not tested).
fn plotting_spectrum(s: &Series, settings: &DiagnosticSettings, dt: f64) -> Spectrum {
    let span = match (s.t.first(), s.t.last()) {
        (Some(a), Some(b)) => b - a,
        _ => f64::NAN,
    };
    let grid = spectrum::log_grid(1.0 / span, 0.5 / dt, settings.spectrum_points);
    Spectrum {
        power: grid
            .iter()
            .map(|&f| {
                let o = spectrum::ordinate(&s.t, &s.w, f);
                o.q.map(|q| q / o.dof.max(1) as f64)
            })
            .collect(),
        frequency_hz: grid,
    }
}

/// The band that holds a chi-square(dof) variable with probability `1 - level`, two-sided.
fn band(dof: f64, level: f64) -> (f64, f64) {
    match ChiSquared::new(dof) {
        Ok(d) if level > 0.0 && level < 1.0 => {
            (d.inverse_cdf(0.5 * level), d.inverse_cdf(1.0 - 0.5 * level))
        }
        _ => (f64::NAN, f64::NAN),
    }
}

/// Every test of the innovations `innov` (in update order, with their segments), per
/// measurement kind, and the verdict at the family-wise level `settings.alpha` (Bonferroni
/// over all the tests made). Innovations whose covariance is not positive definite or whose
/// values are not finite are counted and left out; nothing here panics on bad input.
pub fn diagnose(
    innov: &[Innovation],
    segments: &[Segment],
    settings: &DiagnosticSettings,
) -> Diagnostics {
    let mut tests = vec![];
    let kinds: Vec<KindDiagnostics> = [MeasurementKind::Accel, MeasurementKind::Turntable]
        .into_iter()
        .filter_map(|k| diagnose_kind(innov, k, segments, settings, &mut tests))
        .collect();
    let alpha = if settings.alpha > 0.0 && settings.alpha < 1.0 {
        settings.alpha
    } else {
        0.01
    };
    let per_test_level = alpha / tests.len().max(1) as f64;
    let mut failures = vec![];
    for t in &mut tests {
        // A NaN p-value (nothing could be computed) is a failure too: the fit is not shown good.
        t.fails = t.p_value.is_nan() || t.p_value < per_test_level;
        if t.fails {
            failures.push(format!(
                "{}: statistic {:.4} ({} dof), p = {} < {}",
                t.name,
                t.statistic,
                t.dof,
                p_value_text(t.p_value),
                p_value_text(per_test_level)
            ));
        }
    }
    let mut kinds = kinds;
    for k in &mut kinds {
        k.nis.band = band(k.nis.dof, per_test_level);
        for s in &mut k.segments {
            s.nis.band = band(s.nis.dof, per_test_level);
        }
    }
    Diagnostics {
        settings: *settings,
        log_likelihood: kinds.iter().map(|k| k.log_likelihood).sum(),
        kinds,
        fits: failures.is_empty(),
        failures,
        tests,
        per_test_level,
    }
}

impl Diagnostics {
    /// The diagnostics of a kind, if it had updates.
    pub fn kind(&self, kind: MeasurementKind) -> Option<&KindDiagnostics> {
        self.kinds.iter().find(|k| k.kind == kind)
    }

    /// A short human-readable summary (a few lines per kind).
    pub fn summary(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        for k in &self.kinds {
            let name = kind_label(k.kind);
            let (lo, hi) = k.nis.band;
            let _ = writeln!(
                s,
                "  {name}: {} updates; NIS sum {:.1} for {} dof (band {:.1} .. {:.1}, p = {})",
                k.updates,
                k.nis.sum,
                k.nis.dof,
                lo,
                hi,
                p_value_text(k.nis.p_value)
            );
            let lb: Vec<String> = k
                .whiteness
                .iter()
                .zip(["x", "y", "z"])
                .map(|(w, a)| format!("{a} {:.1} (p = {})", w.ljung_box, p_value_text(w.p_value)))
                .collect();
            let _ = writeln!(
                s,
                "    Ljung-Box, {} lags: {}",
                self.settings.max_lag,
                lb.join(", ")
            );
            let worst_line = k
                .lines
                .iter()
                .flat_map(|l| (0..3).map(move |a| (l, a)))
                .min_by(|a, b| a.0.p_value[a.1].total_cmp(&b.0.p_value[b.1]));
            if let Some((l, a)) = worst_line {
                let _ = writeln!(
                    s,
                    "    strongest program line: {:.5} Hz ({}), axis {}, power {:.2} (p = {}) of {} lines",
                    l.frequency_hz,
                    l.source,
                    ["x", "y", "z"][a],
                    l.power[a],
                    p_value_text(l.p_value[a]),
                    k.lines.len()
                );
            }
            let worst_seg = k
                .segments
                .iter()
                .min_by(|a, b| a.nis.p_value.total_cmp(&b.nis.p_value));
            if let Some(g) = worst_seg {
                let _ = writeln!(
                    s,
                    "    least likely segment: {} ({}), NIS {:.1} for {} dof (p = {})",
                    g.segment,
                    g.label,
                    g.nis.sum,
                    g.nis.dof,
                    p_value_text(g.nis.p_value)
                );
            }
        }
        let _ = writeln!(s, "  log-likelihood {:.1}", self.log_likelihood);
        if self.fits {
            let _ = writeln!(
                s,
                "  tests: none fails ({} tests, family-wise level {} %, each at {}; the verdict below weighs them)",
                self.tests.len(),
                100.0 * self.settings.alpha,
                p_value_text(self.per_test_level)
            );
        } else {
            let _ = writeln!(
                s,
                "  tests: {} of {} fail (family-wise level {} %, each at {}; the verdict below weighs them)",
                self.failures.len(),
                self.tests.len(),
                100.0 * self.settings.alpha,
                p_value_text(self.per_test_level)
            );
            for f in self.failures.iter().take(10) {
                let _ = writeln!(s, "    {f}");
            }
            if self.failures.len() > 10 {
                let _ = writeln!(s, "    ... and {} more", self.failures.len() - 10);
            }
        }
        s
    }
}

/// Log-likelihood of innovations `nu ~ N(0, S)`, and the number of scalar innovations (the
/// held-out ones left out: [`held_out_log_density`]).
pub fn log_likelihood(innovations: &[Innovation]) -> (f64, usize) {
    log_density(innovations.iter().filter(|i| !i.held_out))
}

/// Summed log predictive density of the held-out innovations, and their number of scalar
/// innovations.
pub fn held_out_log_density(innovations: &[Innovation]) -> (f64, usize) {
    log_density(innovations.iter().filter(|i| i.held_out))
}

fn log_density<'a>(innovations: impl Iterator<Item = &'a Innovation>) -> (f64, usize) {
    let mut ll = 0.0;
    let mut m = 0;
    for inn in innovations {
        let Some(chol) = inn.s.cholesky() else {
            continue;
        };
        let y = chol.solve(&inn.nu);
        let log_det: f64 = 2.0 * chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
        ll -= 0.5 * (inn.nu.dot(&y) + log_det + 3.0 * (2.0 * std::f64::consts::PI).ln());
        m += 3;
    }
    (ll, m)
}

#[cfg(test)]
mod tests;
