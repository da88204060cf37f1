//! PNG plots of the diagnostics of a fit (`calib::check::diagnostics`): per measurement kind the
//! whitened innovations against time, their periodograms with the program's lines, their
//! autocorrelations with the white-noise band, and the NIS per program segment against its
//! band. An optional second fit ("after", e.g. with an extended model) is overlaid in another
//! colour (NIS per segment: side by side).

use crate::Error;
use calib::check::diagnostics::{Diagnostics, Innovation, KindDiagnostics, kind_label, whiten};
use calib::model::MeasurementKind;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

const BEFORE: RGBColor = RGBColor(31, 119, 180);
const AFTER: RGBColor = RGBColor(255, 127, 14);
const BAND: RGBColor = RGBColor(120, 120, 120);
const AXES: [&str; 3] = ["x", "y", "z"];
const FAILS: RGBColor = RGBColor(214, 39, 40);
/// Title font size (px): the titles fit an 800-pixel-wide plot.
const TITLE_SIZE: u32 = 18;

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
            crate::plot::write_png(&path, size, |root| f(root, kind, &fits))?;
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
    let root = root
        .titled(title, ("sans-serif", TITLE_SIZE))
        .map_err(|e| perr(&e))?;
    Ok(root.split_evenly((3, 1)))
}

fn innovations_plot(
    root: &Area<'_>,
    kind: MeasurementKind,
    fits: &[Fit<'_>],
) -> Result<(), String> {
    let panels = three_panels(
        root,
        &format!(
            "{}: whitened innovations L^-1 nu, lines at +-3{}",
            kind_label(kind),
            fits_note(fits)
        ),
    )?;
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
        let (_, y) = range(series.iter().flatten().map(|p| p.1[a]), true);
        let y = y.max(4.0);
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(t0..t1, -y..y)
            .map_err(|e| perr(&e))?;
        chart
            .configure_mesh()
            .y_label_formatter(&|v| crate::table::tick(*v))
            .x_label_formatter(&|v| crate::table::tick(*v))
            .x_desc("IMU time [s]")
            .y_desc(format!("axis {} [sigma]", AXES[a]))
            .label_style(("sans-serif", 13))
            .light_line_style(RGBColor(240, 240, 240))
            .draw()
            .map_err(|e| perr(&e))?;
        for (f, s) in fits.iter().zip(&series) {
            chart
                .draw_series(
                    s.iter()
                        .map(|p| Circle::new((p.0, p.1[a]), 1, f.colour.mix(0.6).filled())),
                )
                .map_err(|e| perr(&e))?;
        }
        for b in [-3.0, 3.0] {
            chart
                .draw_series(LineSeries::new([(t0, b), (t1, b)], BAND.stroke_width(1)))
                .map_err(|e| perr(&e))?;
        }
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

fn spectrum_plot(root: &Area<'_>, kind: MeasurementKind, fits: &[Fit<'_>]) -> Result<(), String> {
    let panels = three_panels(
        root,
        &format!(
            "{}: periodogram of whitened innovations; triangles: program lines, line: fail level{}",
            kind_label(kind),
            fits_note(fits)
        ),
    )?;
    let ks = kinds(fits, kind);
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
            .build_cartesian_2d((f0..f1).log_scale(), (1e-3..hi).log_scale())
            .map_err(|e| perr(&e))?;
        chart
            .configure_mesh()
            .y_label_formatter(&|v| crate::table::tick(*v))
            .x_label_formatter(&|v| crate::table::tick(*v))
            .x_desc("frequency [Hz]")
            .y_desc(format!("axis {} [power / white]", AXES[a]))
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

fn autocorrelation_plot(
    root: &Area<'_>,
    kind: MeasurementKind,
    fits: &[Fit<'_>],
) -> Result<(), String> {
    let panels = three_panels(
        root,
        &format!(
            "{}: autocorrelation of whitened innovations, lines: 95 % band{}",
            kind_label(kind),
            fits_note(fits)
        ),
    )?;
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
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .caption(
                format!("axis {}: Ljung-Box p = {}", AXES[a], ljung_box.join(", ")),
                ("sans-serif", 13),
            )
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..lags as f64 + 1.0, -y..y)
            .map_err(|e| perr(&e))?;
        chart
            .configure_mesh()
            .y_label_formatter(&|v| crate::table::tick(*v))
            .x_label_formatter(&|x| format!("{x:.0}"))
            .x_desc("lag [updates]")
            .y_desc(format!("axis {} [correlation]", AXES[a]))
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
    let root = root
        .titled(
            &format!(
                "{}: NIS / dof per segment, bars: band at the per-test level, red ring: fails{}",
                kind_label(kind),
                fits_note(fits)
            ),
            ("sans-serif", TITLE_SIZE),
        )
        .map_err(|e| perr(&e))?;
    let ks = kinds(fits, kind);
    let n_seg = ks
        .iter()
        .flat_map(|(_, k)| k.segments.iter().map(|s| s.segment + 1))
        .max()
        .unwrap_or(1);
    let vals = ks.iter().flat_map(|(_, k)| {
        k.segments
            .iter()
            .flat_map(|s| [s.nis.sum, s.nis.band.0, s.nis.band.1].map(|v| v / s.nis.dof.max(1.0)))
    });
    let (lo, hi) = range(vals.chain([1.0]), false);
    let mut chart = ChartBuilder::on(&root)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5..n_seg as f64 - 0.5, lo.min(0.9)..hi.max(1.1))
        .map_err(|e| perr(&e))?;
    chart
        .configure_mesh()
        .y_label_formatter(&|v| crate::table::tick(*v))
        .x_desc("segment number (names: report.md, or the diagnostics in the JSON)")
        .y_desc("NIS / dof [1 expected]")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .label_style(("sans-serif", 14))
        .light_line_style(RGBColor(240, 240, 240))
        .draw()
        .map_err(|e| perr(&e))?;
    chart
        .draw_series(LineSeries::new(
            [(-0.5, 1.0), (n_seg as f64 - 0.5, 1.0)],
            BAND.stroke_width(1),
        ))
        .map_err(|e| perr(&e))?;
    let m = ks.len().max(1) as f64;
    for (n, (f, k)) in ks.iter().enumerate() {
        let dx = if m > 1.0 { (n as f64 - 0.5) * 0.2 } else { 0.0 };
        let d = |s: &calib::check::diagnostics::SegmentNis| s.nis.dof.max(1.0);
        chart
            .draw_series(k.segments.iter().map(|s| {
                let x = s.segment as f64 + dx;
                PathElement::new(
                    [(x, s.nis.band.0 / d(s)), (x, s.nis.band.1 / d(s))],
                    f.colour.mix(0.5).stroke_width(3),
                )
            }))
            .map_err(|e| perr(&e))?;
        chart
            .draw_series(k.segments.iter().map(|s| {
                Circle::new(
                    (s.segment as f64 + dx, s.nis.sum / d(s)),
                    4,
                    f.colour.filled(),
                )
            }))
            .map_err(|e| perr(&e))?;
        let level = f.diag.per_test_level;
        chart
            .draw_series(
                k.segments
                    .iter()
                    .filter(|s| s.nis.p_value.is_nan() || s.nis.p_value < level)
                    .map(|s| {
                        Circle::new(
                            (s.segment as f64 + dx, s.nis.sum / d(s)),
                            8,
                            FAILS.stroke_width(2),
                        )
                    }),
            )
            .map_err(|e| perr(&e))?;
    }
    Ok(())
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
