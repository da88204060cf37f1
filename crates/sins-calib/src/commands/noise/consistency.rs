//! `sins-calib noise`: the maximum-likelihood model against the measured Allan deviation at
//! every averaging time ([`::noise::consistency`]), and where it leaves the band, why: the
//! printed block and the JSON's `ml_band` (docs/noise.md, "The likelihood model against the
//! measured deviation").
//!
//! Its own module, beside the command: the split of the rests needs one more reading of the
//! records, which the command gives as a closure, so that this module does not reach back into
//! it.

use crate::commands::noise::model::{ACCEL, AXES, GYRO, Sensor, SensorNoise};
use crate::render::table;
use ::noise::consistency::{self, AxisCheck, Cause, FamilyCheck, Split, SplitFits};
use ::noise::likelihood::Level;
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::ops::Range;

/// The check of the six axes (gyro x, y, z, accelerometer x, y, z) as one family.
pub(crate) fn check(sensors: &[SensorNoise]) -> FamilyCheck {
    let pairs: Vec<_> = sensors
        .iter()
        .flat_map(|sn| sn.axes.iter().map(|a| &a.curve).zip(&sn.ml))
        .collect();
    consistency::check_family(&pairs)
}

/// The split of the rests of every axis the model leaves the band on (`None` elsewhere): one
/// more reading of the records, which `read` visits as `(record index, six increments)`, each
/// rest held while it lasts (no longer than the Allan sums hold it).
pub(crate) fn splits<E>(
    family: &FamilyCheck,
    sensors: &[SensorNoise],
    intervals: &[Range<usize>],
    median: f64,
    read: impl FnOnce(&mut dyn FnMut(usize, &[f64])) -> Result<(), E>,
) -> Result<Vec<Option<Split>>, E> {
    let mls: Vec<_> = sensors.iter().flat_map(|s| &s.ml).collect();
    let mut fits: Vec<Option<SplitFits>> = family
        .axes
        .iter()
        .zip(&mls)
        .map(|(c, ml)| {
            // The long rests: those the point furthest outside rests on (2m records or more).
            // Not the shortest point outside: there the shorter rests may take part too, and
            // the split would not separate what that point sees from what it does not.
            let m = c.worst()?.m;
            let block = (ml.block_s / median).round().max(1.0) as usize;
            Some(SplitFits::new(median, block, 2 * m))
        })
        .collect();
    if fits.iter().all(Option::is_none) {
        return Ok(vec![None; fits.len()]);
    }
    let mut held: Vec<Vec<f64>> = vec![Vec::new(); fits.len()];
    let mut at = 0usize;
    read(&mut |k, v| {
        while at < intervals.len() && intervals[at].end <= k {
            at += 1;
        }
        let Some(r) = intervals.get(at).filter(|r| r.contains(&k)) else {
            return;
        };
        for (a, f) in fits.iter().enumerate() {
            if f.is_some() {
                held[a].push(v[a]);
            }
        }
        if k + 1 == r.end {
            for (f, h) in fits.iter_mut().zip(&mut held) {
                if let Some(f) = f {
                    f.push(h);
                }
                h.clear();
            }
        }
    })?;
    Ok(fits.into_iter().map(|f| f.map(SplitFits::finish)).collect())
}

/// The sensor and axis of axis index `i` (0..6).
fn sensor_axis(i: usize) -> (&'static Sensor, usize) {
    if i < 3 { (&GYRO, i) } else { (&ACCEL, i - 3) }
}

/// A walk in the sensor's report unit as `value [lower, upper]`.
fn walk_text(s: &Sensor, l: &Level) -> String {
    let f = s.factors[3];
    let g = |x: f64| {
        if x == 0.0 {
            "0".to_string()
        } else if x.is_infinite() {
            "inf".to_string()
        } else {
            table::significant(x * f, 2)
        }
    };
    format!("{} [{}, {}]", g(l.value), g(l.lower), g(l.upper))
}

