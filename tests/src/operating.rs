//! The verdict's operating characteristic: how often a calibration's exit status is 3 on clean
//! simulated runs (false alarms) and how often it names a hidden term's effect (detection), per
//! class of run, effect and size. Used by `cargo xtask operating-characteristic` (the table in
//! `docs/verdict.md`) and, on a small fixed subset, by `tests/tests/operating.rs` in CI.
//!
//! A run is simulated with [`calib::simulate::simulate_run_hidden`] and calibrated as
//! `calibrate` does it ([`calib::estimate::run`] along a program with
//! [`calib::estimate::ProgramOptions::CALIBRATE`], and hand-turned on the rests of a recording
//! without one), with
//! the configured noise; its verdict is [`calib::estimate::verdict::RunVerdict`].
//!
//! Effect sizes are stated as the base-parameter error they cause: a reference magnitude (every
//! parameter of the term at its grade's prior sigma, signs alternating) is simulated without
//! noise and calibrated with the paper's model; its worst |error| / sigma over the base
//! parameters, `z_ref`, is what that magnitude moves a base parameter by, and the effect is
//! scaled by `k / z_ref` for a size of `k` sigma (the model is linear in the effect at these
//! sizes).

use crate::hidden::{case_config, warm_up};
use crate::parallel_map;
use calib::config::RunConfig;
use calib::estimate::calibration::Calibration;
use calib::estimate::{self, HandTurnedRun, MemoryImu, Plan, ProgramOptions, Records, RunKind};
use calib::io::{ImuData, TurntableData};
use calib::model::extension::HiddenEffects;
use calib::model::layout::layout_for;
use calib::motion::rests::Rest;
use sins_model::candidates::Candidate;
use turntable::program::{ProgramSpec, Segment};

/// A class of run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// The paper's program with the turntable angles (28 states), navigation grade.
    ProgramNavigation,
    /// The paper's program, IMU only (24 states), navigation grade.
    ProgramImuOnly,
    /// The paper's program with the turntable angles in a warm-up (20 -> 35 deg C): the
    /// thermal candidates are tested too.
    ProgramWarmUp,
    /// 19 rests joined by 90-degree turns, no program or angles given to the filter,
    /// navigation grade.
    RestsNavigation,
    /// The same 19 rests, consumer grade (MEMS priors and noise).
    RestsConsumer,
}

impl Class {
    /// Every class, in table order.
    pub const ALL: [Class; 5] = [
        Class::ProgramNavigation,
        Class::ProgramImuOnly,
        Class::ProgramWarmUp,
        Class::RestsNavigation,
        Class::RestsConsumer,
    ];

    /// Its name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Class::ProgramNavigation => "paper's program, 28 states, navigation",
            Class::ProgramImuOnly => "paper's program, 24 states, navigation",
            Class::ProgramWarmUp => "paper's program, 28 states, warm-up 20 -> 35 degC",
            Class::RestsNavigation => "19 rests, 24 states, navigation",
            Class::RestsConsumer => "19 rests, 24 states, consumer",
        }
    }

    /// The candidate terms hidden in this class's effect rows.
    pub fn effects(self) -> Vec<Candidate> {
        use Candidate::*;
        match self {
            Class::ProgramNavigation | Class::ProgramImuOnly => vec![
                GyroGSensitivity,
                GyroScaleAsymmetry,
                AccelQuadratic,
                AccelSizeEffect,
                GyroAccelTimeOffset,
            ],
            Class::ProgramWarmUp => vec![GyroTempBias, AccelTempBias, GyroTempScale],
            Class::RestsNavigation | Class::RestsConsumer => {
                vec![GyroGSensitivity, GyroScaleAsymmetry, AccelQuadratic]
            }
        }
    }

    fn rests(self) -> bool {
        matches!(self, Class::RestsNavigation | Class::RestsConsumer)
    }

    fn turntable(self) -> bool {
        matches!(self, Class::ProgramNavigation | Class::ProgramWarmUp)
    }

    /// The run configuration of seed `seed`: the paper's priors and noise at 25 Hz
    /// ([`case_config`]), the class's program, grade and temperature.
    pub fn config(self, seed: u64) -> RunConfig {
        let mut c = case_config(&crate::hidden::negative_control(seed));
        if self == Class::ProgramWarmUp {
            c.temperature = Some(warm_up());
        }
        if self.rests() {
            c.inline_program = Some(nineteen_positions());
        }
        if self == Class::RestsConsumer {
            c.priors.gyro_bias_deg_h = 3600.0;
            c.priors.gyro_scale = 0.02;
            c.priors.gyro_misalignment_arcmin = 60.0;
            c.priors.accel_bias_m_s2 = 0.3;
            c.priors.accel_scale = 0.02;
            c.priors.accel_misalignment_arcmin = 60.0;
            c.noise.gyro_deg_h = 120.0;
            c.noise.accel_m_s2 = 0.0012;
        }
        c
    }
}

