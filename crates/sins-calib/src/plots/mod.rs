//! PNG plot of the static residuals `|f| - g` per pose, before and after a free-motion
//! calibration: plotters' pure-Rust bitmap backend with an embedded font (Noto Sans Regular from
//! the `ttf-noto-sans` crate), so nothing needs a system font or library. Also the pieces the
//! other plots share: tick labels to the precision of their axis, titles that fit the width,
//! residual axes that a few outliers do not stretch, a legend placed off the data, and the
//! indexed PNG writer.

pub mod allan_deviation;
pub mod innovation_diagnostics;
pub mod lab_report;
pub mod navigation;

use crate::Error;
use calib::motion::free_motion::PoseResidual;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};
use std::path::Path;
use std::sync::OnceLock;

const FITTED: RGBColor = RGBColor(31, 119, 180);
const HELD_OUT: RGBColor = RGBColor(214, 39, 40);
/// Points beyond a residual axis, drawn at its edge.
pub(crate) const BEYOND: RGBColor = RGBColor(120, 20, 20);

pub(crate) fn ensure_fonts() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            register_font("sans-serif", FontStyle::Normal, ttf_noto_sans::REGULAR)
                .map_err(|_| "the embedded font could not be registered".to_string())
        })
        .clone()
}

// Tick labels.

/// The tick label of `v` on an axis whose labels must tell values `resolution` apart: the fewest
/// decimals that put it within half the resolution of `v`, so that a tick computed as
/// 0.30000000000000004 on an axis of 0.1 steps reads 0.3 and one at 1700000100 s on an axis of
/// 100-s steps reads 1700000100, not 1.7e9. What rounding left of a zero reads 0; past six
/// decimals, or where it is shorter for a large number, scientific notation. Without a
/// resolution (an axis of no span): [`crate::render::table::tick`], seven significant digits.
pub(crate) fn tick_label(v: f64, resolution: f64) -> String {
    if !(v.is_finite() && resolution.is_finite() && resolution > 0.0) {
        return crate::render::table::tick(v);
    }
    let half = 0.5 * resolution;
    if v.abs() <= half {
        return "0".to_string();
    }
    let close = |s: &String| s.parse::<f64>().is_ok_and(|p| (p - v).abs() <= half);
    let fixed = (0..=6usize).map(|d| format!("{v:.d$}")).find(close);
    let scientific = || {
        (0..=16usize)
            .map(|d| format!("{v:.d$e}"))
            .find(close)
            .unwrap_or_else(|| format!("{v:e}"))
    };
    match fixed {
        Some(f) if v.abs() < 1e8 => f,
        Some(f) => {
            let s = scientific();
            if s.len() < f.len() { s } else { f }
        }
        None => scientific(),
    }
}

/// Tick labels of a linear axis from `lo` to `hi`: to a thousandth of its span, finer than any
/// step between its labels.
pub(crate) fn linear_ticks(lo: f64, hi: f64) -> impl Fn(&f64) -> String {
    let resolution = (hi - lo).abs() / 1000.0;
    move |v| tick_label(*v, resolution)
}

/// The tick label of `v` on a logarithmic axis: to a thousandth of itself.
pub(crate) fn log_tick(v: &f64) -> String {
    tick_label(*v, v.abs() / 1000.0)
}

/// The ticks of a logarithmic axis from `lo` to `hi` (both positive): powers of ten, or, where
/// they are fewer than three, also twice and five times them, or else every digit times them;
/// and every digit times the powers of ten for the light grid. (plotters' own labels none
/// below the first power of ten in the range: an axis from 0.02 to 0.5 Hz read only 0.1 to 0.5.)
pub(crate) fn log_key_points(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let (lo, hi) = (lo.min(hi), lo.max(hi));
    if !(lo > 0.0 && hi.is_finite()) {
        return (vec![], vec![]);
    }
    let decades = lo.log10().floor() as i32..=hi.log10().ceil() as i32;
    let points = |digits: &[u8]| -> Vec<f64> {
        decades
            .clone()
            .flat_map(|e| digits.iter().map(move |&d| f64::from(d) * 10f64.powi(e)))
            .map(|v| format!("{v:.12e}").parse::<f64>().unwrap_or(v))
            .filter(|v| (lo * (1.0 - 1e-9)..=hi * (1.0 + 1e-9)).contains(v))
            .collect()
    };
    let all = points(&[1, 2, 3, 4, 5, 6, 7, 8, 9]);
    let bold = [&[1u8][..], &[1, 2, 5]]
        .into_iter()
        .map(points)
        .find(|p| p.len() >= 3)
        .unwrap_or_else(|| all.clone());
    (bold, all)
}

