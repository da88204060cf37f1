//! `sins-calib noise` on records with a `temp` column: the thermal part of the static data
//! (each axis's rate or specific force per kelvin, regressed on the temperature within the
//! rests), its table and JSON, and what removing it did to the levels.

use super::*;

/// The thermal part of the static data: the temperatures seen and each axis's (gyros in rad/s,
/// accelerometers in m/s^2 per K).
pub(super) struct Thermal {
    lo_c: f64,
    hi_c: f64,
    axes: Vec<::noise::thermal::AxisThermal>,
    /// Each interval's mean temperature (deg C; NaN without records).
    pub(super) interval_means: Vec<f64>,
}

/// How far from zero, in sigmas, a thermal coefficient is taken as there (the sigma takes the
/// bin means as independent, optimistic where a walk is left: a wide margin).
pub(super) const THERMAL_SIGMAS: f64 = 5.0;

impl Thermal {
    /// The coefficients (rate per K) of the axes whose coefficient stands [`THERMAL_SIGMAS`]
    /// clear of zero, 0 for the others.
    pub(super) fn significant(&self) -> [f64; 6] {
        std::array::from_fn(|i| {
            let a = &self.axes[i];
            if a.sigma > 0.0 && (a.coefficient / a.sigma).abs() >= THERMAL_SIGMAS {
                a.coefficient
            } else {
                0.0
            }
        })
    }
}

/// How much of the intervals' slow variation the `temp` column explains
/// ([`::noise::thermal`]): one more reading of the records; `None` without a temperature or
/// when it does not move.
pub(super) fn thermal_fit(
    source: &mut RateSource<'_>,
    intervals: &[Range<usize>],
    median: f64,
) -> Result<Option<Thermal>, Error> {
    let mut bins: Vec<::noise::thermal::IntervalBins> = intervals
        .iter()
        .map(|_| ::noise::thermal::IntervalBins::new(6))
        .collect();
    let kind = source.kind();
    let (mut k, mut at, mut any) = (0usize, 0usize, false);
    source.records_of(&mut |r, _| {
        while at < intervals.len() && intervals[at].end <= k {
            at += 1;
        }
        if let (Some(range), Some(temp)) = (intervals.get(at), r.temp)
            && range.contains(&k)
        {
            // Rates: as they are; increments over the median interval.
            let scale = match kind {
                ImuKind::Rates => 1.0,
                ImuKind::Increments => 1.0 / median,
            };
            let v = [
                r.gyro[0] * scale,
                r.gyro[1] * scale,
                r.gyro[2] * scale,
                r.accel[0] * scale,
                r.accel[1] * scale,
                r.accel[2] * scale,
            ];
            bins[at].push(r.t, temp, &v);
            any = true;
        }
        k += 1;
    })?;
    if !any {
        return Ok(None);
    }
    for b in &mut bins {
        b.close();
    }
    let interval_means = bins.iter().map(|b| b.mean_temp()).collect();
    Ok(
        ::noise::thermal::fit(&bins).map(|(lo_c, hi_c, axes)| Thermal {
            lo_c,
            hi_c,
            axes,
            interval_means,
        }),
    )
}

/// Which axes had their thermal part removed before the fits, and what it did to their walk.
pub(super) fn thermal_removed_note(
    removed: &[f64; 6],
    measured: &[SensorNoise],
    sensors: &[SensorNoise],
) -> String {
    let mut s = format!(
        "the levels above and the [noise] block are fitted with the thermal part removed from \
         the axes whose coefficient stands {THERMAL_SIGMAS} sigma clear of zero (a drift that \
         follows the temperature is no random walk):\n"
    );
    for (i, _) in removed.iter().enumerate().filter(|(_, c)| **c != 0.0) {
        let (sensor, axis, k) = if i < 3 {
            (&GYRO, i, 0)
        } else {
            (&ACCEL, i - 3, 1)
        };
        let walk = |sn: &[SensorNoise]| sn[k].ml[axis].walk.value * sensor.factors[3];
        let _ = writeln!(
            s,
            "  {} {}: bias walk {} as measured, {} without the thermal part [{}]",
            sensor.name,
            AXES[axis],
            table::significant(walk(measured), 3),
            table::significant(walk(sensors), 3),
            sensor.labels[3]
                .split('[')
                .nth(1)
                .unwrap_or("")
                .trim_end_matches(']'),
        );
    }
    s
}

/// The console table of [`Thermal`].
pub(super) fn thermal_table(t: &Thermal) -> String {
    let mut s = format!(
        "\nTemperature: {:.2} .. {:.2} deg C over the intervals; each axis regressed on it \
         ({}-s means about each interval's mean; the coefficient as the model's gyro.tbias / \
         accel.tbias; docs/temperature.md)\n",
        t.lo_c,
        t.hi_c,
        ::noise::thermal::BIN_S
    );
    let mut tab = Table::new(&[
        ("axis", Align::Left),
        ("tbias", Align::Right),
        ("sigma", Align::Right),
        ("unit", Align::Left),
        ("variance explained", Align::Right),
        ("Allan dev. at tau", Align::Right),
        ("before", Align::Right),
        ("after", Align::Right),
        ("unit ", Align::Left),
    ]);
    for (i, a) in t.axes.iter().enumerate() {
        // In the model's convention: a gyro's output is w - nu, so its `gyro.tbias` is the
        // negative of the output's slope; an accelerometer's output is f + df.
        let (name, f, unit, adev_unit) = if i < 3 {
            (
                format!("gyro {}", AXES[i]),
                -1.0 / sins_model::units::DEG_PER_HOUR,
                "deg/h/K",
                "deg/h",
            )
        } else {
            (format!("accel {}", AXES[i - 3]), 1.0, "m/s^2/K", "m/s^2")
        };
        tab.row(vec![
            name,
            table::significant(a.coefficient * f, 3),
            table::sigma(a.sigma * f.abs()),
            unit.into(),
            format!("{:.0} %", 100.0 * a.explained),
            format!("{} s", table::compact(a.tau_s)),
            table::significant(a.adev_before * f.abs(), 3),
            table::significant(a.adev_after * f.abs(), 3),
            adev_unit.into(),
        ]);
    }
    s += &tab.render();
    s
}

/// [`Thermal`] in the JSON file (SI: rad/s/K, m/s^2/K; Allan deviations in rad/s and m/s^2).
pub(super) fn thermal_json(t: &Thermal) -> Value {
    // The gyros' coefficients in the model's convention (`gyro.tbias`: the output is w - nu).
    let gyro: Vec<::noise::thermal::AxisThermal> = t.axes[..3]
        .iter()
        .map(|a| ::noise::thermal::AxisThermal {
            coefficient: -a.coefficient,
            ..a.clone()
        })
        .collect();
    json!({
        "min_c": t.lo_c,
        "max_c": t.hi_c,
        "bin_s": ::noise::thermal::BIN_S,
        "gyro_tbias": gyro,
        "accel_tbias": &t.axes[3..],
    })
}
