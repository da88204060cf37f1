//! The plots of the filed report (`--report DIR`) beyond the diagnostics' own: the residuals of
//! each measurement in physical units with their noise band and the segments named by number,
//! and the posterior correlation matrix as a heat map.

use crate::Error;
use crate::plots::{
    beyond, beyond_note, linear_ticks, off_axis, robust_limit, titled, write_png, write_png_keeping,
};
use calib::check::diagnostics::{Segment, kind_label};
use calib::model::MeasurementKind;
use calib::report::lab::{Residual, residual_unit};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

const POINTS: RGBColor = RGBColor(31, 119, 180);
const BAND: RGBColor = RGBColor(150, 150, 150);
const SHADE: RGBColor = RGBColor(238, 238, 238);
const FAILING: RGBColor = RGBColor(250, 200, 200);
/// The axes of the innovations: the local geographic frame.
const ENU: [&str; 3] = ["East", "North", "Up"];

/// The mesh of a panel in the report's style: the axes' titles, linear ticks over `x` and `y`,
/// no light grid lines.
fn draw_mesh(
    chart: &mut ChartContext<'_, BitMapBackend<'_>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    (x_desc, y_desc): (&str, &str),
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Result<(), String> {
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&linear_ticks(x0, x1))
        .y_label_formatter(&linear_ticks(y0, y1))
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 13))
        .light_line_style(TRANSPARENT)
        .draw()
        .map_err(|e| e.to_string())
}

/// The `q`-quantile of the magnitudes of `values` (0 when empty).
fn quantile_abs(values: impl Iterator<Item = f64>, q: f64) -> f64 {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).map(f64::abs).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// The limit of the residual axis `axis`: from updates with a typical band (at most twice the
/// median sigma), the 98th percentile of their magnitudes with half as much again, at least
/// three median sigmas ([`robust_limit`]). A few outliers, and updates with a wider band (the
/// first of a fit, or after a motion between rests), go beyond it and are marked at its edge.
fn residual_limit(residuals: &[Residual], axis: usize) -> f64 {
    let typical_sigma = quantile_abs(residuals.iter().map(|r| r.sigma[axis]), 0.5);
    let typical = residuals
        .iter()
        .filter(|r| r.sigma[axis] <= 2.0 * typical_sigma)
        .map(|r| r.value[axis]);
    robust_limit(typical, 0.98, 1.5, 3.0 * typical_sigma)
}

/// What a residual plot shows besides the residuals: the segments and which of them fail.
pub struct SegmentMarks<'a> {
    /// The fit's segments (program pieces or rests), numbered as in the report's tables.
    pub segments: &'a [Segment],
    /// Numbers of the segments whose NIS test fails.
    pub failing: &'a [usize],
}

/// Write `path`: the residuals of one measurement kind, one panel per axis (East, North, Up),
/// in physical units, with the 1-sigma band of the innovation covariance, the segments shaded
/// alternately (failing ones red) and numbered.
pub fn residuals_png(
    path: &Path,
    kind: MeasurementKind,
    residuals: &[Residual],
    marks: &SegmentMarks<'_>,
) -> Result<(), Error> {
    let (unit, _) = residual_unit(kind);
    let title = format!(
        "{} residuals z - Hx [{unit}]; grey: +-1 sigma of S; red: segment fails; \
         triangles: beyond the axis",
        kind_label(kind)
    );
    write_png(path, (800, 600), |root| {
        let root = titled(root, &title, 17.0)?;
        let panels = root.split_evenly((3, 1));
        for (axis, panel) in panels.iter().enumerate() {
            residual_panel(panel, axis, unit, residuals, marks, axis == 0)?;
        }
        Ok(())
    })
}