/// The tick label of an axis of whole numbers (segments, lags, poses): none between them.
pub(crate) fn count_tick(v: &f64) -> String {
    if (v - v.round()).abs() < 1e-6 {
        format!("{}", v.round() as i64)
    } else {
        String::new()
    }
}

// Titles.

/// How `title` fits `width` px: its font size and lines. One line at `size` px, or a little
/// smaller (down to 85 %); else broken after "; ", then ", ", then a space into lines at `size`
/// (smaller still if a line does not fit). `measure(text, size)`: the width of `text` in px.
pub(crate) fn title_layout(
    title: &str,
    width: f64,
    size: f64,
    measure: impl Fn(&str, f64) -> f64,
) -> (f64, Vec<String>) {
    let fits = |s: &str, z: f64| measure(s, z) <= width;
    let mut z = size;
    while z >= (0.85 * size).floor() {
        if fits(title, z) {
            return (z, vec![title.to_string()]);
        }
        z -= 1.0;
    }
    let lines = wrap(title, &["; ", ", ", " "], &|s| fits(s, size));
    let mut z = size;
    while z > 8.0 && !lines.iter().all(|l| fits(l, z)) {
        z -= 1.0;
    }
    (z, lines)
}

/// `text` in lines that fit, broken after the first of `separators` and, within a part too
/// long for a line, after the next ones.
fn wrap(text: &str, separators: &[&str], fits: &dyn Fn(&str) -> bool) -> Vec<String> {
    let Some((separator, finer)) = separators.split_first() else {
        return vec![text.to_string()];
    };
    if fits(text) {
        return vec![text.to_string()];
    }
    let mut lines: Vec<String> = vec![];
    let mut line = String::new();
    for part in text.split_inclusive(separator) {
        let joined = format!("{line}{part}");
        if line.is_empty() || fits(joined.trim_end()) {
            line = joined;
        } else {
            lines.push(line.trim_end().to_string());
            line = part.to_string();
        }
    }
    lines.push(line.trim_end().to_string());
    lines
        .into_iter()
        .flat_map(|l| wrap(&l, finer, fits))
        .collect()
}

/// Write `title` centred at the top of `area`, fitted to its width ([`title_layout`]), at `size`
/// px at most; the area below it.
pub(crate) fn titled<'a>(area: &Canvas<'a>, title: &str, size: f64) -> Result<Canvas<'a>, String> {
    let pe = |e: &dyn std::fmt::Display| format!("plotting: {e}");
    let width = area.dim_in_pixel().0 as f64;
    let measure = |s: &str, z: f64| {
        let style = TextStyle::from(("sans-serif", z).into_font());
        area.estimate_text_size(s, &style)
            .map_or(f64::INFINITY, |d| f64::from(d.0))
    };
    let (z, lines) = title_layout(title, width - 16.0, size, measure);
    let style = TextStyle::from(("sans-serif", z).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Top));
    let line_height = (1.25 * z).ceil() as i32;
    let pad = 5;
    for (k, line) in lines.iter().enumerate() {
        let at = (width as i32 / 2, pad + k as i32 * line_height);
        area.draw(&Text::new(line.as_str(), at, style.clone()))
            .map_err(|e| pe(&e))?;
    }
    let height = 2 * pad + lines.len() as i32 * line_height;
    Ok(area.split_vertically(height).1)
}

// Residual axes.

