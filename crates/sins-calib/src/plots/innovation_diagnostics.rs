//! PNG plots of the diagnostics of a fit (`calib::check::diagnostics`): per measurement kind the
//! whitened innovations against time, their periodograms with the program's lines, their
//! autocorrelations with the white-noise band, and the NIS per program segment against its
//! band. An optional second fit ("after", e.g. with an extended model) is overlaid in another
//! colour (NIS per segment: side by side).

use crate::Error;
use crate::plots::{
    beyond, beyond_note, count_tick, linear_ticks, log_key_points, log_tick, off_axis,
    robust_limit, titled,
};
use calib::check::diagnostics::{Diagnostics, Innovation, KindDiagnostics, kind_label, whiten};
use calib::model::MeasurementKind;
use plotters::coord::Shift;
use plotters::coord::combinators::{LogCoord, WithKeyPoints};
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const BEFORE: RGBColor = RGBColor(31, 119, 180);
const AFTER: RGBColor = RGBColor(255, 127, 14);
const BAND: RGBColor = RGBColor(120, 120, 120);
/// The axes of the innovations of both kinds: the local geographic frame (ENU), named as in the
/// report's residual plots.
const AXES: [&str; 3] = ["East", "North", "Up"];
const FAILS: RGBColor = RGBColor(214, 39, 40);
/// Title font size (px), smaller or wrapped where a title does not fit the width.
const TITLE_SIZE: f64 = 18.0;

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// One fit to plot: its diagnostics, innovations, colour and name.
struct Fit<'a> {
    diag: &'a Diagnostics,
    innov: &'a [Innovation],
    colour: RGBColor,
    name: &'static str,
}

fn perr(e: &dyn std::fmt::Display) -> String {
    format!("plotting: {e}")
}

/// The plots of [`write_plots`], by file-name stem.
pub const PLOTS: [&str; 4] = ["innovations", "spectrum", "autocorrelation", "nis_segments"];

/// Every file [`write_diagnostic_plots`] may write (`<stem>_<kind>.png`): `--diagnostics` is
/// written as `--report` is, into a temporary directory swapped in whole
/// ([`crate::output::DirOutput`]), so a refused or interrupted run leaves no plot behind.
pub const NAMES: [&str; 8] = [
    "innovations_accel.png",
    "spectrum_accel.png",
    "autocorrelation_accel.png",
    "nis_segments_accel.png",
    "innovations_turntable.png",
    "spectrum_turntable.png",
    "autocorrelation_turntable.png",
    "nis_segments_turntable.png",
];

/// Write the diagnostic plots of a fit into the directory `dir` whole (see [`NAMES`]);
/// returns the number of plots.
pub fn write_diagnostics_dir(
    dir: &Path,
    diagnostics: &Diagnostics,
    innovations: &[Innovation],
) -> Result<usize, Error> {
    let out = crate::output::DirOutput::begin(dir, &NAMES)?;
    let files = write_diagnostic_plots(out.tmp_dir(), diagnostics, innovations, None)?;
    if let Some(f) = files
        .iter()
        .find(|f| !NAMES.iter().any(|n| f.file_name().is_some_and(|x| x == *n)))
    {
        return Err(format!("{}: not one of the diagnostic plots' names", f.display()).into());
    }
    out.commit()?;
    Ok(files.len())
}

/// Write the diagnostic plots of a fit (and of a second one, `after`) into `dir`: per kind
/// `innovations_<kind>.png`, `spectrum_<kind>.png`, `autocorrelation_<kind>.png`,
/// `nis_segments_<kind>.png`. Returns the files written.
pub fn write_diagnostic_plots(
    dir: &Path,
    before: &Diagnostics,
    innov_before: &[Innovation],
    after: Option<(&Diagnostics, &[Innovation])>,
) -> Result<Vec<PathBuf>, Error> {
    write_plots(dir, &PLOTS, (1100, 900), before, innov_before, after)
}