/// One axis of [`residuals_png`]; the segment numbers are written on the first panel.
fn residual_panel(
    panel: &Area<'_>,
    axis: usize,
    unit: &str,
    residuals: &[Residual],
    marks: &SegmentMarks<'_>,
    numbered: bool,
) -> Result<(), String> {
    let pe = |e: &dyn std::fmt::Display| e.to_string();
    let (t0, t1) = match (residuals.first(), residuals.last()) {
        (Some(a), Some(b)) if b.t > a.t => (a.t, b.t),
        _ => (0.0, 1.0),
    };
    let y = residual_limit(residuals, axis);
    let mut chart = ChartBuilder::on(panel)
        .margin(6)
        .x_label_area_size(28)
        .y_label_area_size(62)
        .build_cartesian_2d(t0..t1, -y..y)
        .map_err(|e| pe(&e))?;
    // Segments first, under everything.
    let spans = marks
        .segments
        .iter()
        .filter(|s| s.t1 > t0 && s.t0 < t1)
        .map(|s| (s.index, s.t0.max(t0), s.t1.min(t1)));
    chart
        .draw_series(spans.clone().filter_map(|(i, a, b)| {
            let failing = marks.failing.contains(&i);
            (failing || i % 2 == 1).then(|| {
                let colour = if failing { FAILING } else { SHADE };
                Rectangle::new([(a, -y), (b, y)], colour.filled())
            })
        }))
        .map_err(|e| pe(&e))?;
    draw_mesh(
        &mut chart,
        ("IMU time [s]", &format!("{} [{unit}]", ENU[axis])),
        (t0, t1),
        (-y, y),
    )?;
    // The band as dots: the sigma of the angles changes from one update to the next as the
    // gimbals turn, and a line through it would fill the panel. A band wider than the axis is
    // left out (at the edge it would look like residuals).
    for sign in [-1.0, 1.0] {
        chart
            .draw_series(
                residuals
                    .iter()
                    .filter(|r| r.sigma[axis] <= y)
                    .map(|r| Circle::new((r.t, sign * r.sigma[axis]), 1, BAND.filled())),
            )
            .map_err(|e| pe(&e))?;
    }
    let value = |r: &&Residual| r.value[axis];
    chart
        .draw_series(
            residuals
                .iter()
                .filter(|r| value(r).abs() <= y)
                .map(|r| Circle::new((r.t, value(&r)), 1, POINTS.filled())),
        )
        .map_err(|e| pe(&e))?;
    chart
        .draw_series(residuals.iter().filter(|r| value(r).abs() > y).map(|r| {
            EmptyElement::at((r.t, 0.985 * y.copysign(value(&r)))) + off_axis(value(&r) > 0.0)
        }))
        .map_err(|e| pe(&e))?;
    beyond_note(
        panel,
        beyond(residuals.iter().map(|r| r.value[axis]), y),
        12.0,
    )?;
    if numbered {
        // A number where there is room for it (about 18 px).
        let width_px = panel.dim_in_pixel().0.saturating_sub(70).max(1) as f64;
        let style = TextStyle::from(("sans-serif", 11).into_font())
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Top));
        chart
            .draw_series(
                spans
                    .filter(|(_, a, b)| (b - a) / (t1 - t0) * width_px >= 18.0)
                    .map(|(i, a, b)| {
                        Text::new(i.to_string(), (0.5 * (a + b), 0.97 * y), style.clone())
                    }),
            )
            .map_err(|e| pe(&e))?;
    }
    Ok(())
}

/// Write `path`: the records' temperature over time (1-s means, the reference dashed), then the
/// specific-force residuals in the instrument's axes against the temperature at their time
/// (`points`: IMU time and residual, report units), one panel per axis, with their means in
/// [`TEMPERATURE_BINS`] bins of temperature and the standard error of each.
pub fn temperature_png(
    path: &Path,
    series: &[[f64; 2]],
    reference_c: f64,
    points: &[(f64, [f64; 3])],
) -> Result<(), Error> {
    let (unit, _) = residual_unit(MeasurementKind::Accel);
    let (lo, hi) = series
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p[1]), b.max(p[1]))
        });
    let at: Vec<(f64, [f64; 3])> = points
        .iter()
        .map(|(t, r)| (temperature_at(series, *t), *r))
        .filter(|(c, _)| c.is_finite())
        .collect();
    let pad = ((hi - lo) * 0.05).max(0.05);
    let span = (lo - pad, hi + pad);
    write_png(path, (800, 800), |root| {
        let root = titled(
            root,
            &format!(
                "temperature (reference {reference_c:.2} deg C dashed); specific-force \
                 residuals [{unit}] in the instrument axes, bin means red"
            ),
            17.0,
        )?;
        let panels = root.split_evenly((4, 1));
        temperature_panel(&panels[0], series, reference_c, span)?;
        for (axis, panel) in panels[1..].iter().enumerate() {
            let means = bin_means(&at, axis, lo, hi);
            against_temperature_panel(panel, &at, &means, axis, unit, span)?;
        }
        Ok(())
    })
}

