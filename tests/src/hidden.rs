//! Hidden-effect cases: a simulated run of a program with one (or two) unmodelled effects, run
//! through the model-extension loop as a user would (`calib::extend::run_loop`), and what the
//! loop made of it. Used by `tests/tests/hidden_effects.rs` and `cargo xtask hidden-effects`.
//!
//! Magnitudes (fixed before any run, not tuned) are those of navigation- and tactical-grade
//! units, each with its source in [`HiddenCase::source`]; the runs use the paper's priors and
//! noises, the IMU and the angle sensors at 25 Hz (the information is set by the noise
//! densities, not the rate, and the loop fits each model a dozen times).

use calib::config::{RunConfig, TemperatureConfig};
use calib::estimate::RunData;
use calib::extend::{LoopResult, LoopSettings, run_loop};
use calib::io::{ImuData, TurntableData};
use calib::model::extension::HiddenEffects;
use sins_model::candidates::Candidate;
use turntable::program::ProgramSpec;

/// Which program a case runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgramChoice {
    /// The paper's three cycles (every candidate is separable there with the turntable angles:
    /// `sins-calib design --config paper --with-turntable --terms ...`).
    Paper,
    /// Only the paper's first cycle (turns about instrument x), which cannot separate a term
    /// that needs turns about the other axes.
    FirstCycle,
    /// The program `sins-calib design` proposes for the case's terms, starting from the first
    /// cycle.
    Designed,
}

/// The paper's first cycle: its first two segments (+-10 deg/s about instrument x).
pub fn first_cycle(config: &RunConfig) -> ProgramSpec {
    let mut p = config.program_spec().expect("the paper's program");
    p.segments.truncate(2);
    p.name = "the paper's first cycle".into();
    p
}

/// One hidden-effect case.
#[derive(Clone, Debug)]
pub struct HiddenCase {
    /// Short name.
    pub name: &'static str,
    /// The terms hidden in the data (empty: the negative control).
    pub terms: Vec<Candidate>,
    /// True values of the hidden terms' parameters (SI) by name.
    pub values: Vec<(String, f64)>,
    /// True gyro bias random walk (rad/s/sqrt(s)), if hidden.
    pub drift: Option<[f64; 3]>,
    /// Where the magnitude comes from.
    pub source: &'static str,
    /// The program run.
    pub program: ProgramChoice,
    /// Seed of the simulation.
    pub seed: u64,
    /// The unit's temperature over the run (`None`: no temperature column).
    pub temperature: Option<TemperatureConfig>,
}

/// 1 deg/h/sqrt(h) in rad/s/sqrt(s).
const DEG_PER_H_SQRT_H: f64 = sins_model::units::DEG_PER_HOUR / 60.0;

fn v(name: &str, value: f64) -> (String, f64) {
    (name.to_string(), value)
}

/// The cases of the issue: each candidate alone, one with two effects, one on a designed
/// program. Seeds are the case's number (fixed in advance).
pub fn cases() -> Vec<HiddenCase> {
    let mut c = cases_base();
    c.push(designed_asymmetry());
    c
}