/// The unit of a sensor's walk, from its column label.
pub(crate) fn walk_unit(s: &Sensor) -> &str {
    s.labels[3]
        .split_once('[')
        .map_or("", |x| x.1.trim_end_matches(']'))
}

/// The printed block: the family's level, per axis within the band or where not and by what
/// factor, and the cause.
pub(crate) fn report(family: &FamilyCheck, splits: &[Option<Split>], median: f64) -> String {
    let mut s = format!(
        "\nmaximum likelihood against the measured Allan deviation (every averaging time from \
         the likelihood's block duration on; the model must lie in the measured deviation's \
         interval at {} per point, Bonferroni over the {} points of the six axes for a \
         family-wise {} %, widened by the model's own 68 % intervals at that level)\n",
        table::significant(1.0 - family.point_level, 5),
        family.points,
        table::compact(100.0 * family.family_level),
    );
    for (i, c) in family.axes.iter().enumerate() {
        let (sensor, axis) = sensor_axis(i);
        let range = match (c.points.first(), c.points.last()) {
            (Some(a), Some(b)) => format!(
                "{} points, {} .. {} s",
                c.points.len(),
                table::significant(a.tau_s, 3),
                table::significant(b.tau_s, 3)
            ),
            _ => "no point at or above the blocks".to_string(),
        };
        if c.passes() {
            // The furthest point said even inside the band: a model several times the data at
            // a long tau is within it only by that point's few degrees of freedom.
            let far = c
                .points
                .iter()
                .max_by(|a, b| a.ratio.ln().abs().total_cmp(&b.ratio.ln().abs()))
                .map_or(String::new(), |p| {
                    format!(
                        "; furthest at {} s, model / measured x{} with {} degrees of freedom",
                        table::significant(p.tau_s, 3),
                        table::significant(p.ratio, 2),
                        table::significant(p.edf, 2)
                    )
                });
            let _ = writeln!(
                s,
                "  {} {}: within the band ({range}{far})",
                sensor.name, AXES[axis]
            );
            continue;
        }
        let outside: Vec<String> = c
            .outside()
            .map(|p| {
                format!(
                    "{} s x{}",
                    table::significant(p.tau_s, 3),
                    table::significant(p.ratio, 2)
                )
            })
            .collect();
        let _ = writeln!(
            s,
            "  {} {}: outside the band at {} (model / measured; {range})",
            sensor.name,
            AXES[axis],
            outside.join(", ")
        );
        if let Some(Some(split)) = splits.get(i) {
            let _ = writeln!(s, "    why: {}", cause_text(sensor, c, split, median));
        }
    }
    s
}

/// The cause of an axis's points outside, as a sentence with its figures.
fn cause_text(sensor: &Sensor, c: &AxisCheck, split: &Split, median: f64) -> String {
    let long_s = table::significant(split.long_records as f64 * median, 3);
    let unit = walk_unit(sensor);
    let walks = match (&split.long_walk, &split.other_walk) {
        (Some(l), Some(o)) => format!(
            "the walk of the {} rest{} of {long_s} s or more (the only ones the point furthest \
             outside, {} s, rests on) is {}, that of the {} shorter rest{} {} {unit}",
            split.long_rests,
            plural(split.long_rests),
            c.worst()
                .map_or("-".into(), |p| table::significant(p.tau_s, 3)),
            walk_text(sensor, l),
            split.other_rests,
            plural(split.other_rests),
            walk_text(sensor, o),
        ),
        (Some(l), None) if split.other_rests == 0 => format!(
            "every rest is {long_s} s or more (no shorter rest to compare with); their walk is \
             {} {unit}",
            walk_text(sensor, l)
        ),
        _ => format!(
            "the walks of the {} rest{} of {long_s} s or more and of the {} shorter could not \
             both be fitted (too few blocks)",
            split.long_rests,
            plural(split.long_rests),
            split.other_rests
        ),
    };
    match consistency::name_cause(c, split) {
        Some(Cause::WalksDiffer { sigmas }) => {
            let drift = if sigmas > 0.0 {
                "the unit drifts more in the shorter rests (after each turn or motion) than over \
                 the long one"
            } else {
                "the long rest drifts more than the shorter ones"
            };
            format!(
                "{walks}: they differ by {} sigma; {drift}, and one walk for all rests cannot \
                 be both",
                table::significant(sigmas.abs(), 2)
            )
        }
        Some(Cause::Shape {
            from_tau_s,
            to_tau_s,
            factor,
            limit,
            falls,
        }) => format!(
            "{walks}{}; their own deviation {} {} times from {} to {} s, where {} {} times: a \
             curve white noise plus a walk cannot follow",
            agree(&split.long_walk, &split.other_walk),
            if falls { "falls" } else { "rises" },
            table::significant(factor, 2),
            table::significant(from_tau_s, 3),
            table::significant(to_tau_s, 3),
            if falls {
                "white noise falls"
            } else {
                "a walk rises"
            },
            table::significant(limit, 2),
        ),
        _ => format!(
            "not named: {walks}{}, and their own deviation bends no faster than white noise \
             and a walk can follow",
            agree(&split.long_walk, &split.other_walk)
        ),
    }
}