/// Bins of temperature of [`temperature_png`].
const TEMPERATURE_BINS: usize = 20;

/// The temperature at `t` from the 1-s means, linearly between them, held beyond the ends.
fn temperature_at(series: &[[f64; 2]], t: f64) -> f64 {
    let k = series.partition_point(|p| p[0] <= t);
    match (k.checked_sub(1).map(|i| series[i]), series.get(k)) {
        (Some(a), Some(b)) => a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0]),
        (Some(a), None) => a[1],
        (None, Some(b)) => b[1],
        (None, None) => f64::NAN,
    }
}

/// The residuals' means of `axis` in [`TEMPERATURE_BINS`] bins from `lo` to `hi` deg C, as
/// (bin centre, mean, standard error); bins of fewer than three residuals left out.
fn bin_means(at: &[(f64, [f64; 3])], axis: usize, lo: f64, hi: f64) -> Vec<(f64, f64, f64)> {
    let width = ((hi - lo) / TEMPERATURE_BINS as f64).max(1e-9);
    let mut sums = [(0.0, 0.0, 0usize); TEMPERATURE_BINS];
    for (c, r) in at {
        let k = (((c - lo) / width) as usize).min(TEMPERATURE_BINS - 1);
        sums[k].0 += r[axis];
        sums[k].1 += r[axis] * r[axis];
        sums[k].2 += 1;
    }
    sums.iter()
        .enumerate()
        .filter(|(_, s)| s.2 >= 3)
        .map(|(k, &(sum, sq, n))| {
            let n = n as f64;
            let mean = sum / n;
            let var = ((sq - n * mean * mean) / (n - 1.0)).max(0.0);
            (lo + (k as f64 + 0.5) * width, mean, (var / n).sqrt())
        })
        .collect()
}

/// The first panel of [`temperature_png`]: the temperature over IMU time, the reference dashed.
fn temperature_panel(
    panel: &Area<'_>,
    series: &[[f64; 2]],
    reference_c: f64,
    (c0, c1): (f64, f64),
) -> Result<(), String> {
    let pe = |e: &dyn std::fmt::Display| e.to_string();
    let (t0, t1) = (
        series[0][0],
        series[series.len() - 1][0].max(series[0][0] + 1.0),
    );
    let mut chart = ChartBuilder::on(panel)
        .margin(6)
        .x_label_area_size(28)
        .y_label_area_size(62)
        .build_cartesian_2d(t0..t1, c0..c1)
        .map_err(|e| pe(&e))?;
    draw_mesh(
        &mut chart,
        ("IMU time [s]", "temperature [deg C]"),
        (t0, t1),
        (c0, c1),
    )?;
    chart
        .draw_series(LineSeries::new(series.iter().map(|p| (p[0], p[1])), POINTS))
        .map_err(|e| pe(&e))?;
    chart
        .draw_series(DashedLineSeries::new(
            [(t0, reference_c), (t1, reference_c)],
            6,
            4,
            BAND.into(),
        ))
        .map_err(|e| pe(&e))?;
    Ok(())
}

/// One axis of [`temperature_png`]: the residuals against the temperature and their bin means.
/// The scale is the bin means' (with their errors, four times over): a thermal error is a trend
/// of the means, micro-g under a noise of hundreds; residuals beyond it are not drawn.
fn against_temperature_panel(
    panel: &Area<'_>,
    at: &[(f64, [f64; 3])],
    means: &[(f64, f64, f64)],
    axis: usize,
    unit: &str,
    (c0, c1): (f64, f64),
) -> Result<(), String> {
    let pe = |e: &dyn std::fmt::Display| e.to_string();
    let m = means
        .iter()
        .map(|(_, v, e)| v.abs() + e)
        .fold(0.0, f64::max);
    let y = (4.0 * m).max(1e-9);
    let mut chart = ChartBuilder::on(panel)
        .margin(6)
        .x_label_area_size(28)
        .y_label_area_size(62)
        .build_cartesian_2d(c0..c1, -y..y)
        .map_err(|e| pe(&e))?;
    draw_mesh(
        &mut chart,
        (
            "temperature [deg C]",
            &format!("{} [{unit}]", ["x", "y", "z"][axis]),
        ),
        (c0, c1),
        (-y, y),
    )?;
    chart
        .draw_series(
            at.iter()
                .filter(|(_, r)| r[axis].abs() <= y)
                .map(|(c, r)| Circle::new((*c, r[axis]), 1, SHADE.filled())),
        )
        .map_err(|e| pe(&e))?;
    chart
        .draw_series(
            means.iter().map(|&(c, v, e)| {
                PathElement::new(vec![(c, v - e), (c, v + e)], RED.stroke_width(2))
            }),
        )
        .map_err(|e| pe(&e))?;
    chart
        .draw_series(
            means
                .iter()
                .map(|&(c, v, _)| Circle::new((c, v), 3, RED.filled())),
        )
        .map_err(|e| pe(&e))?;
    Ok(())
}