/// Write the plots named in `which` (stems of [`PLOTS`]) of each measurement kind, `size`
/// pixels each, into `dir`; returns the files written.
pub fn write_plots(
    dir: &Path,
    which: &[&str],
    size: (u32, u32),
    before: &Diagnostics,
    innov_before: &[Innovation],
    after: Option<(&Diagnostics, &[Innovation])>,
) -> Result<Vec<PathBuf>, Error> {
    if !dir.is_dir() {
        return Err(format!("{}: not a directory", dir.display()).into());
    }
    let mut fits = vec![Fit {
        diag: before,
        innov: innov_before,
        colour: BEFORE,
        name: if after.is_some() {
            "paper's model"
        } else {
            "fit"
        },
    }];
    if let Some((diag, innov)) = after {
        fits.push(Fit {
            diag,
            innov,
            colour: AFTER,
            name: "extended model",
        });
    }
    let mut written = vec![];
    for kind in [MeasurementKind::Accel, MeasurementKind::Turntable] {
        if fits.iter().all(|f| f.diag.kind(kind).is_none()) {
            continue;
        }
        let tag = calib::check::diagnostics::kind_serde::name(kind);
        let plots: [(&str, PlotFn); 4] = [
            ("innovations", innovations_plot),
            ("spectrum", spectrum_plot),
            ("autocorrelation", autocorrelation_plot),
            ("nis_segments", nis_plot),
        ];
        for (what, f) in plots.into_iter().filter(|(w, _)| which.contains(w)) {
            let path = dir.join(format!("{what}_{tag}.png"));
            crate::plots::write_png(&path, size, |root| f(root, kind, &fits))?;
            written.push(path);
        }
    }
    Ok(written)
}

type PlotFn = fn(&Area<'_>, MeasurementKind, &[Fit<'_>]) -> Result<(), String>;

/// A finite range around `values` (symmetric about 0 when `symmetric`).
fn range(values: impl Iterator<Item = f64>, symmetric: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return (-1.0, 1.0);
    }
    if symmetric {
        let m = lo.abs().max(hi.abs()).max(1e-12) * 1.05;
        return (-m, m);
    }
    if hi - lo < 1e-12 {
        return (lo - 1.0, hi + 1.0);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

fn three_panels<'a>(root: &Area<'a>, title: &str) -> Result<Vec<Area<'a>>, String> {
    Ok(titled(root, title, TITLE_SIZE)?.split_evenly((3, 1)))
}

/// The title of the innovations' panels, after the measurement kind.
const INNOVATIONS_TITLE: &str = "whitened innovations L^-1 nu, lines at +-3";
/// The title of the autocorrelations' panels, after the measurement kind.
const AUTOCORRELATION_TITLE: &str = "autocorrelation of whitened innovations, lines: 95 % band";

/// [`three_panels`] titled `<kind>: <what><the fits' note>`.
fn kind_panels<'a>(
    root: &Area<'a>,
    kind: MeasurementKind,
    fits: &[Fit<'_>],
    what: &str,
) -> Result<Vec<Area<'a>>, String> {
    let title = format!("{}: {what}{}", kind_label(kind), fits_note(fits));
    three_panels(root, &title)
}

