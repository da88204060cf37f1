//! The printed tables of `sins-calib noise`: per sensor the Allan fit's terms and the
//! maximum-likelihood levels per axis, with the notes on fits that failed their checks.

use super::*;

/// The tables of both fits, the thermal regression, and what removing it did.
pub(super) fn tables(fits: &Fitted, median: f64, intervals: &[Range<usize>]) -> String {
    let mut out = String::new();
    let whole_seconds: Vec<usize> = intervals
        .iter()
        .map(|r| (r.len() as f64 * median + 1e-9).floor() as usize)
        .collect();
    for (s, sn) in [&GYRO, &ACCEL].into_iter().zip(&fits.sensors) {
        out += &ml_table(s, sn);
        out += &crate::commands::noise::slow_terms::one_second_line(s, sn, &whole_seconds);
    }
    out += &crate::commands::noise::consistency::report(&fits.band, &fits.splits, median);
    for (s, sn) in [&GYRO, &ACCEL].into_iter().zip(&fits.sensors) {
        out += &sensor_table(s, sn);
    }
    for (s, sn) in [&GYRO, &ACCEL].into_iter().zip(&fits.sensors) {
        out += &crate::commands::noise::slow_terms::report(s, sn);
    }
    if let Some(t) = &fits.thermal {
        out += &thermal_table(t);
    }
    if let Some(measured) = &fits.as_measured {
        out += &thermal_removed_note(&fits.removed, measured, &fits.sensors);
    }
    out
}

/// A level with its sigma; a term the fit left out as `-` with the level it could hide. A fit
/// that fails its own check gives no result: its terms as `no result (x)`, the figure for
/// orientation only, and no level hidden (a bound from a model the data reject bounds nothing).
pub(super) fn level(fit: &NoiseFit, j: usize, factor: f64) -> String {
    let e = &fit.terms[j];
    if !fit.passes() {
        return if e.included {
            format!("no result ({})", table::significant(e.value * factor, 2))
        } else {
            "-".into()
        };
    }
    if e.included {
        format!(
            "{} +- {}",
            table::with_precision_of(e.value * factor, e.sigma * factor),
            table::sigma(e.sigma * factor)
        )
    } else {
        format!("- (<{})", table::significant(e.sigma * factor, 2))
    }
}

/// The averaging times where an Allan fit's sum leaves the measured band: one tau, or
/// `from-to` (s, three digits).
fn tau_range(m: &::noise::fit::Misfit) -> String {
    if m.points == 1 {
        table::significant(m.from_tau_s, 3)
    } else {
        format!(
            "{}-{}",
            table::significant(m.from_tau_s, 3),
            table::significant(m.to_tau_s, 3)
        )
    }
}