/// The 19-position program: a 20-s rest, then 18 turns of 90 degrees (9 s at 10 deg/s) about
/// the gimbals in turn, each followed by a 20-s rest (`tests/tests/rests.rs`'s).
pub fn nineteen_positions() -> ProgramSpec {
    let turns: [(u8, f64); 18] = [
        (3, 10.0),
        (3, 10.0),
        (3, 10.0),
        (3, 10.0),
        (2, 10.0),
        (2, 10.0),
        (2, 10.0),
        (2, 10.0),
        (1, 10.0),
        (3, -10.0),
        (3, -10.0),
        (2, -10.0),
        (2, -10.0),
        (1, 10.0),
        (3, 10.0),
        (2, 10.0),
        (3, -10.0),
        (2, -10.0),
    ];
    let mut segments = vec![Segment::Dwell { duration_s: 20.0 }];
    for (gimbal, rate_deg_s) in turns {
        segments.push(Segment::Rotate {
            gimbal,
            rate_deg_s,
            duration_s: 9.0,
        });
        segments.push(Segment::Dwell { duration_s: 20.0 });
    }
    ProgramSpec {
        name: "19 positions".into(),
        start_deg: [0.0; 3],
        segments,
    }
}

/// What one calibration's verdict said.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Exit status 3.
    pub exit3: bool,
    /// The candidate terms named in its decisive lines.
    pub named: Vec<String>,
    /// The terms the calibration carried on its own (the thermal bias terms of a run whose
    /// temperature moved): their effect is in the model.
    pub carried: Vec<String>,
    /// Its decisive lines.
    pub reasons: Vec<String>,
    /// Its informative lines.
    pub notes: Vec<String>,
    /// The worst |error| / sigma over the base parameters against the truth.
    pub worst_base_sigma: f64,
}

/// Simulate `class` with seed `seed` and the hidden values `values` (SI, by name), noise on or
/// off, and calibrate it as `calibrate` does.
pub fn run(class: Class, seed: u64, values: &[(String, f64)], noise: bool) -> Outcome {
    let (cal, sim) = simulate_and_calibrate(class, seed, values, noise);
    let named = Candidate::ALL
        .iter()
        .map(|c| c.id().to_string())
        .filter(|id| cal.verdict.decisive.iter().any(|l| l.contains(id.as_str())))
        .collect();
    let carried = cal.estimate.carried_terms.clone();
    let worst = worst_base_error(&cal.estimate, &sim.truth).map_or(0.0, |(_, z)| z.abs());
    Outcome {
        exit3: !cal.verdict.fits(),
        named,
        carried,
        reasons: cal.verdict.decisive.clone(),
        notes: cal.verdict.informative.clone(),
        worst_base_sigma: worst,
    }
}

/// Simulate `class` with seed `seed` and the hidden `values`, noise on or off, and calibrate it
/// as `calibrate` does.
fn simulate_and_calibrate(
    class: Class,
    seed: u64,
    values: &[(String, f64)],
    noise: bool,
) -> (Calibration, turntable::simulate::Simulation) {
    let mut config = class.config(seed);
    config.truth.noise = noise;
    let hidden = HiddenEffects {
        values: values.to_vec(),
        gyro_drift: None,
    };
    let sim =
        calib::simulate::simulate_run_hidden(&config, "operating", &hidden).expect("simulation");
    let imu = ImuData::from_samples(&sim.imu);
    (calibrate(class, &config, &imu, &sim.turntable), sim)
}

