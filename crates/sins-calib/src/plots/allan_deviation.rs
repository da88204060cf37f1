//! PNG plot of `sins-calib noise`: per gyro and accelerometer axis the measured Allan deviation
//! with its 68 % confidence band, the fitted terms and their sum (the points whose 95 % band the
//! sum leaves ringed, the start of the fitted range dashed), the maximum-likelihood model
//! (whose levels are the ones reported), and the configured noise
//! model; one legend for all panels, below them, so that it covers no data.

use crate::Error;
use crate::commands::noise::model::{SensorNoise, adev_units, configured};
use crate::plots::ensure_fonts;
use ::noise::fit::Term;
use calib::config::NoiseConfig;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

const MEASURED: RGBColor = RGBColor(31, 119, 180);
const SUM: RGBColor = RGBColor(214, 39, 40);
const CONFIG: RGBColor = RGBColor(0, 0, 0);
/// Points below the fitted range, and the range's start.
const BELOW_RANGE: RGBColor = RGBColor(127, 127, 127);
/// The maximum-likelihood model (the levels reported).
const ML: RGBColor = RGBColor(23, 190, 207);
/// Colours of the terms, `Term::ALL` order.
const TERM_COLOURS: [RGBColor; 5] = [
    RGBColor(148, 103, 189),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];
const TERM_LABELS: [&str; 5] = [
    "quantisation",
    "white noise",
    "bias instability",
    "bias random walk",
    "rate ramp",
];
const AXES: [&str; 3] = ["x", "y", "z"];

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

fn perr(e: &dyn std::fmt::Display) -> String {
    format!("plotting: {e}")
}

fn log_grid(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| a * (b / a).powf(i as f64 / (n - 1) as f64))
        .collect()
}

