//! PNG plot of the static residuals `|f| - g` per pose, before and after a free-motion
//! calibration: plotters' pure-Rust bitmap backend with an embedded font (Noto Sans Regular from
//! the `ttf-noto-sans` crate), so nothing needs a system font or library.

use crate::Error;
use calib::motion::free_motion::PoseResidual;
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
        .y_label_formatter(&|v| crate::table::tick(*v))
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

/// A drawing area of a plot in memory.
pub(crate) type Canvas<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// Draw a plot of `size` pixels with `draw` and write it to `path` as an 8-bit indexed PNG
/// ([`palette`]): a third to a fifth of the size of plotters' RGB files, so that a report
/// with a dozen plots stays a few hundred kilobytes.
pub(crate) fn write_png(
    path: &Path,
    size: (u32, u32),
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
    let (colours, indices) = palette(&rgb);
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

/// An RGB image as a palette of at most 256 colours and an index per pixel: the 256 most
/// frequent colours, every other colour (the rarer shades of antialiased edges) mapped to the
/// nearest of them. A plot of a few colours on white keeps its look.
fn palette(rgb: &[u8]) -> (Vec<[u8; 3]>, Vec<u8>) {
    use std::collections::HashMap;
    let mut counts: HashMap<[u8; 3], usize> = HashMap::new();
    for p in rgb.chunks_exact(3) {
        *counts.entry([p[0], p[1], p[2]]).or_default() += 1;
    }
    let mut by_count: Vec<([u8; 3], usize)> = counts.into_iter().collect();
    by_count.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let colours: Vec<[u8; 3]> = by_count.iter().take(256).map(|c| c.0).collect();
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
        let (colours, indices) = palette(&rgb);
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