fn innovations_plot(
    root: &Area<'_>,
    kind: MeasurementKind,
    fits: &[Fit<'_>],
) -> Result<(), String> {
    let panels = kind_panels(root, kind, fits, INNOVATIONS_TITLE)?;
    let series: Vec<Vec<(f64, [f64; 3])>> = fits
        .iter()
        .map(|f| {
            f.innov
                .iter()
                .filter(|i| i.kind == kind)
                .filter_map(|i| whiten(i).map(|w| (i.t, [w[0], w[1], w[2]])))
                .collect()
        })
        .collect();
    let (t0, t1) = range(series.iter().flatten().map(|p| p.0), false);
    for (a, panel) in panels.iter().enumerate() {
        // At least 4 sigma; a few outliers beyond the 99th percentile of the magnitudes (with
        // half as much again) are marked at the edge instead of stretching the axis.
        let values = || series.iter().flatten().map(|p| p.1[a]);
        let y = robust_limit(values(), 0.99, 1.5, 4.0);
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(t0..t1, -y..y)
            .map_err(|e| perr(&e))?;
        chart
            .configure_mesh()
            .y_label_formatter(&linear_ticks(-y, y))
            .x_label_formatter(&linear_ticks(t0, t1))
            .x_desc("IMU time [s]")
            .y_desc(format!("{} [sigma]", AXES[a]))
            .label_style(("sans-serif", 13))
            .light_line_style(RGBColor(240, 240, 240))
            .draw()
            .map_err(|e| perr(&e))?;
        for (f, s) in fits.iter().zip(&series) {
            let on_axis = s.iter().filter(|p| p.1[a].abs() <= y);
            chart
                .draw_series(
                    on_axis.map(|p| Circle::new((p.0, p.1[a]), 1, f.colour.mix(0.6).filled())),
                )
                .map_err(|e| perr(&e))?;
            chart
                .draw_series(s.iter().filter(|p| p.1[a].abs() > y).map(|p| {
                    EmptyElement::at((p.0, 0.985 * y.copysign(p.1[a]))) + off_axis(p.1[a] > 0.0)
                }))
                .map_err(|e| perr(&e))?;
        }
        for b in [-3.0, 3.0] {
            chart
                .draw_series(LineSeries::new([(t0, b), (t1, b)], BAND.stroke_width(1)))
                .map_err(|e| perr(&e))?;
        }
        beyond_note(panel, beyond(values(), y), 13.0)?;
    }
    Ok(())
}

/// With two fits, which colour is which (for a title); nothing with one.
fn fits_note(fits: &[Fit<'_>]) -> String {
    if fits.len() < 2 {
        return String::new();
    }
    let names: Vec<String> = fits
        .iter()
        .map(|f| format!("{}: {}", colour_name(f.colour), f.name))
        .collect();
    format!("; {}", names.join(", "))
}

fn colour_name(c: RGBColor) -> &'static str {
    if c == BEFORE { "blue" } else { "orange" }
}

fn kinds<'a>(
    fits: &'a [Fit<'a>],
    kind: MeasurementKind,
) -> Vec<(&'a Fit<'a>, &'a KindDiagnostics)> {
    fits.iter()
        .filter_map(|f| f.diag.kind(kind).map(|k| (f, k)))
        .collect()
}

/// The title of [`spectrum_plot`]: the program's lines named where they are drawn.
fn spectrum_title(kind: MeasurementKind, has_lines: bool, fits: &[Fit<'_>]) -> String {
    format!(
        "{}: periodogram of whitened innovations; {}line: fail level{}",
        kind_label(kind),
        if has_lines {
            "triangles: program lines, "
        } else {
            ""
        },
        fits_note(fits)
    )
}

fn spectrum_plot(root: &Area<'_>, kind: MeasurementKind, fits: &[Fit<'_>]) -> Result<(), String> {
    let ks = kinds(fits, kind);
    // The program's lines are drawn (and named) only where there are some: a recording of
    // rests has no program.
    let has_lines = ks
        .iter()
        .any(|(_, k)| k.lines.iter().any(|l| l.frequency_hz > 0.0));
    let panels = three_panels(root, &spectrum_title(kind, has_lines, fits))?;
    let freqs = ks
        .iter()
        .flat_map(|(_, k)| k.spectrum.frequency_hz.iter().copied())
        .filter(|f| f.is_finite() && *f > 0.0);
    let (f0, f1) = freqs.fold((f64::INFINITY, 0.0f64), |(a, b), f| (a.min(f), b.max(f)));
    let f0 = if f0.is_finite() { f0 } else { 1e-3 };
    let f1 = f1.max(f0 * 10.0);
    for (a, panel) in panels.iter().enumerate() {
        let powers = ks.iter().flat_map(|(_, k)| {
            k.spectrum
                .power
                .iter()
                .map(move |p| p[a])
                .chain(k.lines.iter().map(move |l| l.power[a]))
        });
        let hi = powers.filter(|p| p.is_finite()).fold(30.0f64, f64::max) * 1.5;
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(log_axis(f0, f1), log_axis(1e-3, hi))
            .map_err(|e| perr(&e))?;
        chart
            .configure_mesh()
            .y_label_formatter(&log_tick)
            .x_label_formatter(&log_tick)
            .x_desc("frequency [Hz]")
            .y_desc(format!("{} [power / white]", AXES[a]))
            .label_style(("sans-serif", 13))
            .light_line_style(RGBColor(240, 240, 240))
            .draw()
            .map_err(|e| perr(&e))?;
        for (f, k) in &ks {
            let pts: Vec<(f64, f64)> = k
                .spectrum
                .frequency_hz
                .iter()
                .zip(&k.spectrum.power)
                .map(|(fr, p)| (*fr, p[a].max(1e-3)))
                .collect();
            chart
                .draw_series(LineSeries::new(pts, f.colour.stroke_width(1)))
                .map_err(|e| perr(&e))?;
            chart
                .draw_series(k.lines.iter().filter(|l| l.frequency_hz > 0.0).map(|l| {
                    TriangleMarker::new(
                        (l.frequency_hz, l.power[a].max(1e-3)),
                        6,
                        f.colour.filled(),
                    )
                }))
                .map_err(|e| perr(&e))?;
            // The level a line must pass to fail at the verdict's per-test level (2 dof:
            // P(Q / 2 > x) = exp(-x)).
            let level = -f.diag.per_test_level.ln();
            chart
                .draw_series(LineSeries::new(
                    [(f0, level), (f1, level)],
                    f.colour.mix(0.5).stroke_width(1),
                ))
                .map_err(|e| perr(&e))?;
        }
    }
    Ok(())
}

