//! Program design for candidate terms the recorded program cannot separate: extend the program
//! with manoeuvres from a fixed menu, run the covariance analysis of the extended model on each
//! proposal, and return the shortest proposal under which every requested term is separable
//! (`sins-calib design`).
//!
//! The menu, in order of added time (the instrument axes as in the paper's program: at gimbal
//! angles (0, 0, 0) x = East, y = North, z = Up; the bank gimbal turns about x, the pitch
//! gimbal about y there):
//! - six static positions, each instrument axis up and down, 60 s each: a dwell with an axis
//!   along gravity sees `f_i = +-g` against zero with it horizontal, which tells a term in
//!   `f_i^2` from a bias;
//! - turns about the vertical at +-10 deg/s with each instrument axis up in turn: rates with the
//!   specific force along the rotation axis, which tell g-sensitivity from the scale factors;
//! - the program's own turns again at twice the rate (half the duration): the centripetal
//!   terms grow as the rate squared while the scale factors grow as the rate;
//! - combinations of these.

use crate::config::{ConfigError, RunConfig};
use crate::estimate::covariance::{AnalysisError, Posterior, covariance_analysis_ext};
use crate::extend::evidence::{Separability, separability};
use crate::model::extension::ModelExtension;
use serde::Serialize;
use sins_model::candidates::Candidate;
use turntable::program::{ProgramSpec, Segment};

/// Errors of the design.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    /// The configuration's program cannot be read.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A proposal extends the program beyond what a program may be.
    #[error("the proposal \"{description}\": {source}")]
    Proposal {
        /// What the proposal adds.
        description: String,
        /// Why its program is refused.
        source: ConfigError,
    },
    /// The analyses of all proposals together would take too many IMU steps.
    #[error(
        "{origin}: designing runs {programs} covariance analyses of {total_s} s of programs in \
         all, {steps:.3e} IMU steps at filter.imu_rate_hz = {rate_hz} Hz: expected at most \
         {max:.0e}; design with a shorter program or a lower filter.imu_rate_hz",
        max = crate::estimate::covariance::MAX_ANALYSIS_STEPS
    )]
    TooManySteps {
        /// The configuration's program.
        origin: String,
        /// Programs analysed (the recorded one and the proposals).
        programs: usize,
        /// Their total duration (s).
        total_s: f64,
        /// IMU rate (Hz).
        rate_hz: f64,
        /// Total steps.
        steps: f64,
    },
    /// A covariance analysis failed.
    #[error(transparent)]
    Analysis(#[from] AnalysisError),
}

/// One evaluated program.
#[derive(Clone, Debug, Serialize)]
pub struct Proposal {
    /// What was added to the recorded program.
    pub description: String,
    /// The whole program.
    #[serde(skip)]
    pub program: ProgramSpec,
    /// Its duration (s).
    pub duration_s: f64,
    /// Separability of each requested term under it.
    pub terms: Vec<(String, Separability)>,
    /// Posterior sigma of every parameter of the requested terms (SI).
    pub sigmas: Vec<(String, f64, f64)>,
    /// The whole posterior of the analysis (what else a caller judges the program by: the
    /// navigation figure of `sins-calib design`).
    #[serde(skip)]
    pub posterior: Posterior,
}

impl Proposal {
    /// Every requested term separable.
    pub fn separates(&self) -> bool {
        self.terms.iter().all(|(_, s)| s.separable)
    }

    /// The largest posterior-over-prior sigma ratio of the requested terms' parameters.
    pub fn worst_ratio(&self) -> f64 {
        self.terms
            .iter()
            .flat_map(|(_, s)| s.parameters.iter().map(|p| p.sigma_ratio))
            .fold(0.0, f64::max)
    }

    /// The program as TOML, headed by the predicted sigmas.
    pub fn to_toml(&self) -> String {
        let mut s = format!(
            "# Proposed by `sins-calib design`: {}\n# Duration {:.0} s. Predicted posterior sigma \
             (SI) of the requested terms, against their prior:\n",
            self.description, self.duration_s
        );
        for (name, sigma, prior) in &self.sigmas {
            s += &format!(
                "#   {name:<22} {sigma:.3e}  (prior {prior:.3e}, ratio {:.3})\n",
                sigma / prior
            );
        }
        s += &toml::to_string(&self.program).unwrap_or_else(|e| format!("# cannot write: {e}\n"));
        s
    }
}

const POSITION_RATE_DEG_S: f64 = 10.0;

/// Gimbal angles putting each instrument axis up and down.
const SIX_POSITIONS_DEG: [[f64; 3]; 6] = [
    [0.0, 0.0, 0.0],
    [0.0, 180.0, 0.0],
    [0.0, 90.0, 0.0],
    [0.0, -90.0, 0.0],
    [0.0, 0.0, 90.0],
    [0.0, 0.0, -90.0],
];

fn six_positions(dwell_s: f64) -> Vec<Segment> {
    SIX_POSITIONS_DEG
        .iter()
        .flat_map(|k| {
            [
                Segment::Move {
                    target_deg: *k,
                    rate_deg_s: POSITION_RATE_DEG_S,
                },
                Segment::Dwell {
                    duration_s: dwell_s,
                },
            ]
        })
        .collect()
}