/// What the score tests could do against a hidden effect: its non-centrality and the power it
/// gives, predicted rather than counted.
///
/// On the noise-free run the efficient score of the hidden term is its information times the
/// effect, so its statistic is the non-centrality `lambda` of its test on noisy runs (the
/// linear-Gaussian model; [`calib::check::score::solo_scores`], the term alone against the
/// base model). From it:
/// - the power of the verdict's own test of the term: chi-square with the term's degrees of
///   freedom at the per-term level (1 % over the number of terms tested), against the
///   non-central chi-square with `lambda`;
/// - the power of the best test any method could make at 1 %, one that knows the effect's
///   direction and sign (Neyman-Pearson: the one-sided normal test of the score along it,
///   `Phi(sqrt(lambda) - z_0.99)`). Where even that is below a detection target, no test on
///   these data meets the target: the term is too nearly a combination of the base parameters
///   on this run.
#[derive(Clone, Copy, Debug)]
pub struct Power {
    /// The non-centrality of the term's score test.
    pub noncentrality: f64,
    /// Its degrees of freedom.
    pub dof: usize,
    /// The verdict's per-term level (1 % over the terms tested).
    pub per_term_level: f64,
    /// The predicted rate at which the verdict's test calls the term for.
    pub verdict_test: f64,
    /// The power of the best test at 1 % that knows the effect.
    pub best_test: f64,
}

/// The score tests' [`Power`] against `term` hidden with `values` in `class` (noise-free run,
/// seed 1). `None` where the run gave no extended pass or the term no information.
pub fn power(class: Class, term: Candidate, values: &[(String, f64)]) -> Option<Power> {
    use calib::check::score::solo_scores;
    let (cal, _) = simulate_and_calibrate(class, 1, values, false);
    let pass = cal.estimate.extended.as_ref()?;
    let k = pass.terms.iter().position(|(id, _)| id == term.id())?;
    let solo = solo_scores(pass)?;
    let tested = solo.iter().filter(|(t, _)| t.dof > 0).count().max(1);
    let test = &solo[k].0;
    if test.dof == 0 {
        return None;
    }
    let per_term_level = calib::estimate::verdict::SCORE_LEVEL / tested as f64;
    Some(Power {
        noncentrality: test.statistic,
        dof: test.dof,
        per_term_level,
        verdict_test: noncentral_chi_square_sf(
            calib::check::score::critical_value(per_term_level, test.dof),
            test.dof,
            test.statistic,
        ),
        best_test: best_test_power(test.statistic, 0.01),
    })
}

/// `Phi(sqrt(lambda) - z_(1 - level))`: the power of the one-sided normal test at `level` of
/// an effect whose statistic has non-centrality `lambda` ([`Power::best_test`]).
pub fn best_test_power(lambda: f64, level: f64) -> f64 {
    use statrs::distribution::{ContinuousCDF, Normal};
    let n = Normal::new(0.0, 1.0).expect("standard normal");
    n.cdf(lambda.max(0.0).sqrt() - n.inverse_cdf(1.0 - level))
}

/// Upper tail at `x` of the non-central chi-square distribution with `dof` degrees of freedom
/// and non-centrality `lambda`: the Poisson(`lambda / 2`) mixture of central chi-squares with
/// `dof + 2 j` degrees of freedom, summed over `j` within 12 standard deviations of its mean.
pub fn noncentral_chi_square_sf(x: f64, dof: usize, lambda: f64) -> f64 {
    use calib::check::score::chi_square_sf;
    use statrs::function::gamma::ln_gamma;
    let mean = 0.5 * lambda.max(0.0);
    if mean == 0.0 {
        return chi_square_sf(x, dof);
    }
    let spread = 12.0 * mean.sqrt() + 12.0;
    let lo = (mean - spread).max(0.0) as usize;
    let hi = (mean + spread) as usize;
    (lo..=hi)
        .map(|j| {
            let jf = j as f64;
            let ln_w = jf * mean.ln() - mean - ln_gamma(jf + 1.0);
            ln_w.exp() * chi_square_sf(x, dof + 2 * j)
        })
        .sum::<f64>()
        .clamp(0.0, 1.0)
}

