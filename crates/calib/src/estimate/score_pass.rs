//! The extended information pass behind the score tests of a calibration's verdict: once the
//! fit has converged, one more pass over the data with every candidate term the recording can
//! test appended to the model (their prior means zero), linearised about the fit's estimates.
//! Its posterior gives the score test of every candidate at once
//! ([`crate::check::score::term_scores`]): no refit per candidate.

use super::{Estimate, EstimateError, Feedback, Nominal, PassInputs, run_pass};
use crate::check::score::ExtendedPosterior;
use crate::config::RunConfig;
use crate::model::layout::{StateLayout, non_instrument_priors};
use sins_model::candidates::{Candidate, CorrectionPart, ThermalPart};
use sins_model::terms::{ErrorModel, Sensor};

/// The smallest span of the records' temperatures (K) over which the thermal candidates are
/// tested: below it their effect cannot be told from the constant biases and scale factors.
pub const MIN_THERMAL_SPAN_K: f64 = 0.1;

/// The candidate terms a fit of `layout` tests, with their prior sigmas (the unit's grade's):
/// every candidate that is a state (not the gyro bias random walk, a noise process), not
/// already in the model, and, for the thermal ones, only when the records' temperature spans
/// [`MIN_THERMAL_SPAN_K`].
pub fn testable_candidates(
    config: &RunConfig,
    layout: &StateLayout,
    temperature_span_k: Option<f64>,
) -> Vec<(Candidate, f64)> {
    let grade = config.unit_grade();
    Candidate::ALL
        .into_iter()
        .filter(|c| *c != Candidate::GyroBiasDrift)
        .filter(|c| !c.is_thermal() || temperature_span_k.is_some_and(|s| s >= MIN_THERMAL_SPAN_K))
        .filter(|c| c.param_names().iter().all(|n| layout.index(n).is_none()))
        .map(|c| (c, c.prior_sigma(grade)))
        .collect()
}

/// The span of the records' temperature (K) from which `calibrate` carries the thermal bias
/// terms the model lacks, at the unit's grade's prior: the temperature moved and the base
/// parameters are otherwise those of no temperature in particular, with sigmas that ignore it
/// (a 0.005 deg/h/K gyro coefficient, 1-2 sigma per axis on the paper's program, left its gyro
/// biases 6.6 sigma off over a 14-K warm-up). Carried, the coefficients are estimated, the base
/// parameters are those at the reference temperature and their sigmas include the
/// coefficients' uncertainty.
pub const CARRY_THERMAL_SPAN_K: f64 = 1.0;

/// `layout` with the thermal bias terms of the triads that have no thermal term, when the
/// records' temperature spans [`CARRY_THERMAL_SPAN_K`] (`span_k`); with the ids carried.
pub(super) fn with_thermal_biases(
    config: &RunConfig,
    layout: &StateLayout,
    span_k: Option<f64>,
) -> Option<(StateLayout, Vec<String>)> {
    if span_k.is_none_or(|s| s < CARRY_THERMAL_SPAN_K) {
        return None;
    }
    // Whether the model has a thermal term of the triad; the bias terms, from their
    // declarations.
    let has = |sensor: Sensor| {
        Candidate::thermal()
            .filter(|c| c.sensor() == sensor)
            .any(|c| c.param_names().iter().any(|n| layout.index(n).is_some()))
    };
    let is_bias = |c: &Candidate| {
        matches!(
            c.declaration().correction,
            CorrectionPart::Thermal(ThermalPart::Bias)
        )
    };
    let grade = config.unit_grade();
    let extra: Vec<(Candidate, f64)> = Candidate::thermal()
        .filter(is_bias)
        .filter(|c| !has(c.sensor()))
        .map(|c| (c, c.prior_sigma(grade)))
        .collect();
    if extra.is_empty() {
        return None;
    }
    let ext = extended_layout(config, layout, &extra)?;
    Some((ext, extra.iter().map(|(c, _)| c.id().to_string()).collect()))
}