fn vertical_turns(turn_s: f64) -> Vec<Segment> {
    // z up at (0, 0, 0); the bank gimbal's quarter turn about x brings y vertical, the pitch
    // gimbal's quarter turn about y brings x vertical.
    [[0.0, 0.0, 0.0], [0.0, 90.0, 0.0], [0.0, 0.0, 90.0]]
        .iter()
        .flat_map(|k| {
            [
                Segment::Move {
                    target_deg: *k,
                    rate_deg_s: POSITION_RATE_DEG_S,
                },
                Segment::Rotate {
                    gimbal: 1,
                    rate_deg_s: 10.0,
                    duration_s: turn_s,
                },
                Segment::Rotate {
                    gimbal: 1,
                    rate_deg_s: -10.0,
                    duration_s: turn_s,
                },
            ]
        })
        .collect()
}

fn faster_turns(base: &ProgramSpec) -> Vec<Segment> {
    std::iter::once(Segment::Move {
        target_deg: base.start_deg,
        rate_deg_s: POSITION_RATE_DEG_S,
    })
    .chain(base.segments.iter().map(|s| match *s {
        Segment::Rotate {
            gimbal,
            rate_deg_s,
            duration_s,
        } if (2.0 * rate_deg_s).abs() <= turntable::program::MAX_RATE_DEG_S => Segment::Rotate {
            gimbal,
            rate_deg_s: 2.0 * rate_deg_s,
            duration_s: 0.5 * duration_s,
        },
        // A turn already faster than half the fastest rate a program may have is kept as it
        // is: doubled, the proposal would be refused as a program.
        ref other => other.clone(),
    }))
    .collect()
}

/// The menu of additions to `base`, shortest first.
pub fn candidate_programs(base: &ProgramSpec) -> Vec<(String, ProgramSpec)> {
    let extend = |name: &str, parts: Vec<Vec<Segment>>| {
        let mut p = base.clone();
        p.name = format!("{} + {name}", base.name);
        for part in parts {
            p.segments.extend(part);
        }
        (name.to_string(), p)
    };
    vec![
        extend("six static positions, 60 s each", vec![six_positions(60.0)]),
        extend(
            "turns about the vertical at +-10 deg/s with each axis up, 180 s each way",
            vec![vertical_turns(180.0)],
        ),
        extend(
            "the program's turns again at twice the rate",
            vec![faster_turns(base)],
        ),
        extend(
            "six static positions and turns about the vertical",
            vec![six_positions(60.0), vertical_turns(180.0)],
        ),
        extend(
            "six static positions and the turns at twice the rate",
            vec![six_positions(60.0), faster_turns(base)],
        ),
        extend(
            "six static positions, turns about the vertical and at twice the rate",
            vec![
                six_positions(60.0),
                vertical_turns(180.0),
                faster_turns(base),
            ],
        ),
    ]
}

/// Evaluate the extended model `ext` (holding `terms`) under `program`.
pub fn evaluate(
    config: &RunConfig,
    with_turntable: bool,
    ext: &ModelExtension,
    terms: &[Candidate],
    description: &str,
    program: ProgramSpec,
) -> Result<Proposal, DesignError> {
    let mut c = config.clone();
    c.inline_program = Some(program.clone());
    let duration_s = c.program()?.duration();
    let post: Posterior = covariance_analysis_ext(&c, with_turntable, ext)?;
    let requested: Vec<String> = terms.iter().flat_map(|t| t.param_names()).collect();
    let base: Vec<String> = post
        .names
        .iter()
        .skip(crate::model::layout::StateLayout::INSTRUMENT)
        .filter(|n| !requested.contains(n))
        .cloned()
        .collect();
    let sep_terms = terms
        .iter()
        .map(|t| {
            let s = separability(
                &post.names,
                &post.prior_sigma,
                &post.cov,
                &t.param_names(),
                &base,
            );
            (t.id().to_string(), s)
        })
        .collect();
    let sigmas = requested
        .iter()
        .filter_map(|n| {
            let i = post.names.iter().position(|m| m == n)?;
            Some((
                n.clone(),
                post.cov[(i, i)].max(0.0).sqrt(),
                post.prior_sigma[i],
            ))
        })
        .collect();
    Ok(Proposal {
        description: description.to_string(),
        program,
        duration_s,
        terms: sep_terms,
        sigmas,
        posterior: post,
    })
}