/// The base parameter farthest from its truth, and how far (signed, in its sigmas).
pub fn worst_base_error(
    est: &calib::estimate::Estimate,
    truth: &turntable::simulate::Truth,
) -> Option<(String, f64)> {
    est.names
        .iter()
        .enumerate()
        .skip(calib::model::layout::StateLayout::INSTRUMENT)
        .filter_map(|(i, n)| {
            let t = truth.get(n)?;
            Some((n.clone(), (est.values[i] - t) / est.cov[(i, i)].sqrt()))
        })
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
}

fn calibrate(
    class: Class,
    config: &RunConfig,
    imu: &ImuData,
    turntable: &[turntable::simulate::TurntableSample],
) -> Calibration {
    let layout = layout_for(config, class.turntable());
    if class.rests() {
        let program = config.program().expect("program");
        let rests: Vec<Rest> = program
            .pieces()
            .iter()
            .filter(|p| p.rate == [0.0; 3])
            .map(|p| Rest { t0: p.t0, t1: p.t1 })
            .collect();
        let mut config = config.clone();
        config.inline_program = None;
        let run = HandTurnedRun {
            rests: &rests,
            turns: &[],
            holdout: None,
            measured: None,
        };
        let plan = Plan {
            config: &config,
            layout: Some(&layout),
            kind: RunKind::HandTurned(run),
        };
        let records = Records::Streamed {
            imu: &mut MemoryImu::new(imu, "imu.csv"),
            turntable: None,
        };
        return estimate::run(plan, records, &mut |_, _| {}).expect("calibration");
    }
    let tt = TurntableData::from_samples(turntable);
    let angles = class.turntable().then(|| (&tt, "turntable.csv").into());
    let plan = Plan {
        config,
        layout: Some(&layout),
        kind: RunKind::Programmed(ProgramOptions::CALIBRATE),
    };
    let records = Records::Streamed {
        imu: &mut MemoryImu::new(imu, "imu.csv"),
        turntable: angles,
    };
    estimate::run(plan, records, &mut |_, _| {}).expect("calibration")
}

/// The reference magnitude of `term` on `class`: every parameter at its grade's prior sigma,
/// signs alternating.
pub fn reference_values(class: Class, term: Candidate) -> Vec<(String, f64)> {
    let sigma = term.prior_sigma(class.config(1).unit_grade());
    term.param_names()
        .into_iter()
        .enumerate()
        .map(|(i, n)| (n, if i % 2 == 0 { sigma } else { -sigma }))
        .collect()
}

/// The hidden values of `term` on `class` that move a base parameter by `k` sigma, and the
/// noise-free reference run's `z_ref` ([`reference_values`]; module documentation).
pub fn sized_values(class: Class, term: Candidate, k: f64) -> (Vec<(String, f64)>, f64) {
    let reference = reference_values(class, term);
    let z_ref = run(class, 1, &reference, false).worst_base_sigma;
    let scale = k / z_ref.max(f64::MIN_POSITIVE);
    (
        reference.into_iter().map(|(n, v)| (n, v * scale)).collect(),
        z_ref,
    )
}

/// Counts of one row of the table.
#[derive(Clone, Debug, Default)]
pub struct Row {
    /// Runs.
    pub runs: usize,
    /// Exit status 3.
    pub exit3: usize,
    /// Exit 3 naming the hidden term, or the term carried by the calibration itself
    /// (detection rows); exit 3 naming any term (clean rows).
    pub named: usize,
    /// Runs that ended in exit 0 with a base parameter 10 sigma or more from its truth and the
    /// hidden term named nowhere.
    pub silent_10_sigma: usize,
    /// Runs that ended in exit 0 with a base parameter 10 sigma or more from its truth, the
    /// hidden term named in the verdict's blind-spot finding.
    pub blind_10_sigma: usize,
    /// The seeds that exited 3 (clean rows) or did not name the term (detection rows).
    pub odd_seeds: Vec<u64>,
}

