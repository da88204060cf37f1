//! The one result of a calibration: what every command reports and every output is built from.
//!
//! A fit along a program, of a recording of rests, and each fit of the model-extension loop is
//! a [`Calibration`]: the filter's [`Estimate`], the configuration it ran with, where its noise
//! came from, what the result does to the rests of a recording without a program (its held-out
//! figures), the tests of its innovations, and the one verdict of the run ([`RunVerdict`]),
//! decided here once so that no output can decide it differently. Its file form is
//! [`Calibration::result_file`].

use crate::check::diagnostics::{DiagnosticSettings, Diagnostics, diagnose};
use crate::config::RunConfig;
use crate::estimate::Estimate;
use crate::estimate::noise::NoiseSource;
use crate::estimate::verdict::RunVerdict;
use crate::io::ResultFile;
use crate::motion::free_motion::Evaluation;

/// The result of a calibration with its checks and its verdict.
#[derive(Clone, Debug)]
pub struct Calibration {
    /// The filter's estimate: every state with the posterior covariance, the fit statistics,
    /// the innovations and the segments they belong to.
    pub estimate: Estimate,
    /// The configuration the filter ran with (for a recording of rests whose noise was
    /// measured, the noise levels as finally used).
    pub config: RunConfig,
    /// Where the noise levels came from: the configuration, or the recording's rests.
    pub noise: NoiseSource,
    /// A recording of rests: what the result does to its rests, its known turns and (with a
    /// hold-out) its held-out rests ([`crate::motion::free_motion::evaluate`]); `None` on a
    /// program and in the fits of the model-extension loop.
    pub evaluation: Option<Evaluation>,
    /// The tests of the innovations.
    pub diagnostics: Diagnostics,
    /// The verdict: the configured noise's mean NIS and the diagnostics decide, or, with the
    /// noise measured from the data, the held-out rests and the known turns.
    pub verdict: RunVerdict,
}

impl Calibration {
    /// The calibration of `estimate`: its innovations tested with `settings`, and its verdict.
    pub fn new(
        estimate: Estimate,
        config: RunConfig,
        noise: NoiseSource,
        evaluation: Option<Evaluation>,
        settings: &DiagnosticSettings,
    ) -> Self {
        let diagnostics = diagnose(&estimate.innovations, &estimate.segments, settings);
        let verdict = RunVerdict::of(
            &estimate,
            &noise,
            evaluation.as_ref(),
            Some(&diagnostics),
            estimate.with_turntable(),
        );
        Self {
            estimate,
            config,
            noise,
            evaluation,
            diagnostics,
            verdict,
        }
    }

    /// Whether the noise was measured from these data (the held-out rests decide).
    pub fn noise_measured(&self) -> bool {
        matches!(self.noise, NoiseSource::Measured { .. })
    }

    /// The parameters with their correlation, correction and temperature, as a result file.
    pub fn result_file(&self) -> ResultFile {
        self.estimate.to_result_file()
    }
}
