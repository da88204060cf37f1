//! The JSON file of `sins-calib noise` (`--json`, docs/noise.md): the intervals used and, per
//! sensor and axis, the levels of the maximum-likelihood fit with their profile intervals, the
//! Allan fit's terms, statistics and curve.

use crate::commands::noise::model::{AXES, Sensor, SensorNoise};
use ::noise::allan::AllanPoint;
use ::noise::fit::Term;
use ::noise::likelihood::{Level, MlFit};
use serde_json::{Map, Value, json};
use std::ops::Range;

/// Where the levels come from: the recording, the records used and the intervals they are in.
pub(crate) struct Recording<'a> {
    /// The IMU file as named.
    pub(crate) file: &'a str,
    /// Whether the whole recording is used (split at gaps only).
    pub(crate) whole: bool,
    /// The intervals used (record ranges) and the time stamps of their first and last records.
    pub(crate) intervals: &'a [Range<usize>],
    pub(crate) times: &'a [(f64, f64)],
    /// Records in the file and their median interval (s).
    pub(crate) records: usize,
    pub(crate) median: f64,
}

/// The JSON of both sensors' fits (`sensors`: gyro, accelerometer) and the `[noise]` block.
pub(crate) fn json_of(rec: &Recording<'_>, sensors: &[SensorNoise], block: &str) -> Value {
    let mut root = Map::new();
    root.insert("imu".into(), json!(rec.file));
    root.insert("records".into(), json!(rec.records));
    root.insert("median_interval_s".into(), json!(rec.median));
    root.insert("whole_recording".into(), json!(rec.whole));
    root.insert(
        "intervals".into(),
        Value::Array(
            rec.intervals
                .iter()
                .zip(rec.times)
                .map(|(r, t)| {
                    json!({
                        "first_record": r.start,
                        "last_record": r.end - 1,
                        "start_s": t.0,
                        "end_s": t.1,
                    })
                })
                .collect(),
        ),
    );
    for (s, sn) in [
        &crate::commands::noise::model::GYRO,
        &crate::commands::noise::model::ACCEL,
    ]
    .into_iter()
    .zip(sensors)
    {
        root.insert(s.key.into(), Value::Object(sensor_json(s, sn)));
    }
    root.insert("noise_toml".into(), json!(block));
    Value::Object(root)
}

/// One sensor's object: the levels of every term per axis, the Gauss-Markov bias, the
/// likelihood fit's statistics, the Allan fit's terms, statistics and curve.
fn sensor_json(s: &Sensor, sn: &SensorNoise) -> Map<String, Value> {
    let mut m = Map::new();
    for j in 0..5 {
        term_levels(&mut m, s, sn, j);
    }
    gauss_markov_levels(&mut m, s, sn);
    m.insert(
        "ml".into(),
        json!(
            sn.ml
                .iter()
                .map(|f| ml_statistics(s, f))
                .collect::<Vec<_>>()
        ),
    );
    let (floors, slow) = crate::commands::noise::slow_terms::sensor_json(s, sn);
    m.insert("floor".into(), floors);
    m.insert("slow_terms".into(), slow);
    m.insert(
        "terms".into(),
        json!(
            sn.axes
                .iter()
                .map(|a| a
                    .fit
                    .terms
                    .iter()
                    .filter(|e| e.included)
                    .map(|e| e.term.name())
                    .collect::<Vec<_>>())
                .collect::<Vec<_>>()
        ),
    );
    m.insert(
        "fit".into(),
        json!(
            sn.axes
                .iter()
                .map(|a| allan_statistics(s, &a.fit))
                .collect::<Vec<_>>()
        ),
    );
    m.insert(
        "curve".into(),
        Value::Array(
            sn.axes
                .iter()
                .enumerate()
                .map(|(i, a)| curve_json(s, AXES[i], &a.curve.points))
                .collect(),
        ),
    );
    m
}

/// Term `j` of every axis: the white level and walk the maximum-likelihood values, their sigma
/// the mean half-width of the profile interval, and its ends; the other terms the Allan fit's
/// with their sigmas.
fn term_levels(m: &mut Map<String, Value>, s: &Sensor, sn: &SensorNoise, j: usize) {
    let ml = |f: &MlFit| match j {
        1 => Some(f.white),
        3 => Some(f.walk),
        _ => None,
    };
    if ml(&sn.ml[0]).is_some() {
        let get = |g: fn(&Level) -> f64| -> Vec<f64> {
            sn.ml
                .iter()
                .map(|f| ml(f).map_or(0.0, |l| g(&l)) * s.factors[j])
                .collect()
        };
        m.insert(s.keys[j].into(), json!(get(|l| l.value)));
        m.insert(
            format!("{}_sigma", s.keys[j]),
            json!(get(Level::mean_half_width)),
        );
        m.insert(format!("{}_lower", s.keys[j]), json!(get(|l| l.lower)));
        m.insert(format!("{}_upper", s.keys[j]), json!(get(|l| l.upper)));
        return;
    }
    // An Allan fit that fails its own check gives no result: null (its figures are under
    // `fit[axis].orientation_only`).
    let of = |get: fn(&::noise::fit::TermEstimate) -> f64| -> Vec<Option<f64>> {
        sn.axes
            .iter()
            .map(|a| a.fit.passes().then(|| get(&a.fit.terms[j]) * s.factors[j]))
            .collect()
    };
    let (vals, sig) = (of(|e| e.value), of(|e| e.sigma));
    m.insert(s.keys[j].into(), json!(vals));
    m.insert(format!("{}_sigma", s.keys[j]), json!(sig));
}

