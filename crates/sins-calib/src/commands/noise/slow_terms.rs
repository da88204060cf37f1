//! `sins-calib noise`: the slow terms, bias instability and walk. The bias instability read off
//! a flat floor of the Allan curve, and whether the rests are long enough to tell either at all
//! ([`::noise::floor`]); an oscillation the likelihood's blocks were chosen above
//! (docs/noise.md, "Oscillations, floors and short rests").

use crate::commands::noise::consistency::walk_unit;
use crate::commands::noise::model::{AXES, Sensor, SensorNoise};
use crate::render::table;
use ::noise::floor::{self, FLOOR_SPAN, Floor, MIN_WALK_BOUND_TAU_S, SlowTerms};
use ::noise::likelihood::MlFit;
use serde_json::{Value, json};
use std::fmt::Write as _;

/// Whether the rests of each axis of a sensor are long enough for the slow terms.
pub(crate) fn slow_terms(sn: &SensorNoise) -> Vec<SlowTerms> {
    sn.axes
        .iter()
        .zip(&sn.ml)
        .map(|(a, m)| floor::slow_terms(&a.curve, m))
        .collect()
}

/// The floor of each axis's curve.
pub(crate) fn floors(sn: &SensorNoise) -> Vec<Option<Floor>> {
    sn.axes
        .iter()
        .zip(&sn.ml)
        .map(|(a, m)| floor::flicker_floor(&a.curve, a.fit.tau_min_s, m.white.value))
        .collect()
}

fn sig(x: f64) -> String {
    if x.is_finite() {
        table::significant(x, 3)
    } else {
        "inf".into()
    }
}

/// What a walk must dominate to be told: the floor where the curve shows one (the walk is then
/// fitted with it, [`floor::walk_beyond_floor`]), a flat excess under the walk that is no floor
/// ([`floor::floor_under_walk`]), else the white noise.
fn dominated(st: &SlowTerms) -> &'static str {
    match (&st.walk_beyond_floor, st.bias_instability) {
        (Some(_), true) => "floor",
        // A flat excess under the walk that does not dominate two octaves: no bias
        // instability, but the walk is fitted with it (`floor::floor_under_walk`).
        (Some(_), false) => "flat excess under it",
        (None, _) => "white noise",
    }
}

/// Why the rests do not tell a walk: the longest rest and how far the curve reaches.
pub(crate) fn walk_not_determined(st: &SlowTerms) -> String {
    let reach = format!(
        "the longest rest {} s (the curve to {} s)",
        sig(st.longest_rest_s),
        sig(st.longest_tau_s)
    );
    if st.walk_bound && st.walk_crossover_s.is_finite() {
        format!(
            "{reach} is too short: its interval reaches 0, but a bound needs the curve to reach \
             {} s (this one allows a walk that would dominate the {} from {} s)",
            sig(MIN_WALK_BOUND_TAU_S),
            dominated(st),
            sig(st.walk_crossover_s)
        )
    } else if let Some((tau_s, ratio)) = st.walk_contradicted_at {
        format!(
            "the curve beyond {} s, from which the walk would dominate the white noise, lies \
             below it (at {} s {} times below its upper bound at {} % over those points): a \
             correlation of a few seconds or a unit settling, not a walk",
            sig(st.walk_crossover_s),
            sig(tau_s),
            table::significant(ratio, 2),
            table::compact(100.0 * ::noise::floor::WALK_CONTRADICTION_LEVEL)
        )
    } else if st.walk_crossover_s.is_finite() {
        format!(
            "{reach} is too short: the walk would dominate the {} from {} s, and two octaves \
             beyond that are needed",
            dominated(st),
            sig(st.walk_crossover_s)
        )
    } else {
        format!("{reach}: no walk bounded")
    }
}

/// The report's lines: per axis the bias instability from the floor (or not determined) and
/// whether the walk is determined.
pub(crate) fn report(s: &Sensor, sn: &SensorNoise) -> String {
    let unit = s.adev_unit;
    let f = s.factors[2];
    let mut out = format!("\n{}, bias instability and walk:\n", s.name);
    for (a, (st, fl)) in slow_terms(sn).iter().zip(floors(sn)).enumerate() {
        let b = match &fl {
            Some(fl) => format!(
                "bias instability {} [{}, {}] {unit} from the floor (the Allan deviation's \
                 excess over the likelihood's white noise, flat at {} {unit} over 0.664, \
                 dominating from {} to {} s; likelihood ratio e^{} over a walk's rising excess)",
                sig(fl.value * f),
                sig(fl.lower * f),
                sig(fl.upper * f),
                sig(fl.adev * f),
                sig(fl.from_tau_s),
                sig(fl.to_tau_s),
                table::compact(fl.ln_lr_over_walk.round())
            ),
            None => format!(
                "bias instability not determined: no flat floor (the longest rest {} s, the \
                 curve to {} s)",
                sig(st.longest_rest_s),
                sig(st.longest_tau_s)
            ),
        };
        // Beside a floor the walk is the one fitted with it, which the report gives here (the
        // likelihood's, whose model has no floor, takes the floor's slow power in).
        let wf = s.factors[3];
        let beside = st.walk_beyond_floor.as_ref().map_or(String::new(), |w| {
            format!(
                " {} [{}, {}] {}, fitted with the {}",
                sig(w.value * wf),
                sig(w.lower * wf),
                sig(w.upper * wf),
                walk_unit(s),
                dominated(st)
            )
        });
        let w = match (st.walk, st.walk_bound) {
            (true, false) => format!(
                "walk{beside} determined (the curve reaches {} s, {} times the {} s from which \
                 the walk dominates the {}, and follows it)",
                sig(st.longest_tau_s),
                table::compact(FLOOR_SPAN),
                sig(st.walk_crossover_s),
                dominated(st)
            ),
            (true, true) => format!(
                "walk{beside} bounded: its interval reaches 0 (a walk at its upper end would \
                 equal the {} at {} s; the curve reaches {} s)",
                dominated(st),
                sig(st.walk_crossover_s),
                sig(st.longest_tau_s)
            ),
            (false, _) => format!("walk not determined: {}", walk_not_determined(st)),
        };
        let _ = writeln!(out, "  {}: {b}; {w}", AXES[a]);
    }
    out
}