fn cases_base() -> Vec<HiddenCase> {
    use Candidate::*;
    vec![
        HiddenCase {
            name: "g-sensitivity",
            terms: vec![GyroGSensitivity],
            values: vec![
                v("gyro.gsens.xx", 3e-7),
                v("gyro.gsens.yz", -2e-7),
                v("gyro.gsens.zy", 2e-7),
            ],
            drift: None,
            source: "tactical-grade FOG/MEMS gyros specify 1-10 deg/h/g \
                     (5e-7 to 5e-6 rad/s per m/s^2); 3e-7 is the issue's measured case",
            program: ProgramChoice::Paper,
            seed: 1,
            temperature: None,
        },
        HiddenCase {
            name: "scale asymmetry",
            terms: vec![GyroScaleAsymmetry],
            values: vec![
                v("gyro.asym.x", 2e-5),
                v("gyro.asym.y", -1.5e-5),
                v("gyro.asym.z", 1e-5),
            ],
            drift: None,
            source: "tactical-grade gyros specify scale-factor asymmetry of 10-100 ppm \
                     (the issue's 2 ppm case is navigation grade)",
            program: ProgramChoice::Paper,
            seed: 2,
            temperature: None,
        },
        HiddenCase {
            name: "accelerometer quadratic term",
            terms: vec![AccelQuadratic],
            values: vec![
                v("accel.k2.x", 2e-5),
                v("accel.k2.y", -2e-5),
                v("accel.k2.z", 2e-5),
            ],
            drift: None,
            source: "Honeywell QA-2000 quartz accelerometer: second-order coefficient below \
                     20 ug/g^2 (2e-6 per m/s^2); 2e-5 per m/s^2 (200 ug/g^2) is a tactical MEMS unit",
            program: ProgramChoice::Paper,
            seed: 3,
            temperature: None,
        },
        HiddenCase {
            name: "size effect",
            terms: vec![AccelSizeEffect],
            values: vec![
                v("accel.lever.xy", 0.01),
                v("accel.lever.yz", 0.01),
                v("accel.lever.zx", 0.01),
            ],
            drift: None,
            source: "accelerometer proof masses of a navigation-grade triad sit about 10 mm \
                     from the common point (the issue's measured case)",
            program: ProgramChoice::Paper,
            seed: 4,
            temperature: None,
        },
        HiddenCase {
            name: "gyro bias random walk",
            terms: vec![GyroBiasDrift],
            values: vec![],
            drift: Some([0.1 * DEG_PER_H_SQRT_H; 3]),
            source: "bias instability / rate random walk of a tactical FOG, about 0.1 \
                     deg/h/sqrt(h) (the issue's 0.037 case is navigation grade)",
            program: ProgramChoice::Paper,
            seed: 5,
            temperature: None,
        },
        HiddenCase {
            name: "gyro-accelerometer time offset",
            terms: vec![GyroAccelTimeOffset],
            values: vec![v("time.gyro_accel", 1e-3)],
            drift: None,
            source: "an unsynchronised sampling of the two triads of one sample at 1 kHz \
                     (1 ms, the issue's flagged case)",
            program: ProgramChoice::Paper,
            seed: 6,
            temperature: None,
        },
        HiddenCase {
            name: "g-sensitivity and time offset",
            terms: vec![GyroGSensitivity, GyroAccelTimeOffset],
            values: vec![
                v("gyro.gsens.xx", 3e-7),
                v("gyro.gsens.yz", -2e-7),
                v("gyro.gsens.zy", 2e-7),
                v("time.gyro_accel", 1e-3),
            ],
            drift: None,
            source: "the two cases above together",
            program: ProgramChoice::Paper,
            seed: 7,
            temperature: None,
        },
    ]
}

/// Scale asymmetry on the program `design` proposes from the paper's first cycle (which turns
/// only about instrument x and leaves the y and z asymmetries confounded with the biases).
pub fn designed_asymmetry() -> HiddenCase {
    let mut c = asymmetry_case();
    c.name = "scale asymmetry, designed program";
    c.program = ProgramChoice::Designed;
    c.seed = 8;
    c
}

/// The scale-asymmetry case on the paper's first cycle alone.
pub fn first_cycle_asymmetry() -> HiddenCase {
    let mut c = asymmetry_case();
    c.name = "scale asymmetry, first cycle only";
    c.program = ProgramChoice::FirstCycle;
    c.seed = 8;
    c
}

fn asymmetry_case() -> HiddenCase {
    cases_base()
        .into_iter()
        .find(|c| c.name == "scale asymmetry")
        .expect("the asymmetry case")
}

/// The negative control: no hidden effect, seed `seed`.
pub fn negative_control(seed: u64) -> HiddenCase {
    HiddenCase {
        name: "no hidden effect",
        terms: vec![],
        values: vec![],
        drift: None,
        source: "-",
        program: ProgramChoice::Paper,
        seed,
        temperature: None,
    }
}

/// 1 deg/h/K in rad/s/K.
const DEG_PER_H_PER_K: f64 = sins_model::units::DEG_PER_HOUR;

/// A warm-up after power-on, 20 -> 35 deg C with a time constant of 900 s (the issue's).
pub fn warm_up() -> TemperatureConfig {
    TemperatureConfig {
        profile: "warmup".into(),
        start_c: Some(20.0),
        end_c: Some(35.0),
        time_constant_s: Some(900.0),
        ..Default::default()
    }
}

/// A thermal chamber's ramp, 20 -> 40 deg C at 0.5 deg C per minute.
pub fn chamber_ramp() -> TemperatureConfig {
    TemperatureConfig {
        profile: "ramp".into(),
        start_c: Some(20.0),
        end_c: Some(40.0),
        rate_c_per_min: Some(0.5),
        ..Default::default()
    }
}