/// The Gauss-Markov bias of the maximum-likelihood fit (0 and null where not selected).
fn gauss_markov_levels(m: &mut Map<String, Value>, s: &Sensor, sn: &SensorNoise) {
    let gm_key = s.keys[2].replace("bias_instability", "gauss_markov");
    let gm = |g: fn(&Level) -> f64| -> Vec<f64> {
        sn.ml
            .iter()
            .map(|f| f.gauss_markov.map_or(0.0, |x| g(&x.sigma)) * s.factors[2])
            .collect()
    };
    m.insert(gm_key.clone(), json!(gm(|l| l.value)));
    m.insert(format!("{gm_key}_sigma"), json!(gm(Level::mean_half_width)));
    m.insert(format!("{gm_key}_lower"), json!(gm(|l| l.lower)));
    m.insert(format!("{gm_key}_upper"), json!(gm(|l| l.upper)));
    m.insert(
        "gauss_markov_tc_s".into(),
        json!(
            sn.ml
                .iter()
                .map(|f| f.gauss_markov.map(|g| g.correlation_time_s))
                .collect::<Vec<_>>()
        ),
    );
}

/// An axis's maximum-likelihood statistics: the selection, the check, the blocks.
fn ml_statistics(s: &Sensor, f: &MlFit) -> Value {
    json!({
        "oscillation": crate::commands::noise::slow_terms::oscillation_json(s, f),
        "gauss_markov": f.gauss_markov.is_some(),
        "lr_statistic": f.lr_statistic,
        "lr_p_value": f.lr_p_value,
        "check_p_value": f.whiteness.map(|w| w.p_value),
        "check_window_s": f.whiteness.map(|w| w.window_blocks as f64 * f.block_s),
        "check_variance_ratio": f.whiteness.map(|w| w.variance_ratio),
        "neg2_log_likelihood": f.neg2_log_likelihood,
        "passes": f.passes(),
        "correlation_s": f.correlation_s,
        "tc_at_bound": f.tc_at_bound,
        "block_s": f.block_s,
        "blocks": f.blocks,
    })
}

/// An axis's Allan fit: its statistics and misfits, and its own white level and walk (for
/// comparison with the likelihood's).
fn allan_statistics(s: &Sensor, fit: &::noise::fit::NoiseFit) -> Value {
    let (w, k) = (fit.term(Term::White), fit.term(Term::RandomWalk));
    let mut o = Map::new();
    o.insert("chi2".into(), json!(fit.chi2));
    o.insert("dof".into(), json!(fit.dof));
    o.insert("p_value".into(), json!(fit.p_value));
    o.insert("sigma_scale".into(), json!(fit.sigma_scale));
    o.insert("passes".into(), json!(fit.passes()));
    o.insert("tau_min_s".into(), json!(fit.tau_min_s));
    o.insert("misfits".into(), json!(fit.misfits));
    let mut levels = Map::new();
    levels.insert(s.keys[1].into(), json!(w.value * s.factors[1]));
    levels.insert(
        format!("{}_sigma", s.keys[1]),
        json!(w.sigma * s.factors[1]),
    );
    levels.insert(s.keys[3].into(), json!(k.value * s.factors[3]));
    levels.insert(
        format!("{}_sigma", s.keys[3]),
        json!(k.sigma * s.factors[3]),
    );
    // A fit that fails its own check gives no result: its levels null, the figures kept under
    // `orientation_only` (the terms the fit took, at its optimum).
    if fit.passes() {
        o.extend(levels);
    } else {
        for key in levels.keys() {
            o.insert(key.clone(), Value::Null);
        }
        let mut fig = Map::new();
        for (j, (e, key)) in fit.terms.iter().zip(s.keys).enumerate() {
            if e.included {
                fig.insert(key.into(), json!(e.value * s.factors[j]));
            }
        }
        o.insert("orientation_only".into(), Value::Object(fig));
    }
    Value::Object(o)
}

/// An axis's Allan deviation curve in the report unit: tau, the deviation and its 68 %
/// interval, the degrees of freedom and noise types.
fn curve_json(s: &Sensor, axis: &str, p: &[AllanPoint]) -> Value {
    let (k, f) = (s.adev_key, s.adev_factor);
    let mut c = Map::new();
    c.insert("axis".into(), json!(axis));
    c.insert(
        "tau_s".into(),
        json!(p.iter().map(|x| x.tau_s).collect::<Vec<_>>()),
    );
    for (name, get) in [
        ("adev", (|x: &AllanPoint| x.adev) as fn(_) -> f64),
        ("lower", |x| x.lower),
        ("upper", |x| x.upper),
    ] {
        c.insert(
            format!("{name}_{k}"),
            json!(p.iter().map(|x| get(x) * f).collect::<Vec<_>>()),
        );
    }
    c.insert(
        "edf".into(),
        json!(p.iter().map(|x| x.edf).collect::<Vec<_>>()),
    );
    c.insert(
        "noise_type".into(),
        json!(p.iter().map(|x| x.noise_type).collect::<Vec<_>>()),
    );
    Value::Object(c)
}