/// A logarithmic axis from `lo` to `hi` with the ticks of [`log_key_points`].
fn log_axis(lo: f64, hi: f64) -> WithKeyPoints<LogCoord<f64>> {
    let (bold, light) = log_key_points(lo, hi);
    (lo..hi)
        .log_scale()
        .with_key_points(bold)
        .with_light_points(light)
}

fn autocorrelation_plot(
    root: &Area<'_>,
    kind: MeasurementKind,
    fits: &[Fit<'_>],
) -> Result<(), String> {
    let panels = kind_panels(root, kind, fits, AUTOCORRELATION_TITLE)?;
    let ks = kinds(fits, kind);
    let lags = ks
        .iter()
        .flat_map(|(_, k)| k.whiteness.iter().map(|w| w.autocorrelation.len()))
        .max()
        .unwrap_or(1)
        .max(1);
    for (a, panel) in panels.iter().enumerate() {
        let vals = ks.iter().flat_map(|(_, k)| {
            k.whiteness
                .get(a)
                .into_iter()
                .flat_map(|w| w.autocorrelation.iter().copied().chain([w.band_95]))
        });
        let (_, y) = range(vals, true);
        let ljung_box: Vec<String> = ks
            .iter()
            .filter_map(|(f, k)| {
                let w = k.whiteness.get(a)?;
                let p = calib::check::stats::p_value_text(w.p_value);
                Some(if fits.len() > 1 {
                    format!("{p} ({})", f.name)
                } else {
                    p
                })
            })
            .collect();
        let panel = titled(
            panel,
            &format!("{}: Ljung-Box p = {}", AXES[a], ljung_box.join(", ")),
            13.0,
        )?;
        let mut chart = ChartBuilder::on(&panel)
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..lags as f64 + 1.0, -y..y)
            .map_err(|e| perr(&e))?;
        chart
            .configure_mesh()
            .y_label_formatter(&linear_ticks(-y, y))
            .x_label_formatter(&count_tick)
            .x_desc("lag [updates]")
            .y_desc(format!("{} [correlation]", AXES[a]))
            .label_style(("sans-serif", 13))
            .light_line_style(RGBColor(240, 240, 240))
            .draw()
            .map_err(|e| perr(&e))?;
        for (n, (f, k)) in ks.iter().enumerate() {
            let Some(w) = k.whiteness.get(a) else {
                continue;
            };
            let dx = 0.15 * n as f64;
            chart
                .draw_series(w.autocorrelation.iter().enumerate().map(|(i, r)| {
                    let x = (i + 1) as f64 + dx;
                    PathElement::new([(x, 0.0), (x, *r)], f.colour.stroke_width(2))
                }))
                .map_err(|e| perr(&e))?;
            for b in [-w.band_95, w.band_95] {
                chart
                    .draw_series(LineSeries::new(
                        [(0.0, b), (lags as f64 + 1.0, b)],
                        f.colour.mix(0.5).stroke_width(1),
                    ))
                    .map_err(|e| perr(&e))?;
            }
        }
    }
    Ok(())
}