/// The note on an axis's oscillation, where its samples have one.
pub(crate) fn oscillation_note(s: &Sensor, axis: &str, m: &MlFit) -> Option<String> {
    let o = m.oscillation?;
    Some(format!(
        "  {axis}: an oscillation in the samples: period {} s ({} Hz), root mean square {} {}, \
         autocorrelation of the first differences {:+.2} at that lag; they stay correlated to \
         {} s, and blocks ten times that would take the slow noise for white: the blocks are \
         ten periods, over which it averages out\n",
        sig(o.period_s),
        sig(1.0 / o.period_s),
        sig(o.rms * s.adev_factor),
        s.adev_unit,
        o.autocorrelation,
        sig(o.correlated_to_s),
    ))
}

/// The JSON of one sensor's slow terms: per axis the floor (null without one) and whether the
/// walk and the bias instability are determined, with the longest rest.
pub(crate) fn sensor_json(s: &Sensor, sn: &SensorNoise) -> (Value, Value) {
    let f = s.factors[2];
    let floors: Vec<Value> = floors(sn)
        .iter()
        .map(|fl| match fl {
            Some(fl) => json!({
                format!("adev_{}", s.adev_key): fl.adev * s.adev_factor,
                "from_tau_s": fl.from_tau_s,
                "to_tau_s": fl.to_tau_s,
                "ln_lr_over_walk": fl.ln_lr_over_walk,
                "ln_lr_over_none": fl.ln_lr_over_none,
                "ln_lr_over_gauss_markov": fl.ln_lr_over_gauss_markov,
                "points": fl.points,
                "value": fl.value * f,
                "lower": fl.lower * f,
                "upper": fl.upper * f,
            }),
            None => Value::Null,
        })
        .collect();
    let slow: Vec<Value> = slow_terms(sn)
        .iter()
        .map(|st| {
            json!({
                "longest_rest_s": st.longest_rest_s,
                "longest_tau_s": st.longest_tau_s,
                "walk_crossover_s": st.walk_crossover_s.is_finite().then_some(st.walk_crossover_s),
                "walk_determined": st.walk,
                "walk_bound": st.walk_bound,
                "walk_contradicted_at_tau_s": st.walk_contradicted_at.map(|(tau_s, _)| tau_s),
                "bias_instability_determined": st.bias_instability,
                "walk_beside_floor": st.walk_beyond_floor.as_ref().map(|w| json!({
                    "value": w.value * s.factors[3],
                    "lower": w.lower * s.factors[3],
                    "upper": w.upper * s.factors[3],
                    format!("floor_adev_{}", s.adev_key): w.floor_avar.sqrt() * s.adev_factor,
                })),
            })
        })
        .collect();
    (Value::Array(floors), Value::Array(slow))
}

/// The JSON of an axis's oscillation (null without one).
pub(crate) fn oscillation_json(s: &Sensor, m: &MlFit) -> Value {
    match m.oscillation {
        Some(o) => json!({
            "period_s": o.period_s,
            format!("rms_{}", s.adev_key): o.rms * s.adev_factor,
            "autocorrelation": o.autocorrelation,
            "correlated_to_s": o.correlated_to_s,
        }),
        None => Value::Null,
    }
}

/// The scatter of the rests' 1-s means each axis's likelihood model implies, and pooled over
/// the axes as `calibrate` pools it: the figure `calibrate` measures and uses as its white
/// noise, which a walk inside the rests adds to (docs/noise.md, "`noise` and `calibrate`").
pub(crate) fn one_second_line(s: &Sensor, sn: &SensorNoise, whole_seconds: &[usize]) -> String {
    let per: Vec<Option<f64>> = sn
        .ml
        .iter()
        .map(|m| m.model().one_second_scatter(whole_seconds))
        .collect();
    if per.iter().any(Option::is_none) {
        return String::new();
    }
    let v: Vec<f64> = per.into_iter().flatten().collect();
    let pooled = (v.iter().sum::<f64>() / v.len() as f64).sqrt();
    let f = s.adev_factor;
    format!(
        "  the scatter of the rests' 1-s means these models imply (white noise and walk; what \
         `calibrate` measures in its rests, the axes pooled): {} {unit}, pooled {} {unit}\n",
        v.iter()
            .zip(AXES)
            .map(|(x, a)| format!("{a} {}", sig(x.sqrt() * f)))
            .collect::<Vec<_>>()
            .join(", "),
        sig(pooled * f),
        unit = s.adev_unit
    )
}
