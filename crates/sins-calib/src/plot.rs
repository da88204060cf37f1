//! PNG plot of the static residuals `|f| - g` per pose, before and after a free-motion
//! calibration: plotters' pure-Rust bitmap backend with an embedded font (Noto Sans Regular from
//! the `ttf-noto-sans` crate), so nothing needs a system font or library.

use crate::Error;
use calib::free_motion::PoseResidual;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use std::path::Path;
use std::sync::OnceLock;

const FITTED: RGBColor = RGBColor(31, 119, 180);
const HELD_OUT: RGBColor = RGBColor(214, 39, 40);

pub(crate) fn ensure_fonts() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            register_font("sans-serif", FontStyle::Normal, ttf_noto_sans::REGULAR)
                .map_err(|_| "the embedded font could not be registered".to_string())
        })
        .clone()
}

/// One panel: `|f| - g` [m/s^2] against the pose number, fitted poses as circles, held-out
/// poses as red triangles.
fn panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    title: &str,
    values: &[(usize, f64, bool)],
) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("plotting: {e}");
    let y = values
        .iter()
        .fold(0.0f64, |m, v| m.max(v.1.abs()))
        .max(1e-6)
        * 1.15;
    let n = values.len() as f64 + 1.0;
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 22))
        .margin(14)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(0f64..n, -y..y)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("static interval")
        .y_desc("|f| - g [m/s^2]")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| err(&e))?;
    chart
        .draw_series(LineSeries::new(
            [(0.0, 0.0), (n, 0.0)],
            BLACK.stroke_width(1),
        ))
        .map_err(|e| err(&e))?;
    chart
        .draw_series(
            values
                .iter()
                .filter(|v| !v.2)
                .map(|v| Circle::new((v.0 as f64, v.1), 5, FITTED.filled())),
        )
        .map_err(|e| err(&e))?
        .label("fitted")
        .legend(|(x, y)| Circle::new((x + 10, y), 5, FITTED.filled()));
    chart
        .draw_series(
            values
                .iter()
                .filter(|v| v.2)
                .map(|v| TriangleMarker::new((v.0 as f64, v.1), 7, HELD_OUT.filled())),
        )
        .map_err(|e| err(&e))?
        .label("held out")
        .legend(|(x, y)| TriangleMarker::new((x + 10, y), 7, HELD_OUT.filled()));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(|e| err(&e))?;
    Ok(())
}

/// Write the static residuals of every pose before (upper panel) and after (lower panel)
/// calibration to a PNG file.
pub fn static_residuals_png(path: &Path, name: &str, poses: &[PoseResidual]) -> Result<(), Error> {
    ensure_fonts()?;
    let err = |e: &dyn std::fmt::Display| format!("{}: plotting: {e}", path.display());
    let root = BitMapBackend::new(path, (900, 760)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (top, bottom) = root.split_vertically(380);
    let before: Vec<_> = poses
        .iter()
        .enumerate()
        .map(|(i, p)| (i + 1, p.before_m_s2, p.held_out))
        .collect();
    let after: Vec<_> = poses
        .iter()
        .enumerate()
        .map(|(i, p)| (i + 1, p.after_m_s2, p.held_out))
        .collect();
    panel(&top, &format!("{name}: before calibration"), &before)?;
    panel(&bottom, "after free-motion calibration", &after)?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