/// The thermal cases (magnitudes and seeds fixed before any run): a gyro bias temperature
/// coefficient with the unit in a chamber ramp, an accelerometer bias coefficient in a warm-up.
pub fn thermal_cases() -> Vec<HiddenCase> {
    use Candidate::*;
    vec![
        HiddenCase {
            name: "gyro bias temperature coefficient, chamber ramp",
            terms: vec![GyroTempBias],
            values: vec![
                v("gyro.tbias.x", 0.02 * DEG_PER_H_PER_K),
                v("gyro.tbias.y", -0.015 * DEG_PER_H_PER_K),
                v("gyro.tbias.z", 0.01 * DEG_PER_H_PER_K),
            ],
            drift: None,
            source: "navigation FOGs quote 0.001-0.01 deg/h/K after their own thermal \
                     compensation and several times that before it; 0.01-0.02 deg/h/K",
            program: ProgramChoice::Paper,
            seed: 9,
            temperature: Some(chamber_ramp()),
        },
        HiddenCase {
            name: "accelerometer bias temperature coefficient, warm-up",
            terms: vec![AccelTempBias],
            values: vec![
                v("accel.tbias.x", 2e-5),
                v("accel.tbias.y", -2e-5),
                v("accel.tbias.z", 2e-5),
            ],
            drift: None,
            source: "2 ug/K per axis (the issue's case); quartz pendulous accelerometers \
                     5-50 ug/K uncompensated",
            program: ProgramChoice::Paper,
            seed: 10,
            temperature: Some(warm_up()),
        },
    ]
}

/// The thermal negative control: a warm-up in the temperature column, no thermal effect.
pub fn thermal_control(seed: u64) -> HiddenCase {
    HiddenCase {
        name: "warm-up, no hidden effect",
        temperature: Some(warm_up()),
        ..negative_control(seed)
    }
}

/// The run configuration of a case: the paper's priors and noises, turntable clock and truth
/// as in [`crate::simulated_run_config`], IMU and angle records at 25 Hz.
pub fn case_config(case: &HiddenCase) -> RunConfig {
    let mut c = crate::simulated_run_config();
    c.filter.imu_rate_hz = 25.0;
    c.truth.imu_rate_hz = 25.0;
    c.truth.turntable_rate_hz = 25.0;
    c.truth.seed = case.seed;
    c.temperature = case.temperature.clone();
    match case.program {
        ProgramChoice::Paper => {}
        ProgramChoice::FirstCycle => c.inline_program = Some(first_cycle(&c)),
        ProgramChoice::Designed => {
            c.inline_program = Some(first_cycle(&c));
            c.inline_program = Some(designed_program(&c, &case.terms));
        }
    }
    c
}

/// The program `design` proposes for `terms` on `config` (with the turntable angles).
pub fn designed_program(config: &RunConfig, terms: &[Candidate]) -> ProgramSpec {
    let (recorded, proposals, k) =
        calib::extend::design::design(config, true, terms).expect("design");
    match k {
        Some(k) => proposals[k].program.clone(),
        // The program already separates the terms: `design` keeps it.
        None => recorded.program,
    }
}

/// A case's truth for an extended parameter.
impl HiddenCase {
    /// The true value of a parameter of a hidden term (0 when not set).
    pub fn truth(&self, name: &str) -> f64 {
        self.values
            .iter()
            .find(|(n, _)| n == name)
            .map_or(0.0, |(_, v)| *v)
    }
}

/// Simulate the case and run the loop on it (with the turntable angles).
pub fn run_case(case: &HiddenCase) -> LoopResult {
    run_case_with_truth(case).0
}

/// [`run_case`] and the simulation's truth (every parameter, thermal reference included).
pub fn run_case_with_truth(case: &HiddenCase) -> (LoopResult, calib::io::ResultFile) {
    let config = case_config(case);
    let hidden = HiddenEffects {
        values: case.values.clone(),
        gyro_drift: case.drift,
    };
    let sim =
        calib::simulate::simulate_run_hidden(&config, case.name, &hidden).expect("simulation");
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: Some((&tt, "turntable.csv").into()),
    };
    let r = run_loop(&config, &data, &LoopSettings::default(), &mut |_| {}).expect("loop");
    (r, calib::io::ResultFile::from(&sim.truth))
}

/// The accepted terms' estimates in the final fit against the truth:
/// (name, estimate, sigma, truth). The random walk, which is not a state, comes from the round
/// that accepted it.
pub fn term_errors(case: &HiddenCase, result: &LoopResult) -> Vec<(String, f64, f64, f64)> {
    let mut out = Vec::new();
    let last = &result.last.calibration.estimate;
    for round in &result.rounds {
        let Some(acc) = &round.accepted else { continue };
        let Some(ev) = round.candidates.iter().find(|c| &c.term == acc) else {
            continue;
        };
        for p in &ev.estimate {
            if acc == Candidate::GyroBiasDrift.id() {
                let axis = ["x", "y", "z"]
                    .iter()
                    .position(|a| p.name.ends_with(a))
                    .unwrap_or(0);
                let truth = case.drift.map_or(0.0, |d| d[axis]);
                out.push((p.name.clone(), p.value, p.sigma, truth));
            } else if let Some(i) = last.names.iter().position(|n| n == &p.name) {
                let sigma = last.cov[(i, i)].max(0.0).sqrt();
                out.push((p.name.clone(), last.values[i], sigma, case.truth(&p.name)));
            }
        }
    }
    out
}