/// One axis: the measured deviation with its interval, the fitted terms, their sum and the
/// configured model (all in the report unit, `factor` times SI).
fn panel(
    area: &Area<'_>,
    title: &str,
    unit: &str,
    factor: f64,
    axis: &::noise::AxisNoise,
    // The likelihood model and its check against the measured deviation.
    (ml, band): (
        &::noise::likelihood::MlFit,
        &::noise::consistency::AxisCheck,
    ),
    config: Option<[(Term, f64); 2]>,
) -> Result<(), String> {
    let p = &axis.curve.points;
    // A failed Allan fit is no result: said in the title, its sum drawn for orientation only.
    let title = if axis.fit.passes() {
        title.to_string()
    } else {
        format!("{title} (Allan fit fails: sum dotted)")
    };
    // A walk the rests cannot tell, or the curve denies (`noise::floor::slow_terms`), is not
    // reported, pasted or drawn: the model is drawn without it, and the title says so.
    // Beside a floor the likelihood's walk, whose model has no floor, is not the walk: the
    // report gives the one fitted with the floor.
    let slow = ::noise::floor::slow_terms(&axis.curve, ml);
    let walk = slow.walk && slow.walk_beyond_floor.is_none();
    let title = if slow.walk_beyond_floor.is_some() {
        format!("{title} (walk: see the report)")
    } else if walk || ml.walk.value == 0.0 {
        title
    } else {
        format!("{title} (walk not determined)")
    };
    let (t0, t1) = (p[0].tau_s / 1.5, p[p.len() - 1].tau_s * 1.5);
    let curves = Curves::new(axis, (ml, walk), config, factor, log_grid(t0, t1, 120));
    let (lo, hi) = curves.range;
    let mut chart = ChartBuilder::on(area)
        .caption(&title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d((t0..t1).log_scale(), (lo..hi).log_scale())
        .map_err(|e| perr(&e))?;
    chart
        .configure_mesh()
        .x_desc("averaging time tau [s]")
        .y_desc(format!("Allan deviation [{unit}]"))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .light_line_style(RGBColor(240, 240, 240))
        .draw()
        .map_err(|e| perr(&e))?;
    curves.draw(&mut chart, &axis.fit)?;
    draw_measured(&mut chart, p, factor, (lo, hi))?;
    draw_misfits(&mut chart, axis, factor, (lo, hi))?;
    // The points where the likelihood model leaves its band (::noise::consistency): a square
    // in the model's colour round the measured point.
    chart
        .draw_series(band.outside().map(|x| {
            let y = x.measured * factor;
            Rectangle::new(
                [(x.tau_s / 1.18, y / 1.35), (x.tau_s * 1.18, y * 1.35)],
                ML.stroke_width(2),
            )
        }))
        .map_err(|e| perr(&e))?;
    Ok(())
}

type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// The model curves of a panel over a grid of averaging times (report unit), and the range of
/// deviations the panel shows: the measured points and every curve, with room around them.
struct Curves {
    grid: Vec<f64>,
    factor: f64,
    /// The Allan fit's sum, the maximum-likelihood model, the configured model.
    sum: Vec<(f64, f64)>,
    ml: Vec<(f64, f64)>,
    config: Option<Vec<(f64, f64)>>,
    range: (f64, f64),
}

impl Curves {
    /// `ml`: the likelihood's fit, and whether its walk is determined (drawn only then).
    fn new(
        axis: &::noise::AxisNoise,
        (ml, walk): (&::noise::likelihood::MlFit, bool),
        config: Option<[(Term, f64); 2]>,
        factor: f64,
        grid: Vec<f64>,
    ) -> Self {
        let fit = &axis.fit;
        let sum: Vec<(f64, f64)> = grid
            .iter()
            .map(|&t| (t, fit.avar(t).sqrt() * factor))
            .collect();
        let mut model = ml.model();
        if !walk {
            model.walk = 0.0;
        }
        let ml_curve: Vec<(f64, f64)> = grid
            .iter()
            .map(|&t| (t, model.avar(t).sqrt() * factor))
            .collect();
        let cfg: Option<Vec<(f64, f64)>> = config.map(|c| {
            grid.iter()
                .map(|&t| {
                    let v: f64 = c.iter().map(|(term, x)| term.avar(*x, t)).sum();
                    (t, v.sqrt() * factor)
                })
                .collect()
        });
        let mut lo = f64::INFINITY;
        let mut hi: f64 = 0.0;
        for x in &axis.curve.points {
            lo = lo.min(x.lower * factor).min(x.adev * factor);
            hi = hi.max(x.upper.min(x.adev * 20.0) * factor);
        }
        for (_, v) in sum.iter().chain(&ml_curve).chain(cfg.iter().flatten()) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        Self {
            grid,
            factor,
            sum,
            ml: ml_curve,
            config: cfg,
            range: (lo / 2.0, hi * 2.0),
        }
    }

    /// Every term of the Allan fit (dashed, where inside the range), their sum, the
    /// maximum-likelihood model and the configured model.
    fn draw(self, chart: &mut Chart<'_, '_>, fit: &::noise::fit::NoiseFit) -> Result<(), String> {
        let (lo, hi) = self.range;
        for (j, e) in fit.terms.iter().enumerate() {
            if !e.included {
                continue;
            }
            let pts: Vec<(f64, f64)> = self
                .grid
                .iter()
                .map(|&t| (t, e.term.avar(e.value, t).sqrt() * self.factor))
                .filter(|(_, v)| *v >= lo && *v <= hi)
                .collect();
            chart
                .draw_series(DashedLineSeries::new(
                    pts,
                    6,
                    4,
                    TERM_COLOURS[j].stroke_width(2),
                ))
                .map_err(|e| perr(&e))?;
        }
        if fit.passes() {
            chart
                .draw_series(LineSeries::new(self.sum, SUM.stroke_width(2)))
                .map_err(|e| perr(&e))?;
        } else {
            chart
                .draw_series(DashedLineSeries::new(self.sum, 3, 5, SUM.stroke_width(1)))
                .map_err(|e| perr(&e))?;
        }
        chart
            .draw_series(LineSeries::new(self.ml, ML.stroke_width(3)))
            .map_err(|e| perr(&e))?;
        if let Some(c) = self.config {
            chart
                .draw_series(DashedLineSeries::new(c, 10, 5, CONFIG.stroke_width(2)))
                .map_err(|e| perr(&e))?;
        }
        Ok(())
    }
}

/// The measured deviation: its 68 % confidence band, then each point's interval and the point
/// over it (clipped to the range `lo .. hi`).
fn draw_measured(
    chart: &mut Chart<'_, '_>,
    p: &[::noise::allan::AllanPoint],
    factor: f64,
    (lo, hi): (f64, f64),
) -> Result<(), String> {
    let band: Vec<(f64, f64)> = p
        .iter()
        .map(|x| (x.tau_s, (x.upper * factor).min(hi)))
        .chain(
            p.iter()
                .rev()
                .map(|x| (x.tau_s, (x.lower * factor).max(lo))),
        )
        .collect();
    chart
        .draw_series(std::iter::once(Polygon::new(
            band,
            MEASURED.mix(0.18).filled(),
        )))
        .map_err(|e| perr(&e))?;
    chart
        .draw_series(p.iter().map(|x| {
            PathElement::new(
                [
                    (x.tau_s, (x.lower * factor).max(lo)),
                    (x.tau_s, (x.upper * factor).min(hi)),
                ],
                MEASURED.stroke_width(2),
            )
        }))
        .map_err(|e| perr(&e))?;
    chart
        .draw_series(
            p.iter()
                .map(|x| Circle::new((x.tau_s, x.adev * factor), 4, MEASURED.filled())),
        )
        .map_err(|e| perr(&e))?;
    Ok(())
}

/// The misfit made visible: a ring round every point whose 95 % band the fitted sum leaves
/// (red where fitted, grey below the fitted range), and the fitted range's start.
fn draw_misfits(
    chart: &mut Chart<'_, '_>,
    axis: &::noise::AxisNoise,
    factor: f64,
    (lo, hi): (f64, f64),
) -> Result<(), String> {
    let (p, fit) = (&axis.curve.points, &axis.fit);
    let misses: Vec<(f64, bool)> = p
        .iter()
        .filter_map(|x| {
            fit.misfits
                .iter()
                .find(|m| x.tau_s >= m.from_tau_s * 0.999 && x.tau_s <= m.to_tau_s * 1.001)
                .map(|m| (x.tau_s, m.fitted))
        })
        .collect();
    chart
        .draw_series(misses.iter().filter_map(|&(t, fitted)| {
            let x = p.iter().find(|x| x.tau_s == t)?;
            let c = if fitted { SUM } else { BELOW_RANGE };
            Some(Circle::new((t, x.adev * factor), 9, c.stroke_width(2)))
        }))
        .map_err(|e| perr(&e))?;
    if fit.tau_min_s > p[0].tau_s {
        let t = fit.tau_min_s / 2f64.sqrt();
        chart
            .draw_series(DashedLineSeries::new(
                [(t, lo), (t, hi)],
                4,
                4,
                BELOW_RANGE.stroke_width(1),
            ))
            .map_err(|e| perr(&e))?;
    }
    Ok(())
}

/// A legend's dashed-line mark in colour `c`, starting at `(x, y)`.
fn dashed_mark(a: &Area<'_>, (x, y): (i32, i32), c: RGBColor) -> Result<(), String> {
    a.draw(&PathElement::new([(x, y), (x + 10, y)], c.stroke_width(2)))
        .map_err(|e| perr(&e))?;
    a.draw(&PathElement::new(
        [(x + 16, y), (x + 26, y)],
        c.stroke_width(2),
    ))
    .map_err(|e| perr(&e))
}

/// The legend strip: measured with interval, the Allan fit's sum, the maximum-likelihood model,
/// configured, and the terms.
fn legend(area: &Area<'_>, with_config: bool) -> Result<(), String> {
    let font = ("sans-serif", 15).into_font().color(&BLACK);
    // Two rows: the entries run on into the second where the first is full (one row cut the
    // last terms off at the image's edge).
    let rows = area.split_evenly((2, 1));
    let width = area.dim_in_pixel().0 as i32;
    let (mut x, mut row) = (20, 0usize);
    let y = 22;
    let mut entry = |_: &Area<'_>,
                     draw: &dyn Fn(&Area<'_>, i32) -> Result<(), String>,
                     text: &str|
     -> Result<(), String> {
        let step = 44 + 8 * text.len() as i32;
        if x + step > width && row + 1 < rows.len() {
            row += 1;
            x = 20;
        }
        let area = &rows[row];
        draw(area, x)?;
        area.draw(&Text::new(text.to_string(), (x + 34, y - 8), font.clone()))
            .map_err(|e| perr(&e))?;
        x += step;
        Ok(())
    };
    entry(
        area,
        &|a, x| {
            a.draw(&PathElement::new(
                [(x + 12, y - 9), (x + 12, y + 9)],
                MEASURED.stroke_width(2),
            ))
            .map_err(|e| perr(&e))?;
            a.draw(&Circle::new((x + 12, y), 4, MEASURED.filled()))
                .map_err(|e| perr(&e))
        },
        "measured, 68 % band",
    )?;
    entry(
        area,
        &|a, x| {
            a.draw(&PathElement::new(
                [(x, y), (x + 26, y)],
                SUM.stroke_width(2),
            ))
            .map_err(|e| perr(&e))
        },
        "Allan fit (sum)",
    )?;
    entry(
        area,
        &|a, x| {
            a.draw(&Circle::new((x + 12, y), 8, SUM.stroke_width(2)))
                .map_err(|e| perr(&e))
        },
        "sum outside 95 %",
    )?;
    entry(
        area,
        &|a, x| {
            a.draw(&Circle::new((x + 12, y), 8, BELOW_RANGE.stroke_width(2)))
                .map_err(|e| perr(&e))
        },
        "not fitted (left of dashes)",
    )?;
    entry(
        area,
        &|a, x| {
            a.draw(&PathElement::new([(x, y), (x + 26, y)], ML.stroke_width(3)))
                .map_err(|e| perr(&e))
        },
        "max. likelihood",
    )?;
    entry(
        area,
        &|a, x| {
            a.draw(&Rectangle::new(
                [(x + 4, y - 8), (x + 20, y + 8)],
                ML.stroke_width(2),
            ))
            .map_err(|e| perr(&e))
        },
        "max. likelihood outside band",
    )?;
    if with_config {
        entry(
            area,
            &|a, x| dashed_mark(a, (x, y), CONFIG),
            "configured [noise]",
        )?;
    }
    for (c, label) in TERM_COLOURS.iter().zip(TERM_LABELS) {
        let c = *c;
        entry(area, &move |a, x| dashed_mark(a, (x, y), c), label)?;
    }
    Ok(())
}

/// Write the Allan deviation plot of both sensors (two rows of three axes) to a PNG file.
pub fn allan_png(
    path: &Path,
    name: &str,
    sensors: &[SensorNoise],
    band: &::noise::consistency::FamilyCheck,
    config: Option<&NoiseConfig>,
) -> Result<(), Error> {
    ensure_fonts()?;
    let err = |e: &dyn std::fmt::Display| format!("{}: plotting: {e}", path.display());
    let root = BitMapBackend::new(path, (1500, 1000)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (top, rest) = root.split_vertically(40);
    let (body, bottom) = rest.split_vertically(870);
    // `bottom`: 90 px, two legend rows.
    top.draw(&Text::new(
        format!(
            "{name}: overlapping Allan deviation at rest, fitted noise terms, maximum-likelihood model"
        ),
        (20, 10),
        ("sans-serif", 22).into_font().color(&BLACK),
    ))
    .map_err(|e| err(&e))?;
    let panels = body.split_evenly((2, 3));
    for (row, ((sensor, unit, factor), sn)) in adev_units().into_iter().zip(sensors).enumerate() {
        let cfg = config.map(|c| configured(c, row == 0));
        for (a, ax) in sn.axes.iter().enumerate() {
            panel(
                &panels[row * 3 + a],
                &format!("{sensor} {}", AXES[a]),
                unit,
                factor,
                ax,
                (&sn.ml[a], &band.axes[row * 3 + a]),
                cfg,
            )
            .map_err(|e| err(&e))?;
        }
    }
    legend(&bottom, config.is_some()).map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