/// `runs` seeded runs (seeds `first..first + runs`) of `class` with the hidden `values`
/// (`term`: the term they belong to, `None` for clean runs), counted.
pub fn count(
    class: Class,
    term: Option<Candidate>,
    values: &[(String, f64)],
    first: u64,
    runs: usize,
) -> Row {
    let seeds: Vec<u64> = (first..first + runs as u64).collect();
    let outcomes = parallel_map(&seeds, |&s| (s, run(class, s, values, true)));
    let mut row = Row {
        runs,
        ..Row::default()
    };
    for (seed, o) in outcomes {
        row.exit3 += usize::from(o.exit3);
        let named = match term {
            Some(t) => {
                (o.exit3 && o.named.iter().any(|n| n == t.id()))
                    || o.carried.iter().any(|n| n == t.id())
            }
            None => o.exit3 && !o.named.is_empty(),
        };
        row.named += usize::from(named);
        let blind = term.is_some_and(|t| {
            o.notes
                .iter()
                .any(|n| n.starts_with("blind spots") && n.contains(t.id()))
        });
        let off = !o.exit3 && o.worst_base_sigma >= 10.0;
        row.silent_10_sigma += usize::from(off && !blind);
        row.blind_10_sigma += usize::from(off && blind);
        let odd = match term {
            Some(_) => !named,
            None => o.exit3,
        };
        if odd {
            row.odd_seeds.push(seed);
        }
    }
    row
}

/// The Clopper-Pearson 95 % interval of `k` successes in `n` runs.
pub fn binomial_interval(k: usize, n: usize) -> (f64, f64) {
    use statrs::distribution::{Beta, ContinuousCDF};
    if n == 0 {
        return (0.0, 1.0);
    }
    let (k, nf) = (k as f64, n as f64);
    let lo = if k == 0.0 {
        0.0
    } else {
        Beta::new(k, nf - k + 1.0).expect("beta").inverse_cdf(0.025)
    };
    let hi = if k == nf {
        1.0
    } else {
        Beta::new(k + 1.0, nf - k).expect("beta").inverse_cdf(0.975)
    };
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use statrs::distribution::{ContinuousCDF, Normal};

    /// With one degree of freedom the non-central chi-square is the square of a normal of mean
    /// `sqrt(lambda)`: its tail is `Phi(-sqrt(x) - sqrt(lambda)) + Phi(sqrt(lambda) - sqrt(x))`.
    #[test]
    fn the_noncentral_tail_matches_the_squared_normal() {
        let n = Normal::new(0.0, 1.0).unwrap();
        for &(x, lambda) in &[
            (3.84, 0.0),
            (6.63, 4.0),
            (10.0, 25.0),
            (20.0, 400.0),
            (1.0, 0.5),
        ] {
            let (rx, rl) = (f64::sqrt(x), f64::sqrt(lambda));
            let exact = n.cdf(-rx - rl) + n.cdf(rl - rx);
            let got = noncentral_chi_square_sf(x, 1, lambda);
            assert!(
                (got - exact).abs() < 1e-9,
                "x {x} lambda {lambda}: {got} vs {exact}"
            );
        }
    }

    /// The mixture's mean is `dof + lambda`: the tail integrated over x (its mean) agrees.
    #[test]
    fn the_noncentral_tail_has_the_right_mean() {
        for &(dof, lambda) in &[(3_usize, 10.0), (9, 50.0), (2, 0.7)] {
            let dx = 0.01;
            let mean: f64 = (0..200_000)
                .map(|i| noncentral_chi_square_sf((i as f64 + 0.5) * dx, dof, lambda) * dx)
                .sum();
            let want = dof as f64 + lambda;
            assert!((mean - want).abs() < 1e-3 * want, "{mean} vs {want}");
        }
    }

    /// The best test's power is the level at no effect and 95 % at `(z_0.99 + z_0.95)^2`.
    #[test]
    fn the_best_test_power_has_its_level_and_its_95_percent_point() {
        assert!((best_test_power(0.0, 0.01) - 0.01).abs() < 1e-12);
        let n = Normal::new(0.0, 1.0).unwrap();
        let lambda = (n.inverse_cdf(0.99) + n.inverse_cdf(0.95)).powi(2);
        assert!((best_test_power(lambda, 0.01) - 0.95).abs() < 1e-9);
    }
}