/// Steps of the correlation's colour scale per unit: cells and bar are drawn in the same
/// 2 * 50 + 1 colours, each kept exactly in the indexed PNG (finer than the eye tells apart).
const COLOUR_STEPS: i32 = 50;

/// A correlation as a colour: blue for -1, white for 0, red for +1, in steps of
/// 1 / [`COLOUR_STEPS`].
fn correlation_colour(r: f64) -> RGBColor {
    let steps = f64::from(COLOUR_STEPS);
    let r = if r.is_finite() {
        (r.clamp(-1.0, 1.0) * steps).round() / steps
    } else {
        0.0
    };
    let (end, a) = if r >= 0.0 {
        ((178.0, 24.0, 43.0), r)
    } else {
        ((33.0, 102.0, 172.0), -r)
    };
    let mix = |e: f64| (255.0 + (e - 255.0) * a).round() as u8;
    RGBColor(mix(end.0), mix(end.1), mix(end.2))
}

/// Write `path`: the correlation matrix `r` of the parameters `names` as a heat map, the names
/// on both axes and a colour bar from -1 to +1.
pub fn correlation_png(path: &Path, names: &[String], r: &[Vec<f64>]) -> Result<(), Error> {
    let n = names.len().max(1) as u32;
    // Cells of 22 px for the 25 parameters of a calibration with the turntable angles.
    let side = (570 / n).clamp(2, 22);
    let height = (CORRELATION_TOP + CORRELATION_LABELS) as u32 + n * side + 10;
    write_png_keeping(path, (800, height.max(300)), &correlation_scale(), |root| {
        draw_correlation(root, names, r, side as i32)
    })
}

/// Every colour of [`correlation_colour`], from -1 to +1.
fn correlation_scale() -> Vec<[u8; 3]> {
    (-COLOUR_STEPS..=COLOUR_STEPS)
        .map(|k| correlation_colour(f64::from(k) / f64::from(COLOUR_STEPS)))
        .map(|c| [c.0, c.1, c.2])
        .collect()
}

/// Room above the matrix (title) and below it (the rotated names), px.
const CORRELATION_TOP: i32 = 44;
const CORRELATION_LABELS: i32 = 120;

fn draw_correlation(
    root: &Area<'_>,
    names: &[String],
    r: &[Vec<f64>],
    side: i32,
) -> Result<(), String> {
    let pe = |e: &dyn std::fmt::Display| e.to_string();
    let n = names.len().max(1) as i32;
    let (left, top) = (140, CORRELATION_TOP);
    let title_style = TextStyle::from(("sans-serif", 17).into_font()).color(&BLACK);
    root.draw(&Text::new(
        "posterior correlation of the parameters (in state order)",
        (left, 12),
        title_style,
    ))
    .map_err(|e| pe(&e))?;
    for (i, row) in r.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            let (x, y) = (left + j as i32 * side, top + i as i32 * side);
            root.draw(&Rectangle::new(
                [(x, y), (x + side, y + side)],
                correlation_colour(*v).filled(),
            ))
            .map_err(|e| pe(&e))?;
        }
    }
    let font = (side as f64 * 0.62).clamp(8.0, 12.0);
    let row_style = TextStyle::from(("sans-serif", font).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Right, VPos::Center));
    let column_style = TextStyle::from(
        ("sans-serif", font)
            .into_font()
            .transform(FontTransform::Rotate270),
    )
    .color(&BLACK);
    let bottom = top + n * side;
    for (k, name) in names.iter().enumerate() {
        let c = k as i32 * side + side / 2;
        root.draw(&Text::new(
            name.as_str(),
            (left - 4, top + c),
            row_style.clone(),
        ))
        .map_err(|e| pe(&e))?;
        // Rotated text grows upwards from its anchor: anchor it at the name's length below.
        let len = root
            .estimate_text_size(name, &TextStyle::from(("sans-serif", font).into_font()))
            .map_or(0, |s| s.0 as i32);
        root.draw(&Text::new(
            name.as_str(),
            (left + c - font as i32 / 2, bottom + 4 + len),
            column_style.clone(),
        ))
        .map_err(|e| pe(&e))?;
    }
    colour_bar(root, left + n * side + 24, top, (n * side).max(100))
}