/// ", which agree within ... sigma" where both walks were fitted.
fn agree(long: &Option<Level>, other: &Option<Level>) -> String {
    match (long, other) {
        (Some(l), Some(o)) => format!(
            ", which agree ({} sigma apart, below {})",
            table::significant(consistency::walks_sigmas(l, o).abs(), 2),
            table::compact(consistency::WALKS_DIFFER_SIGMAS)
        ),
        _ => String::new(),
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// The family's level, as the JSON's top-level `ml_band`.
pub(crate) fn family_json(family: &FamilyCheck) -> Value {
    json!({
        "family_level": family.family_level,
        "correction": "bonferroni",
        "points": family.points,
        "point_level": family.point_level,
    })
}

/// One sensor's `ml_band` (three axes, `first` the index of its x axis): per axis whether the
/// model lies in the band, every point tested (deviations in the report unit) and the cause.
pub(crate) fn sensor_json(
    sensor: &Sensor,
    family: &FamilyCheck,
    splits: &[Option<Split>],
    first: usize,
    median: f64,
) -> Value {
    let (k, f) = (sensor.adev_key, sensor.adev_factor);
    let wf = sensor.factors[3];
    let level = |l: &Option<Level>| {
        l.map(|l| json!({"value": l.value * wf, "lower": l.lower * wf, "upper": l.upper * wf}))
    };
    Value::Array(
        (first..first + 3)
            .map(|i| {
                let c = &family.axes[i];
                let points: Vec<Value> = c
                    .points
                    .iter()
                    .map(|p| {
                        json!({
                            "tau_s": p.tau_s,
                            format!("measured_{k}"): p.measured * f,
                            format!("model_{k}"): p.model * f,
                            "ratio": p.ratio,
                            "edf": p.edf,
                            "noise_type": p.noise_type,
                            format!("lower_{k}"): p.lower * f,
                            format!("upper_{k}"): p.upper * f,
                            "outside": p.outside,
                        })
                    })
                    .collect();
                let split = splits.get(i).and_then(Option::as_ref);
                let cause = split.map(|s| {
                    json!({
                        "cause": consistency::name_cause(c, s),
                        "long_rest_s": s.long_records as f64 * median,
                        "long_rests": s.long_rests,
                        "other_rests": s.other_rests,
                        format!("long_walk_{}", sensor.keys[3].trim_start_matches("bias_walk_")):
                            level(&s.long_walk),
                        format!("other_walk_{}", sensor.keys[3].trim_start_matches("bias_walk_")):
                            level(&s.other_walk),
                    })
                });
                json!({
                    "passes": c.passes(),
                    "from_tau_s": c.from_tau_s,
                    "points": points,
                    "why": cause,
                })
            })
            .collect(),
    )
}