pub(super) fn sensor_table(s: &Sensor, sn: &SensorNoise) -> String {
    let mut cols: Vec<(&str, Align)> = vec![("axis", Align::Left)];
    // White, instability and walk first: the levels the configuration uses.
    let order = [1usize, 2, 3, 0, 4];
    for j in order {
        cols.push((s.labels[j], Align::Right));
    }
    cols.push(("chi2/dof", Align::Right));
    cols.push(("p", Align::Right));
    cols.push(("fitted tau [s]", Align::Right));
    cols.push(("sum in 95 % band", Align::Left));
    let mut t = Table::new(&cols);
    let slow = crate::commands::noise::slow_terms::slow_terms(sn);
    for (a, ax) in sn.axes.iter().enumerate() {
        let f = &ax.fit;
        let mut row = vec![AXES[a].to_string()];
        for j in order {
            // Slow terms the rests cannot tell are no figures (docs/noise.md, "Rests too short
            // to tell").
            let undetermined = match j {
                2 => !slow[a].bias_instability,
                3 => !slow[a].walk,
                _ => false,
            };
            row.push(if undetermined && f.terms[j].included {
                "not determined".to_string()
            } else {
                level(f, j, s.factors[j])
            });
        }
        row.push(format!("{:.2}/{}", f.chi2, f.dof));
        row.push(calib::check::stats::p_value_text(f.p_value));
        let last = ax.curve.points.last().map_or(0.0, |p| p.tau_s);
        row.push(format!(
            "{} .. {}",
            table::significant(f.tau_min_s, 3),
            table::significant(last, 3)
        ));
        let outside: Vec<String> = f
            .misfits
            .iter()
            .map(|m| {
                format!(
                    "{} s x{}",
                    tau_range(m),
                    table::significant(m.worst_ratio, 2)
                )
            })
            .collect();
        row.push(if outside.is_empty() {
            "yes".to_string()
        } else {
            format!("no: {}", outside.join(", "))
        });
        t.row(row);
    }
    let mut notes = String::new();
    for (a, ax) in sn.axes.iter().enumerate() {
        for m in &ax.fit.misfits {
            let range = tau_range(m);
            let _ = writeln!(
                notes,
                "  {} {range} s ({} point{}, sum/data up to x{}): {}",
                AXES[a],
                m.points,
                if m.points == 1 { "" } else { "s" },
                table::significant(m.worst_ratio, 2),
                m.kind.describe()
            );
        }
    }
    if !notes.is_empty() {
        notes = format!("  where the sum leaves the band:\n{notes}");
    }
    notes += &failed_fit_notes(sn);
    format!(
        "\n{}, Allan fit (terms +- 1 sigma; `- (<x)`: not in the fit, x the level the data could \
         hide at 1 sigma; `xR`: fitted over measured deviation where the sum is furthest outside \
         the measured 95 % band)\n{}{notes}",
        s.name,
        t.render()
    )
}

/// A line per axis whose Allan fit fails its own check: why, and that its levels are no result.
pub(super) fn failed_fit_notes(sn: &SensorNoise) -> String {
    let mut notes = String::new();
    for (a, ax) in sn.axes.iter().enumerate() {
        let f = &ax.fit;
        if f.passes() {
            continue;
        }
        let bend = f
            .misfits
            .iter()
            .any(|m| m.fitted && m.kind == ::noise::fit::MisfitKind::Bend);
        let why = match (f.p_value < ::noise::fit::CHECK_P, bend) {
            (true, true) => format!(
                "chi-square p {} below {} and a bend in the fitted range",
                calib::check::stats::p_value_text(f.p_value),
                ::noise::fit::CHECK_P
            ),
            (true, false) => format!(
                "chi-square p {} below {}",
                calib::check::stats::p_value_text(f.p_value),
                ::noise::fit::CHECK_P
            ),
            _ => "a bend in the fitted range".to_string(),
        };
        let _ = writeln!(
            notes,
            "  {}: the Allan fit fails its own check ({why}): its levels are no result; the \
             figures in `no result (x)` are for orientation only",
            AXES[a]
        );
    }
    notes
}

/// A maximum-likelihood level as `value [lower, upper]`, all to the precision of the smaller
/// half-width.
pub(super) fn ml_level(l: &Level, factor: f64) -> String {
    let (v, lo, hi) = (l.value * factor, l.lower * factor, l.upper * factor);
    let hw = [v - lo, hi - v]
        .into_iter()
        .filter(|h| h.is_finite() && *h > 0.0)
        .fold(f64::INFINITY, f64::min);
    let hw = if hw.is_finite() { hw } else { v.abs() };
    let f = |x: f64| {
        if x == 0.0 {
            "0".to_string()
        } else if x.is_infinite() {
            "inf".to_string()
        } else {
            table::with_precision_of(x, hw)
        }
    };
    format!("{} [{}, {}]", f(v), f(lo), f(hi))
}