/// The symmetric limit of a residual axis: the `q`-quantile of the magnitudes of `sample` (the
/// finite ones) times `margin`, no more than the largest magnitude and at least `floor`, with a
/// tenth more room. A few outliers do not stretch it; they go beyond it ([`beyond`]).
pub(crate) fn robust_limit(
    sample: impl IntoIterator<Item = f64>,
    q: f64,
    margin: f64,
    floor: f64,
) -> f64 {
    let mut v: Vec<f64> = sample
        .into_iter()
        .filter(|x| x.is_finite())
        .map(f64::abs)
        .collect();
    v.sort_by(f64::total_cmp);
    let (quantile, largest) = match v.last() {
        Some(&largest) => {
            let k = ((v.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
            (v[k], largest)
        }
        None => (0.0, 0.0),
    };
    (quantile * margin).min(largest).max(floor).max(1e-12) * 1.1
}

/// How many of `values` (the finite ones) lie beyond `limit` in magnitude.
pub(crate) fn beyond(values: impl IntoIterator<Item = f64>, limit: f64) -> usize {
    values
        .into_iter()
        .filter(|v| v.is_finite() && v.abs() > limit)
        .count()
}

/// The mark of a point beyond a residual axis, drawn at its edge (`EmptyElement::at(edge) +
/// off_axis(up)`): a dark red triangle pointing off the axis (up when `up`).
pub(crate) fn off_axis(up: bool) -> Polygon<(i32, i32)> {
    let s = if up { -1 } else { 1 };
    Polygon::new(vec![(0, 5 * s), (-4, -2 * s), (4, -2 * s)], BEYOND.filled())
}

/// "N points beyond the axis" at the bottom right of `panel` (under its tick labels, beside the
/// axis' name), when there are any.
pub(crate) fn beyond_note(panel: &Canvas<'_>, n: usize, size: f64) -> Result<(), String> {
    if n == 0 {
        return Ok(());
    }
    let (w, h) = panel.dim_in_pixel();
    let text = if n == 1 {
        "1 point beyond the axis (triangle at its edge)".to_string()
    } else {
        format!("{n} points beyond the axis (triangles at its edge)")
    };
    let style = TextStyle::from(("sans-serif", size).into_font())
        .color(&BEYOND)
        .pos(Pos::new(HPos::Right, VPos::Bottom));
    panel
        .draw(&Text::new(text, (w as i32 - 8, h as i32 - 2), style))
        .map_err(|e| format!("plotting: {e}"))
}

// The legend of the static residuals.

/// A corner of a plot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Corner {
    UpperRight,
    UpperLeft,
    LowerRight,
    LowerLeft,
}

/// Where a legend box of `size` px, `pad` px in from the edges of `plot` (x0, y0, x1, y1 px),
/// covers none of `points` (px, markers of `radius` px): the first free corner of upper right,
/// upper left, lower right, lower left, with the box (x0, y0, x1, y1); none when each covers one.
pub(crate) fn legend_corner(
    plot: [i32; 4],
    size: (i32, i32),
    pad: i32,
    radius: i32,
    points: &[(i32, i32)],
) -> Option<(Corner, [i32; 4])> {
    let [x0, y0, x1, y1] = plot;
    let (w, h) = size;
    let (left, right) = (x0 + pad, x1 - pad - w);
    let (top, bottom) = (y0 + pad, y1 - pad - h);
    [
        (Corner::UpperRight, right, top),
        (Corner::UpperLeft, left, top),
        (Corner::LowerRight, right, bottom),
        (Corner::LowerLeft, left, bottom),
    ]
    .into_iter()
    .map(|(c, x, y)| (c, [x, y, x + w, y + h]))
    .find(|(_, b)| {
        !points.iter().any(|&(px, py)| {
            px + radius >= b[0] && px - radius <= b[2] && py + radius >= b[1] && py - radius <= b[3]
        })
    })
}

// The static residuals of a free-motion calibration.

/// A pose of a panel of [`static_residuals_png`]: its number, `|f| - g` [m/s^2], held out.
type Pose = (usize, f64, bool);
/// The legend's box (px), its distance from the plot's edges, the markers' size.
const LEGEND_SIZE: (i32, i32) = (112, 56);
const LEGEND_PAD: i32 = 10;
const MARKER: i32 = 7;

type PoseChart<'a> =
    ChartContext<'a, BitMapBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The axis limit of a panel: the poses' `|f| - g` without a few outliers.
fn pose_limit(values: &[Pose]) -> f64 {
    robust_limit(values.iter().map(|v| v.1), 0.9, 2.0, 1e-6)
}

/// The chart of a panel on `area`, nothing drawn yet; room at the right for the legend when
/// `outside`.
fn pose_chart<'a>(
    area: &Canvas<'a>,
    n: usize,
    y: f64,
    outside: bool,
) -> Result<PoseChart<'a>, String> {
    let right = if outside {
        LEGEND_SIZE.0 + 2 * LEGEND_PAD
    } else {
        14
    };
    ChartBuilder::on(area)
        .margin(14)
        .margin_right(right)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(0f64..n as f64 + 1.0, -y..y)
        .map_err(|e| format!("plotting: {e}"))
}