/// The recorded program evaluated and, when it does not separate every term in `terms`, every
/// proposal: the chosen one is the shortest that separates them all (or, if none does, the one
/// with the smallest worst ratio). Returns (recorded, proposals, index of the chosen proposal);
/// a recorded program that already separates every term is not extended: no proposal is
/// evaluated and the index is `None`.
pub fn design(
    config: &RunConfig,
    with_turntable: bool,
    terms: &[Candidate],
) -> Result<(Proposal, Vec<Proposal>, Option<usize>), DesignError> {
    let mut ext = ModelExtension::default();
    for &t in terms {
        ext = crate::extend::with_term(&ext, t, config.unit_grade());
    }
    // The random walk is not a state: the covariance analysis has nothing to separate.
    ext.gyro_drift = None;
    let terms: Vec<Candidate> = terms
        .iter()
        .copied()
        .filter(|t| *t != Candidate::GyroBiasDrift)
        .collect();
    // The program as read (file and segment in its errors), and every proposal compiled and
    // counted before any analysis runs.
    let base_program = config.program()?;
    let base = config.program_spec()?;
    let menu = candidate_programs(&base);
    let mut total_s = base_program.duration();
    for (description, p) in &menu {
        let program =
            turntable::program::Program::compile(p, "<proposed program>").map_err(|e| {
                DesignError::Proposal {
                    description: description.clone(),
                    source: e.into(),
                }
            })?;
        total_s += program.duration();
    }
    let rate_hz = config.filter.imu_rate_hz;
    let steps = total_s * rate_hz;
    if !(steps.is_finite() && steps <= crate::estimate::covariance::MAX_ANALYSIS_STEPS) {
        return Err(DesignError::TooManySteps {
            origin: format!("program \"{}\"", config.program),
            programs: menu.len() + 1,
            total_s,
            rate_hz,
            steps,
        });
    }
    let recorded = evaluate(
        config,
        with_turntable,
        &ext,
        &terms,
        "the recorded program",
        base.clone(),
    )?;
    if recorded.separates() {
        return Ok((recorded, Vec::new(), None));
    }
    let mut proposals = Vec::new();
    for (name, p) in menu {
        proposals.push(evaluate(config, with_turntable, &ext, &terms, &name, p)?);
    }
    let chosen = proposals
        .iter()
        .enumerate()
        .filter(|(_, p)| p.separates())
        .min_by(|a, b| a.1.duration_s.total_cmp(&b.1.duration_s))
        .or_else(|| {
            proposals
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.worst_ratio().total_cmp(&b.1.worst_ratio()))
        })
        .map(|(i, _)| i);
    Ok((recorded, proposals, chosen))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every proposal for a program with a turn near the fastest rate accepted compiles: the
    /// faster turns do not double it beyond the bound.
    #[test]
    fn proposals_for_fast_turns_stay_within_the_rate_bound() {
        let base = ProgramSpec {
            name: "fast".into(),
            start_deg: [0.0; 3],
            segments: vec![
                Segment::Rotate {
                    gimbal: 2,
                    rate_deg_s: 1500.0,
                    duration_s: 2.4,
                },
                Segment::Rotate {
                    gimbal: 3,
                    rate_deg_s: -100.0,
                    duration_s: 3.6,
                },
            ],
        };
        let proposals = candidate_programs(&base);
        assert!(!proposals.is_empty());
        for (name, spec) in &proposals {
            turntable::program::Program::compile(spec, name)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        let faster = faster_turns(&base);
        assert!(faster.contains(&base.segments[0]), "{faster:?}");
        assert!(faster.contains(&Segment::Rotate {
            gimbal: 3,
            rate_deg_s: -200.0,
            duration_s: 1.8,
        }));
    }

    /// A program that already separates the terms is not extended. The paper's program with
    /// the turntable angles separates the time offset (docs/model-extension.md: every
    /// candidate's sigma below 0.12 of its prior); the IMU at 10 Hz keeps the analysis short.
    #[test]
    fn a_program_that_separates_the_terms_is_not_extended() {
        let mut config = RunConfig::paper();
        config.filter.imu_rate_hz = 10.0;
        let terms = [Candidate::GyroAccelTimeOffset];
        let (recorded, proposals, chosen) = design(&config, true, &terms).unwrap();
        assert!(recorded.separates(), "{:?}", recorded.terms);
        assert!(proposals.is_empty() && chosen.is_none());
        // A program that does not separate them (the first cycle alone, turns about x only,
        // under which a scale asymmetry looks like a bias) gets a proposal that does.
        let mut spec = config.program_spec().unwrap();
        spec.segments.truncate(2);
        config.inline_program = Some(spec);
        let terms = [Candidate::GyroScaleAsymmetry];
        let (recorded, proposals, chosen) = design(&config, true, &terms).unwrap();
        assert!(!recorded.separates(), "{:?}", recorded.terms);
        let k = chosen.expect("a proposal");
        assert!(proposals[k].separates());
        assert!(proposals[k].duration_s > recorded.duration_s);
    }

    #[test]
    fn proposals_compile_and_grow_the_program() {
        let base = RunConfig::paper().program_spec().unwrap();
        let base_len = turntable::program::Program::compile(&base, "base")
            .unwrap()
            .duration();
        for (name, p) in candidate_programs(&base) {
            let prog = turntable::program::Program::compile(&p, &name).unwrap();
            assert!(
                prog.duration() > base_len + 300.0,
                "{name}: {}",
                prog.duration()
            );
            // The TOML written for the user reads back as the same program.
            let text = toml::to_string(&p).unwrap();
            let back: ProgramSpec = toml::from_str(&text).unwrap();
            assert_eq!(back, p);
        }
    }
}
