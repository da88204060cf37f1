//! The report's plot of the navigation figure: rho(t) over the flight, calibrated and
//! uncalibrated, on a logarithmic axis (the two differ by orders of magnitude).

use crate::Error;
use crate::plots::{log_key_points, log_tick, titled, write_png};
use navsim::NavigationFigure;
use plotters::prelude::*;
use std::path::Path;

const CALIBRATED: RGBColor = RGBColor(31, 119, 180);
const UNCALIBRATED: RGBColor = RGBColor(214, 39, 40);

/// Write `path`: rho(t) of `f` from the posterior and from the priors, time in minutes (in
/// seconds below 10 min), rho in metres on a logarithmic axis.
pub fn rho_png(path: &Path, f: &NavigationFigure, flight: &str) -> Result<(), Error> {
    let minutes = f.horizon.seconds >= 600.0;
    let (scale, unit) = if minutes { (60.0, "min") } else { (1.0, "s") };
    let x_max = (f.horizon.seconds / scale).max(1e-9);
    // From the first positive value of the calibrated curve (rho is zero at the start).
    let positive = |v: &[f64]| {
        v.iter()
            .copied()
            .filter(|x| *x > 0.0 && x.is_finite())
            .collect::<Vec<f64>>()
    };
    let all: Vec<f64> = positive(&f.calibrated_m)
        .into_iter()
        .chain(positive(&f.uncalibrated_m))
        .collect();
    let hi = all.iter().copied().fold(1.0, f64::max) * 1.5;
    let lo = all
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .max(hi * 1e-6)
        .min(hi / 10.0);
    let (bold, light) = log_key_points(lo, hi);
    let title = format!(
        "position error rho over {flight}: calibrated (posterior) {:.0} m, uncalibrated \
         (priors) {:.0} m at {:.0} {unit}",
        f.rho_m, f.uncalibrated_rho_m, x_max
    );
    write_png(path, (900, 560), |root| {
        let area = titled(root, &title, 17.0)?;
        let pe = |e: &dyn std::fmt::Display| format!("plotting: {e}");
        let mut chart = ChartBuilder::on(&area)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                0.0..x_max,
                (lo..hi)
                    .log_scale()
                    .with_key_points(bold)
                    .with_light_points(light),
            )
            .map_err(|e| pe(&e))?;
        chart
            .configure_mesh()
            .x_desc(format!("time [{unit}]"))
            .y_desc("rho [m]")
            .y_label_formatter(&log_tick)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .light_line_style(RGBColor(240, 240, 240))
            .draw()
            .map_err(|e| pe(&e))?;
        for (name, v, colour) in [
            ("calibrated", &f.calibrated_m, CALIBRATED),
            ("uncalibrated", &f.uncalibrated_m, UNCALIBRATED),
        ] {
            let points = f
                .t_s
                .iter()
                .zip(v.iter())
                .filter(|(_, r)| **r >= lo)
                .map(|(t, r)| (t / scale, r.min(hi)));
            chart
                .draw_series(LineSeries::new(points, colour.stroke_width(2)))
                .map_err(|e| pe(&e))?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| pe(&e))?;
        Ok(())
    })
}