fn nis_plot(root: &Area<'_>, kind: MeasurementKind, fits: &[Fit<'_>]) -> Result<(), String> {
    let root = titled(
        root,
        &format!(
            "{}: NIS / dof per segment, bars: band at the per-test level, red ring: fails{}",
            kind_label(kind),
            fits_note(fits)
        ),
        TITLE_SIZE,
    )?;
    let ks = kinds(fits, kind);
    let at = nis_times(&ks, kind)?;
    let mid = |s: &calib::check::diagnostics::SegmentNis| at[&s.segment];
    let xs = ks.iter().flat_map(|(_, k)| k.segments.iter().map(mid));
    let (x0, x1) = range(xs, false);
    let vals = ks.iter().flat_map(|(_, k)| {
        k.segments
            .iter()
            .flat_map(|s| [s.nis.sum, s.nis.band.0, s.nis.band.1].map(|v| v / s.nis.dof.max(1.0)))
    });
    let (lo, hi) = range(vals.chain([1.0]), false);
    let (lo, hi) = (lo.min(0.9), hi.max(1.1));
    let mut chart = ChartBuilder::on(&root)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, lo..hi)
        .map_err(|e| perr(&e))?;
    chart
        .configure_mesh()
        .y_label_formatter(&linear_ticks(lo, hi))
        .x_desc(
            "time on the IMU clock [s], midway between each segment's first and last update \
             (segment names: report.md, or the diagnostics in the JSON)",
        )
        .y_desc("NIS / dof [1 expected]")
        .x_label_formatter(&linear_ticks(x0, x1))
        .label_style(("sans-serif", 14))
        .light_line_style(RGBColor(240, 240, 240))
        .draw()
        .map_err(|e| perr(&e))?;
    chart
        .draw_series(LineSeries::new(
            [(x0, 1.0), (x1, 1.0)],
            BAND.stroke_width(1),
        ))
        .map_err(|e| perr(&e))?;
    let m = ks.len().max(1) as f64;
    for (n, (f, k)) in ks.iter().enumerate() {
        // Two fits side by side, a little apart.
        let dx = if m > 1.0 {
            (n as f64 - 0.5) * 0.004 * (x1 - x0)
        } else {
            0.0
        };
        let d = |s: &calib::check::diagnostics::SegmentNis| s.nis.dof.max(1.0);
        let points: Vec<_> = k.segments.iter().map(|s| (mid(s) + dx, s)).collect();
        chart
            .draw_series(points.iter().map(|&(x, s)| {
                PathElement::new(
                    [(x, s.nis.band.0 / d(s)), (x, s.nis.band.1 / d(s))],
                    f.colour.mix(0.5).stroke_width(3),
                )
            }))
            .map_err(|e| perr(&e))?;
        chart
            .draw_series(
                points
                    .iter()
                    .map(|&(x, s)| Circle::new((x, s.nis.sum / d(s)), 4, f.colour.filled())),
            )
            .map_err(|e| perr(&e))?;
        let level = f.diag.per_test_level;
        chart
            .draw_series(
                points
                    .iter()
                    .filter(|(_, s)| s.nis.p_value.is_nan() || s.nis.p_value < level)
                    .map(|&(x, s)| Circle::new((x, s.nis.sum / d(s)), 8, FAILS.stroke_width(2))),
            )
            .map_err(|e| perr(&e))?;
    }
    Ok(())
}