/// Where the legend of a panel covers none of its points: its box (px), if anywhere.
fn legend_inside(area: &Canvas<'_>, values: &[Pose]) -> Result<Option<[i32; 4]>, String> {
    let y = pose_limit(values);
    let chart = pose_chart(area, values.len(), y, false)?;
    let points: Vec<(i32, i32)> = values
        .iter()
        .map(|v| chart.backend_coord(&(v.0 as f64, v.1.clamp(-y, y))))
        .collect();
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let plot = [xs.start, ys.start, xs.end, ys.end];
    Ok(legend_corner(plot, LEGEND_SIZE, LEGEND_PAD, MARKER, &points).map(|c| c.1))
}

/// The legend (fitted: circles, held out: triangles) in `place` (x0, y0, x1, y1 px on the
/// backend), drawn on `area`.
fn draw_legend(area: &Canvas<'_>, place: [i32; 4]) -> Result<(), String> {
    let pe = |e: &dyn std::fmt::Display| format!("plotting: {e}");
    let (bx, by) = area.get_base_pixel();
    let [x0, y0, x1, y1] = [place[0] - bx, place[1] - by, place[2] - bx, place[3] - by];
    area.draw(&Rectangle::new([(x0, y0), (x1, y1)], WHITE.filled()))
        .map_err(|e| pe(&e))?;
    area.draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))
        .map_err(|e| pe(&e))?;
    let style = TextStyle::from(("sans-serif", 15).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let (a, b) = ((x0 + 20, y0 + 16), (x0 + 20, y0 + 38));
    area.draw(&Circle::new(a, 5, FITTED.filled()))
        .map_err(|e| pe(&e))?;
    area.draw(&TriangleMarker::new(b, MARKER, HELD_OUT.filled()))
        .map_err(|e| pe(&e))?;
    area.draw(&Text::new("fitted", (a.0 + 16, a.1), style.clone()))
        .map_err(|e| pe(&e))?;
    area.draw(&Text::new("held out", (b.0 + 16, b.1), style))
        .map_err(|e| pe(&e))
}

/// One panel: `|f| - g` [m/s^2] against the pose number, fitted poses as circles, held-out
/// poses as red triangles, the few beyond the axis at its edge; the legend in `place` (px), or
/// at the right of the plot when `None`.
fn panel(area: &Canvas<'_>, values: &[Pose], place: Option<[i32; 4]>) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("plotting: {e}");
    let y = pose_limit(values);
    let mut chart = pose_chart(area, values.len(), y, place.is_none())?;
    chart
        .configure_mesh()
        .y_label_formatter(&linear_ticks(-y, y))
        .x_desc("static interval")
        .y_desc("|f| - g [m/s^2]")
        .x_label_formatter(&count_tick)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| err(&e))?;
    let n = values.len() as f64 + 1.0;
    chart
        .draw_series(LineSeries::new(
            [(0.0, 0.0), (n, 0.0)],
            BLACK.stroke_width(1),
        ))
        .map_err(|e| err(&e))?;
    let on_axis = values.iter().filter(|v| v.1.abs() <= y);
    chart
        .draw_series(
            on_axis
                .clone()
                .filter(|v| !v.2)
                .map(|v| Circle::new((v.0 as f64, v.1), 5, FITTED.filled())),
        )
        .map_err(|e| err(&e))?;
    chart
        .draw_series(
            on_axis
                .filter(|v| v.2)
                .map(|v| TriangleMarker::new((v.0 as f64, v.1), MARKER, HELD_OUT.filled())),
        )
        .map_err(|e| err(&e))?;
    chart
        .draw_series(
            values.iter().filter(|v| v.1.abs() > y).map(|v| {
                EmptyElement::at((v.0 as f64, 0.985 * y.copysign(v.1))) + off_axis(v.1 > 0.0)
            }),
        )
        .map_err(|e| err(&e))?;
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let outside = [
        xs.end + LEGEND_PAD,
        ys.start,
        xs.end + LEGEND_PAD + LEGEND_SIZE.0,
        ys.start + LEGEND_SIZE.1,
    ];
    draw_legend(area, place.unwrap_or(outside))?;
    beyond_note(area, beyond(values.iter().map(|v| v.1), y), 14.0)
}