/// A vertical colour bar from -1 (bottom) to +1 (top) at `x`, `top`, `height` px.
fn colour_bar(root: &Area<'_>, x: i32, top: i32, height: i32) -> Result<(), String> {
    let pe = |e: &dyn std::fmt::Display| e.to_string();
    for k in 0..height {
        let v = 1.0 - 2.0 * k as f64 / (height - 1).max(1) as f64;
        root.draw(&Rectangle::new(
            [(x, top + k), (x + 18, top + k + 1)],
            correlation_colour(v).filled(),
        ))
        .map_err(|e| pe(&e))?;
    }
    root.draw(&Rectangle::new(
        [(x, top), (x + 18, top + height)],
        BLACK.stroke_width(1),
    ))
    .map_err(|e| pe(&e))?;
    let style = TextStyle::from(("sans-serif", 12).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    for (v, label) in [
        (1.0, "+1"),
        (0.5, "+0.5"),
        (0.0, "0"),
        (-0.5, "-0.5"),
        (-1.0, "-1"),
    ] {
        let y = top + ((1.0 - v) / 2.0 * (height - 1) as f64).round() as i32;
        root.draw(&Text::new(label, (x + 22, y), style.clone()))
            .map_err(|e| pe(&e))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_colours_run_from_blue_through_white_to_red() {
        assert_eq!(correlation_colour(0.0), RGBColor(255, 255, 255));
        assert_eq!(correlation_colour(1.0), RGBColor(178, 24, 43));
        assert_eq!(correlation_colour(-1.0), RGBColor(33, 102, 172));
        assert_eq!(correlation_colour(f64::NAN), RGBColor(255, 255, 255));
    }

    /// The RGB pixels of a PNG file, and its width.
    fn decoded(path: &Path) -> (Vec<u8>, usize) {
        let mut decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
        decoder.set_transformations(png::Transformations::EXPAND);
        let mut reader = decoder.read_info().unwrap();
        let mut rgb = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut rgb).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb);
        (rgb, info.width as usize)
    }

    #[test]
    fn the_colour_bar_runs_smoothly_in_the_cells_colours() {
        // 30 parameters with correlations of every value: more colours than an indexed PNG
        // holds. The bar was drawn in the most frequent ones, in bands of grey.
        let n: i32 = 30;
        let names: Vec<String> = (0..n).map(|k| format!("p{k}")).collect();
        let r: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0.37 * f64::from(i * n + j)).sin())
                    .collect()
            })
            .collect();
        let dir = std::env::temp_dir().join(format!("sins-calib-corr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("correlation.png");
        correlation_png(&path, &names, &r).unwrap();
        let (rgb, width) = decoded(&path);
        let _ = std::fs::remove_dir_all(&dir);
        // The bar: 9 px into its 18, from the top of the matrix down its height.
        let side = 570 / n;
        let (x, top, height) = (140 + n * side + 24 + 9, CORRELATION_TOP, n * side);
        let pixel = |x: i32, y: i32| {
            let k = 3 * (y as usize * width + x as usize);
            RGBColor(rgb[k], rgb[k + 1], rgb[k + 2])
        };
        let mut shades = std::collections::HashSet::new();
        for k in 1..height - 1 {
            let v = 1.0 - 2.0 * f64::from(k) / f64::from(height - 1);
            assert_eq!(pixel(x, top + k), correlation_colour(v), "row {k}, r = {v}");
            shades.insert(pixel(x, top + k));
        }
        assert_eq!(shades.len(), 2 * COLOUR_STEPS as usize + 1);
        // Each cell exactly in its colour of the scale.
        for (i, j) in [(0, 1), (7, 19), (29, 3)] {
            let (cx, cy) = (140 + j * side + side / 2, top + i * side + side / 2);
            let want = correlation_colour(r[i as usize][j as usize]);
            assert_eq!(pixel(cx, cy), want, "cell {i}, {j}");
        }
    }
}
