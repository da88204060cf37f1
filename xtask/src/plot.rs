//! PNG plots for the project automation, in pure Rust: plotters' bitmap backend and a TrueType
//! font embedded in the binary (Noto Sans Regular from the `ttf-noto-sans` crate, Apache-2.0),
//! so nothing needs a system font or library.

use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

/// Line colours, in series order (repeats after the last).
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Register the embedded font under the family names plotters uses (once per process).
fn ensure_fonts() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            for family in ["sans-serif", "serif", "monospace"] {
                register_font(family, FontStyle::Normal, ttf_noto_sans::REGULAR).map_err(|_| {
                    format!("the embedded font could not be registered as `{family}`")
                })?;
            }
            Ok(())
        })
        .clone()
}

/// Draw rho(t) curves into a PNG file: rho in km against time in minutes, one line per series,
/// with a legend. Each series is `(name, t (s), rho (m))`, both slices of equal length.
pub fn plot_rho_png(
    path: &Path,
    title: &str,
    series: &[(&str, &[f64], &[f64])],
) -> Result<(), String> {
    if series.is_empty() {
        return Err("no series to plot".into());
    }
    let mut t_max = 0.0f64;
    let mut rho_max = 0.0f64;
    for (name, t, rho) in series {
        if t.len() != rho.len() {
            return Err(format!(
                "series `{name}`: {} times but {} rho values",
                t.len(),
                rho.len()
            ));
        }
        if t.is_empty() {
            return Err(format!("series `{name}` is empty"));
        }
        if t.iter().chain(rho.iter()).any(|x| !x.is_finite()) {
            return Err(format!("series `{name}` has a value that is not finite"));
        }
        t_max = t.iter().copied().fold(t_max, f64::max);
        rho_max = rho.iter().copied().fold(rho_max, f64::max);
    }
    ensure_fonts()?;
    let x_max = if t_max > 0.0 { t_max / 60.0 } else { 1.0 };
    let y_max = if rho_max > 0.0 {
        rho_max / 1000.0 * 1.08
    } else {
        1.0
    };
    let err = |e: &dyn std::fmt::Display| format!("plotting {}: {e}", path.display());

    let root = BitMapBackend::new(path, (1000, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 26))
        .margin(18)
        .x_label_area_size(55)
        .y_label_area_size(75)
        .build_cartesian_2d(0f64..x_max, 0f64..y_max)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("time [min]")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_desc("rho [km]")
        .label_style(("sans-serif", 17))
        .axis_desc_style(("sans-serif", 19))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, (name, t, rho)) in series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let points = t
            .iter()
            .zip(rho.iter())
            .map(|(&t, &r)| (t / 60.0, r / 1000.0));
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label(*name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 18))
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_a_png_and_rejects_bad_input() {
        let path = std::env::temp_dir().join(format!("xtask-plot-test-{}.png", std::process::id()));
        let t: Vec<f64> = (0..=3600).map(f64::from).collect();
        let a: Vec<f64> = t
            .iter()
            .map(|t| 0.6 * t * (1.0 - (t / 800.0).cos() * 0.1))
            .collect();
        let b: Vec<f64> = a.iter().map(|x| x * 0.5).collect();
        plot_rho_png(&path, "rho test", &[("a", &t, &a), ("b", &t, &b)]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert!(bytes.len() > 10_000, "{}", bytes.len());
        assert!(plot_rho_png(&path, "x", &[]).is_err());
        assert!(plot_rho_png(&path, "x", &[("a", &t, &a[1..])]).is_err());
        assert!(!path.exists());
    }
}