/// The time of every segment with a NIS in `ks` ([`segment_times`]): the first fit's, or the
/// second's where only it has the segment (the same segments and times when both are of one
/// recording).
fn nis_times(
    ks: &[(&Fit<'_>, &KindDiagnostics)],
    kind: MeasurementKind,
) -> Result<BTreeMap<usize, f64>, String> {
    let mut at = BTreeMap::new();
    for (f, _) in ks.iter().rev() {
        at.extend(segment_times(f.innov, kind));
    }
    for (_, k) in ks {
        if let Some(s) = k.segments.iter().find(|s| !at.contains_key(&s.segment)) {
            return Err(format!(
                "plotting: segment {} has a NIS but no update of its kind",
                s.segment
            ));
        }
    }
    Ok(at)
}

/// Each segment's time on the IMU clock (s) in the NIS plot: midway between its first and
/// last update of `kind`.
fn segment_times(innov: &[Innovation], kind: MeasurementKind) -> BTreeMap<usize, f64> {
    let mut span: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    for i in innov.iter().filter(|i| i.kind == kind && i.t.is_finite()) {
        let e = span.entry(i.segment).or_insert((i.t, i.t));
        e.0 = e.0.min(i.t);
        e.1 = e.1.max(i.t);
    }
    span.into_iter()
        .map(|(k, (a, b))| (k, 0.5 * (a + b)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib::check::diagnostics::{DiagnosticSettings, diagnose};
    use nalgebra::{Matrix3, Vector3};

    fn innovations(scale: f64) -> Vec<Innovation> {
        (0..400)
            .map(|k| {
                let x = (k as f64 * 0.37).sin() * scale;
                Innovation {
                    t: 0.5 * k as f64,
                    kind: if k % 2 == 0 {
                        MeasurementKind::Accel
                    } else {
                        MeasurementKind::Turntable
                    },
                    nu: Vector3::new(x, -0.5 * x, 0.3),
                    s: Matrix3::identity(),
                    segment: k / 100,
                    held_out: false,
                    c_body_to_enu: None,
                }
            })
            .collect()
    }

    #[test]
    fn nis_segments_sit_midway_between_their_first_and_last_update_of_the_kind() {
        let a = innovations(1.0);
        // Specific force: even k, t = 0.5 k; segment 0 holds k = 0..=98, segment 3 k = 300..=398.
        let accel = segment_times(&a, MeasurementKind::Accel);
        assert_eq!(accel.len(), 4);
        assert_eq!(accel[&0], 0.5 * (0.0 + 49.0));
        assert_eq!(accel[&3], 0.5 * (150.0 + 199.0));
        // Turntable angles: odd k; segment 1 holds k = 101..=199.
        let angles = segment_times(&a, MeasurementKind::Turntable);
        assert_eq!(angles[&1], 0.5 * (50.5 + 99.5));
    }

    #[test]
    fn program_lines_are_named_only_where_there_are_some() {
        let a = innovations(1.0);
        let settings = DiagnosticSettings::default();
        let d = diagnose(&a, &[], &settings);
        let fits = [Fit {
            diag: &d,
            innov: &a,
            colour: BEFORE,
            name: "fit",
        }];
        let kind = MeasurementKind::Accel;
        // No program (a hand-turned recording): no lines drawn, none named.
        let k = fits[0].diag.kind(kind).unwrap();
        assert!(k.lines.iter().all(|l| l.frequency_hz <= 0.0));
        let title = spectrum_title(kind, false, &fits);
        assert!(!title.contains("triangles"), "{title}");
        assert!(title.contains("line: fail level"));
        assert!(spectrum_title(kind, true, &fits).contains("triangles: program lines"));
    }

    #[test]
    fn before_and_after_are_plotted_and_bad_directories_refused() {
        let dir =
            std::env::temp_dir().join(format!("sins-calib-diag-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (innovations(1.0), innovations(2.0));
        let settings = DiagnosticSettings::default();
        let (da, db) = (diagnose(&a, &[], &settings), diagnose(&b, &[], &settings));
        let files = write_diagnostic_plots(&dir, &da, &a, Some((&db, &b))).unwrap();
        assert_eq!(files.len(), 8);
        assert!(files.iter().all(|f| f.metadata().unwrap().len() > 1000));
        // Nothing to plot: no files; a missing directory: an error, not a panic.
        let empty = diagnose(&[], &[], &settings);
        assert!(
            write_diagnostic_plots(&dir, &empty, &[], None)
                .unwrap()
                .is_empty()
        );
        assert!(write_diagnostic_plots(&dir.join("missing"), &da, &a, None).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