/// Write the static residuals of every pose before (upper panel) and after (lower panel)
/// calibration to a PNG file. The legend sits in a corner of each panel where it covers no
/// pose, or at the right of both.
pub fn static_residuals_png(path: &Path, name: &str, poses: &[PoseResidual]) -> Result<(), Error> {
    ensure_fonts()?;
    let err = |e: &dyn std::fmt::Display| format!("{}: plotting: {e}", path.display());
    let root = BitMapBackend::new(path, (900, 760)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (top, bottom) = root.split_vertically(380);
    let before: Vec<Pose> = poses
        .iter()
        .enumerate()
        .map(|(i, p)| (i + 1, p.before_m_s2, p.held_out))
        .collect();
    let after: Vec<Pose> = poses
        .iter()
        .enumerate()
        .map(|(i, p)| (i + 1, p.after_m_s2, p.held_out))
        .collect();
    let top = titled(&top, &format!("{name}: before calibration"), 22.0)?;
    let bottom = titled(&bottom, "after free-motion calibration", 22.0)?;
    let places = [
        legend_inside(&top, &before)?,
        legend_inside(&bottom, &after)?,
    ];
    // One panel's legend outside: both, so that their pose axes stay aligned.
    let inside = places.iter().all(Option::is_some);
    panel(&top, &before, places[0].filter(|_| inside))?;
    panel(&bottom, &after, places[1].filter(|_| inside))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// A drawing area of a plot in memory.
pub(crate) type Canvas<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Draw a plot of `size` pixels with `draw` and write it to `path` as an 8-bit indexed PNG
/// ([`palette`]): a third to a fifth of the size of plotters' RGB files, so that a report
/// with a dozen plots stays a few hundred kilobytes.
pub(crate) fn write_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Canvas<'_>) -> Result<(), String>,
) -> Result<(), Error> {
    write_png_keeping(path, size, &[], draw)
}

/// [`write_png`] with the colours of `keep` kept exactly wherever they are drawn (a colour
/// scale's steps, rarer than the shades of text but to be told apart).
pub(crate) fn write_png_keeping(
    path: &Path,
    size: (u32, u32),
    keep: &[[u8; 3]],
    draw: impl FnOnce(&Canvas<'_>) -> Result<(), String>,
) -> Result<(), Error> {
    ensure_fonts()?;
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        draw(&root).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    let (colours, indices) = palette(&rgb, keep);
    // Written beside and renamed: a plot is whole or absent, also after an interruption.
    crate::output::write_with(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| err(&e))?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), size.0, size.1);
        encoder.set_color(png::ColorType::Indexed);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_palette(colours.concat());
        encoder.set_compression(png::Compression::Best);
        encoder.set_filter(png::FilterType::NoFilter);
        let mut writer = encoder.write_header().map_err(|e| err(&e))?;
        writer.write_image_data(&indices).map_err(|e| err(&e))?;
        writer.finish().map_err(|e| err(&e))?;
        Ok(())
    })
}