/// `layout` with the terms `extra` appended to its instrument model (its own terms kept, with
/// their priors).
pub(super) fn extended_layout(
    config: &RunConfig,
    layout: &StateLayout,
    extra: &[(Candidate, f64)],
) -> Option<StateLayout> {
    let mut model = ErrorModel::paper(&config.priors_si());
    let paper_terms = model.terms().len();
    for term in layout.model.terms().iter().skip(paper_terms) {
        let names: Vec<String> = term.params().iter().map(|p| p.name.clone()).collect();
        let c = Candidate::ALL
            .into_iter()
            .find(|c| c.param_names() == names)?;
        model.push(c.term(term.params().first()?.prior_sigma)?);
    }
    for &(c, sigma) in extra {
        model.push(c.term(sigma)?);
    }
    let mut ext = StateLayout::new(
        model,
        &non_instrument_priors(config),
        layout.install.is_some(),
        layout.base.is_some(),
    );
    ext.gyro_drift = layout.gyro_drift;
    ext.accel_drift = layout.accel_drift;
    Some(ext)
}

/// The extended pass of a fit whose inputs are `inp` (the fit's own layout, without the start
/// attitude's copy) and whose last estimates are `nominal`; `feedback` as the fit's later
/// passes. `None` when the recording tests no candidate.
pub(super) fn extended_pass(
    inp: &PassInputs,
    imu: &mut dyn crate::estimate::ImuSource,
    nominal: &Nominal,
    feedback: Feedback,
    estimate: &Estimate,
) -> Result<Option<ExtendedPosterior>, EstimateError> {
    let span = estimate
        .temperature
        .as_ref()
        .and_then(|t| t.max_c.zip(t.min_c).map(|(a, b)| a - b));
    let extra = testable_candidates(inp.config, inp.layout, span);
    if extra.is_empty() {
        return Ok(None);
    }
    let Some(ext) = extended_layout(inp.config, inp.layout, &extra) else {
        return Ok(None);
    };
    let totals: Vec<f64> = ext
        .entries()
        .iter()
        .map(|e| inp.layout.index(&e.name).map_or(0.0, |i| nominal.totals[i]))
        .collect();
    let ext_nominal = Nominal {
        totals,
        c_start: nominal.c_start,
    };
    let smoother = ext.with_start_attitude();
    let ext_inp = PassInputs {
        layout: &smoother,
        ..*inp
    };
    // Its sensitivity to a specific-force offset is not asked for: that of the fit's own
    // last pass is the one carried into its covariance.
    let (est, _, _) = run_pass(
        &ext_inp,
        imu,
        Some(&ext_nominal),
        feedback,
        false,
        &mut |_| {},
    )?;
    let range = StateLayout::INSTRUMENT..ext.dim();
    let names: Vec<String> = est.names[range.clone()].to_vec();
    let terms = extra
        .iter()
        .map(|(c, _)| {
            let ix = c
                .param_names()
                .iter()
                .filter_map(|n| names.iter().position(|m| m == n))
                .collect();
            (c.id().to_string(), ix)
        })
        .collect();
    Ok(Some(ExtendedPosterior {
        names,
        prior_sigma: est.prior_sigma[range.clone()].to_vec(),
        values: est.values[range.clone()].to_vec(),
        cov: est
            .cov
            .view((range.start, range.start), (range.len(), range.len()))
            .into_owned(),
        terms,
    }))
}

/// When the configuration asks for the score tests (`filter.score_terms`), run the extended
/// pass of a fit ([`extended_pass`]) about its last estimates `nominal` and keep its posterior
/// in `estimate`; the tilt is fed back where the fit's later passes fed it back (a recording
/// of rests whose gyro noise walks the tilt, `tilt_walks`). The pass carries terms the data may
/// not support (a unit far from the base model's linear reach): its failure leaves the fit as
/// it is, with the reason in [`Estimate::extended_error`].
pub(super) fn attach(
    inp: &PassInputs,
    imu: &mut dyn crate::estimate::ImuSource,
    nominal: Option<&Nominal>,
    tilt_walks: bool,
    estimate: &mut Estimate,
) {
    let Some(nominal) = nominal.filter(|_| inp.config.filter.score_terms) else {
        return;
    };
    let feedback = if matches!(inp.motion, super::Motion::Rests { .. }) && tilt_walks {
        Feedback::Tilt
    } else {
        Feedback::None
    };
    match extended_pass(inp, imu, nominal, feedback, estimate) {
        Ok(p) => estimate.extended = p,
        Err(e) => estimate.extended_error = Some(e.to_string()),
    }
}