/// The maximum-likelihood levels of a sensor's axes.
pub(super) fn ml_table(s: &Sensor, sn: &SensorNoise) -> String {
    let gm_label = format!(
        "Gauss-Markov [{}]",
        s.labels[2]
            .split_once('[')
            .map_or("", |x| x.1.trim_end_matches(']'))
    );
    let mut t = Table::new(&[
        ("axis", Align::Left),
        (s.labels[1], Align::Right),
        (s.labels[3], Align::Right),
        (&gm_label, Align::Right),
        ("tc [s]", Align::Right),
        ("LR p", Align::Right),
        ("check p", Align::Right),
        ("blocks", Align::Right),
    ]);
    let slow = crate::commands::noise::slow_terms::slow_terms(sn);
    for (a, m) in sn.ml.iter().enumerate() {
        let (gm, tc) = match &m.gauss_markov {
            Some(g) => (
                ml_level(&g.sigma, s.factors[2]),
                format!(
                    "{}{}",
                    table::significant(g.correlation_time_s, 3),
                    if m.tc_at_bound { " (bound)" } else { "" }
                ),
            ),
            None => ("-".to_string(), "-".to_string()),
        };
        t.row(vec![
            AXES[a].to_string(),
            ml_level(&m.white, s.factors[1]),
            if slow[a].walk {
                ml_level(&m.walk, s.factors[3])
            } else {
                "not determined".to_string()
            },
            gm,
            tc,
            calib::check::stats::p_value_text(m.lr_p_value),
            m.whiteness.map_or("-".to_string(), |w| {
                calib::check::stats::p_value_text(w.p_value)
            }),
            format!("{} x {} s", m.blocks, table::significant(m.block_s, 3)),
        ]);
    }
    let notes = ml_notes(s, sn);
    format!(
        "\n{}, maximum likelihood (value [68 % profile interval]; the Gauss-Markov bias where \
         the likelihood-ratio test, p in LR p, selects it at p < 0.01; check p: the model \
         against the data, whiteness of the innovations)\n{}{notes}",
        s.name,
        t.render()
    )
}

/// The notes under a sensor's likelihood table: an oscillation the blocks were chosen above, a
/// check that fails, too few blocks, a correlation time at a bound.
pub(super) fn ml_notes(s: &Sensor, sn: &SensorNoise) -> String {
    let mut notes = String::new();
    for (a, m) in sn.ml.iter().enumerate() {
        if let Some(n) = crate::commands::noise::slow_terms::oscillation_note(s, AXES[a], m) {
            notes += &n;
        }
        let corr = if m.below_correlation() {
            format!(
                "blocks of {} s, a tenth of the longest interval, short of ten times the \
                 sensor's correlation time {} s",
                table::significant(m.block_s, 3),
                table::significant(m.correlation_s, 2)
            )
        } else {
            format!(
                "blocks of {} s above the sensor's correlation time {} s",
                table::significant(m.block_s, 3),
                table::significant(m.correlation_s, 2)
            )
        };
        match m.whiteness {
            Some(w) if w.p_value < ::noise::likelihood::SELECTION_P => {
                let _ = writeln!(
                    notes,
                    "  {}: the check fails ({corr}): over windows of {} s the innovations vary \
                     {} times as much as the model says, a time scale the model does not \
                     describe{}",
                    AXES[a],
                    table::significant(w.window_blocks as f64 * m.block_s, 3),
                    table::significant(w.variance_ratio, 3),
                    if m.tc_at_bound {
                        "; the Gauss-Markov correlation time sits at its lower bound"
                    } else {
                        ""
                    }
                );
            }
            None => {
                let _ = writeln!(notes, "  {}: too few blocks to check ({corr})", AXES[a]);
            }
            _ if m.tc_at_bound => {
                let _ = writeln!(
                    notes,
                    "  {}: the Gauss-Markov correlation time sits at a bound of its search: \
                     the value is the bound's ({corr})",
                    AXES[a]
                );
            }
            _ => {}
        }
    }
    notes
}