/// An RGB image as a palette of at most 256 colours and an index per pixel: the colours of
/// `keep` that it has (the most frequent 256 of them), then the most frequent others, every
/// other colour (the rarer shades of antialiased edges) mapped to the nearest of them. A plot
/// of a few colours on white keeps its look.
fn palette(rgb: &[u8], keep: &[[u8; 3]]) -> (Vec<[u8; 3]>, Vec<u8>) {
    use std::collections::HashMap;
    let mut counts: HashMap<[u8; 3], usize> = HashMap::new();
    for p in rgb.chunks_exact(3) {
        *counts.entry([p[0], p[1], p[2]]).or_default() += 1;
    }
    let mut by_count: Vec<([u8; 3], usize)> = counts.into_iter().collect();
    by_count.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let kept: std::collections::HashSet<[u8; 3]> = keep.iter().copied().collect();
    let (mut colours, others): (Vec<[u8; 3]>, Vec<[u8; 3]>) =
        by_count.iter().map(|c| c.0).partition(|c| kept.contains(c));
    colours.truncate(256);
    let room = 256 - colours.len();
    colours.extend(others.into_iter().take(room));
    let distance = |a: &[u8; 3], b: &[u8; 3]| -> i32 {
        (0..3)
            .map(|k| (i32::from(a[k]) - i32::from(b[k])).pow(2))
            .sum()
    };
    let index: HashMap<[u8; 3], u8> = by_count
        .iter()
        .map(|(c, _)| {
            let nearest = (0..colours.len())
                .min_by_key(|&k| distance(c, &colours[k]))
                .unwrap_or(0);
            (*c, nearest as u8)
        })
        .collect();
    let indices = rgb
        .chunks_exact(3)
        .map(|p| index[&[p[0], p[1], p[2]]])
        .collect();
    (colours, indices)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_have_the_precision_of_their_axis() {
        // A sum of steps: 0.30000000000000004 on an axis of 0.1 steps.
        assert_eq!(tick_label(0.1 + 0.2, 0.001), "0.3");
        assert_eq!(linear_ticks(0.0, 1.0)(&(0.1 + 0.2)), "0.3");
        assert_eq!(tick_label(0.25, 0.001), "0.25");
        assert_eq!(tick_label(-0.05, 0.0005), "-0.05");
        // A zero left by rounding.
        assert_eq!(tick_label(-1.38894e-18, 0.001), "0");
        // Times of a recording stamped on a clock of 1.7e9 s, 100-s steps: seven significant
        // digits (table::tick) read 1.7e9 for every tick.
        assert_eq!(
            linear_ticks(1.7e9, 1.7e9 + 1000.0)(&1_700_000_100.0),
            "1700000100"
        );
        assert_eq!(
            linear_ticks(1.7e9, 1.7e9 + 1000.0)(&1_700_000_150.0),
            "1700000150"
        );
        // A span of half a second: 0.1 s steps, which a whole-number format read as 0.
        assert_eq!(linear_ticks(0.0, 0.5)(&0.1), "0.1");
        assert_eq!(linear_ticks(0.0, 0.5)(&0.30000000000000004), "0.3");
        // Small and large numbers.
        assert_eq!(tick_label(3e-7, 1e-9), "3e-7");
        assert_eq!(tick_label(2.5e12, 1e9), "2.5e12");
        assert_eq!(tick_label(2500.0, 1.0), "2500");
        // No span: seven significant digits.
        assert_eq!(tick_label(0.1 + 0.2, 0.0), "0.3");
        assert_eq!(tick_label(f64::NAN, 1.0), "NaN");
        // Logarithmic axes: to a thousandth of the value.
        assert_eq!(log_tick(&0.30000000000000004), "0.3");
        assert_eq!(log_tick(&0.001), "0.001");
        assert_eq!(log_tick(&20.000000000000004), "20");
        // Whole numbers only on axes of segments, lags and poses.
        assert_eq!(count_tick(&3.0000000001), "3");
        assert_eq!(count_tick(&-1e-12), "0");
        assert_eq!(count_tick(&0.5), "");
    }

    #[test]
    fn logarithmic_axes_are_labelled_across_their_whole_range() {
        // 0.02 to 0.5 Hz: one power of ten (0.1) in it; also 2 and 5 times them.
        let (bold, light) = log_key_points(0.0197, 0.5);
        assert_eq!(bold, vec![0.02, 0.05, 0.1, 0.2, 0.5]);
        assert_eq!(light.len(), 9 + 5 - 1);
        assert_eq!(light[0], 0.02);
        // Three decades: the powers of ten.
        assert_eq!(log_key_points(4e-4, 0.5).0, vec![0.001, 0.01, 0.1]);
        assert_eq!(
            log_key_points(1e-3, 45.0).0,
            vec![0.001, 0.01, 0.1, 1.0, 10.0]
        );
        // Less than a factor of two: every digit.
        assert_eq!(log_key_points(0.3, 0.5).0, vec![0.3, 0.4, 0.5]);
        assert_eq!(log_key_points(0.0, 1.0), (vec![], vec![]));
    }

    #[test]
    fn a_few_outliers_do_not_stretch_a_residual_axis_and_are_counted() {
        // 400 residuals within +-1000 ug and three of 13 000: the axis of their largest
        // magnitude (or of their 99.5th percentile, which is the third outlier) would squeeze
        // the 400 into a thirteenth of the panel.
        let mut values: Vec<f64> = (0..400)
            .map(|k| 1000.0 * (f64::from(k) * 0.7).sin())
            .collect();
        values.extend([13_000.0, -12_500.0, 13_100.0]);
        let limit = robust_limit(values.iter().copied(), 0.98, 1.5, 0.0);
        assert!((1000.0..1700.0).contains(&limit), "{limit}");
        assert_eq!(beyond(values.iter().copied(), limit), 3);
        // Nothing far out: the largest magnitude and a tenth more, nothing beyond.
        let calm = [0.5, -1.0, 0.9, 0.2];
        let limit = robust_limit(calm, 0.9, 2.0, 0.0);
        assert!((limit - 1.1).abs() < 1e-12);
        assert_eq!(beyond(calm, limit), 0);
        // The floor, an empty sample, values that are not numbers.
        assert!((robust_limit([0.1, -0.2], 0.98, 1.5, 3.0) - 3.3).abs() < 1e-12);
        assert!(robust_limit([], 0.98, 1.5, 0.0) > 0.0);
        assert_eq!(beyond([f64::NAN, f64::INFINITY, 5.0], 1.0), 1);
    }

    #[test]
    fn titles_fit_the_width_shrunk_a_little_or_wrapped() {
        // 0.5 px a character per px of font size.
        let measure = |s: &str, z: f64| 0.5 * z * s.chars().count() as f64;
        let (z, lines) = title_layout("short", 800.0, 18.0, measure);
        assert_eq!((z, lines), (18.0, vec!["short".to_string()]));
        // 92 characters at 18 px: 828 px; at 17 px: 782; at 16 px: 736, fits 780.
        let title = "specific force: NIS / dof per segment, bars: band at the per-test level; \
                     blue: paper's model";
        assert_eq!(title.chars().count(), 92);
        let (z, lines) = title_layout(title, 780.0, 18.0, measure);
        assert_eq!((z, lines.len()), (16.0, 1));
        // Too long at 15 px (690 px): broken after "; " into lines that fit at the full size.
        let (z, lines) = title_layout(title, 650.0, 18.0, measure);
        assert_eq!(z, 18.0);
        assert_eq!(
            lines,
            vec![
                "specific force: NIS / dof per segment, bars: band at the per-test level;",
                "blue: paper's model"
            ]
        );
        // A part longer than a line: broken after ", " and spaces.
        let (z, lines) = title_layout(title, 300.0, 18.0, measure);
        assert_eq!(z, 18.0);
        assert!(lines.len() >= 3);
        assert!(lines.iter().all(|l| measure(l, z) <= 300.0), "{lines:?}");
        assert_eq!(lines.concat().replace(' ', ""), title.replace(' ', ""));
        // A word wider than the width: a smaller font.
        let (z, lines) = title_layout("abcdefghijklmnopqrstuvwxyz", 130.0, 18.0, measure);
        assert_eq!(lines.len(), 1);
        assert!(measure(&lines[0], z) <= 130.0 && z < 18.0);
    }

    #[test]
    fn the_legend_goes_to_a_corner_without_points_or_out() {
        let plot = [100, 50, 900, 350];
        let (size, pad, radius) = ((112, 56), 10, 7);
        // The Ferraris recording before calibration: the last rest's point high at the right,
        // under the legend's fixed upper-right place; the first rests' at the left.
        let points = [(150, 110), (210, 108), (270, 290), (860, 80), (760, 300)];
        let (corner, b) = legend_corner(plot, size, pad, radius, &points).unwrap();
        assert_eq!(corner, Corner::LowerRight);
        assert_eq!(b, [900 - 10 - 112, 350 - 10 - 56, 900 - 10, 350 - 10]);
        // Nothing in the upper right: there, as before.
        let (corner, _) = legend_corner(plot, size, pad, radius, &points[..3]).unwrap();
        assert_eq!(corner, Corner::UpperRight);
        // A point just off the box still counts with its marker's size.
        let near = [(900 - 10 - 112 - 5, 100)];
        assert_eq!(
            legend_corner(plot, size, pad, radius, &near).unwrap().0,
            Corner::UpperLeft
        );
        // Every corner taken: no place inside.
        let corners = [(850, 80), (150, 80), (850, 320), (150, 320)];
        assert_eq!(legend_corner(plot, size, pad, radius, &corners), None);
    }

    #[test]
    fn static_residuals_with_every_corner_taken_and_an_outlier_are_drawn() {
        // Poses high and low at both ends (the legend goes out, right of both panels) and one
        // of 13 m/s^2 (beyond the axis, at its edge).
        let poses: Vec<PoseResidual> = (0..20)
            .map(|k| {
                let v = if k % 2 == 0 { 0.6 } else { -0.6 } * if k % 5 == 0 { 0.3 } else { 1.0 };
                PoseResidual {
                    rest: calib::motion::rests::Rest {
                        t0: k as f64,
                        t1: k as f64 + 0.5,
                    },
                    held_out: k % 4 == 3,
                    before_m_s2: if k == 9 { 13.0 } else { v },
                    after_m_s2: 0.01 * v,
                    raw_mean_f_m_s2: nalgebra::Vector3::new(0.0, 0.0, 9.81 + v),
                }
            })
            .collect();
        let dir = std::env::temp_dir().join(format!("sins-calib-free-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("free.png");
        static_residuals_png(&path, "corners", &poses).unwrap();
        let decoder = png::Decoder::new(std::fs::File::open(&path).unwrap());
        let info = decoder.read_info().unwrap().info().clone();
        assert_eq!((info.width, info.height), (900, 760));
        if std::env::var_os("SINS_CALIB_KEEP_TEST_PLOTS").is_none() {
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    #[test]
    fn kept_colours_stay_in_the_palette_however_rare() {
        // 300 greys drawn often, two colours of a scale once each: without keeping them the
        // scale's colours map to the nearest grey.
        let mut rgb: Vec<u8> = vec![];
        for v in 0..300u32 {
            let g = (v % 256) as u8;
            rgb.extend([g, g, (v / 256) as u8 * 3 + g / 2].repeat(10));
        }
        let scale = [[178u8, 24, 43], [33, 102, 172]];
        for c in scale {
            rgb.extend(c);
        }
        let (colours, indices) = palette(&rgb, &scale);
        assert_eq!(colours.len(), 256);
        let n = indices.len();
        assert_eq!(colours[indices[n - 2] as usize], scale[0]);
        assert_eq!(colours[indices[n - 1] as usize], scale[1]);
        let (colours, indices) = palette(&rgb, &[]);
        assert_ne!(colours[indices[n - 2] as usize], scale[0]);
    }

    #[test]
    fn the_palette_keeps_frequent_colours_and_maps_rare_ones_to_the_nearest() {
        // White and a blue often, 128 even greys three times each, 127 odd greys once each:
        // 257 colours, one too many; the odd greys are the rarest.
        let mut rgb: Vec<u8> = [255u8; 3].repeat(1000);
        rgb.extend([31u8, 119, 180].repeat(500));
        for v in (0..=254u8).step_by(2) {
            rgb.extend([v, v, v].repeat(3));
        }
        for v in (1..=253u8).step_by(2) {
            rgb.extend([v, v, v]);
        }
        let (colours, indices) = palette(&rgb, &[]);
        assert_eq!(colours.len(), 256);
        assert_eq!(colours[0], [255, 255, 255]);
        assert_eq!(colours[1], [31, 119, 180]);
        assert_eq!(indices.len(), rgb.len() / 3);
        // The frequent colours exactly, the one left out within a level of its neighbour.
        for (p, &i) in rgb.chunks_exact(3).zip(&indices) {
            let c = colours[i as usize];
            let worst = (0..3)
                .map(|k| (i32::from(p[k]) - i32::from(c[k])).abs())
                .max();
            assert!(worst <= Some(1), "{p:?} drawn as {c:?}");
            if p[0] % 2 == 0 || p[0] == 255 {
                assert_eq!(p, c, "a frequent colour changed");
            }
        }
    }
}
