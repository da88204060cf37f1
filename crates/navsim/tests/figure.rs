//! The candidate terms in flight, the levelled alignment and the navigation figure of a
//! calibration (`navsim::figure`).

use nalgebra::DMatrix;
use navsim::model::BETA;
use navsim::{
    CalibrationCovariance, FlightSetting, InitialAttitude, InstrumentCovariance, NamePolicy,
    NavOptions, SnakeConfig, SnakeTrajectory, StaticTrajectory, Trajectory, initial_covariance,
    navigation_figure, rho_series,
};
use sins_model::candidates::UnitGrade;
use sins_model::earth::Site;

fn at_rest() -> StaticTrajectory {
    StaticTrajectory {
        site: Site::from_degrees(55.7, 37.6, 0.0),
        heading: 0.4,
        duration_s: 1800.0,
    }
}

fn one(name: &str, sigma: f64) -> InstrumentCovariance {
    InstrumentCovariance::from_sigmas(&[(name, sigma)])
}

fn lenient(opts: NavOptions) -> NavOptions {
    NavOptions {
        names: NamePolicy {
            allow_missing: true,
            ignore_unknown: false,
        },
        gyro_noise_density: 0.0,
        accel_noise_density: 0.0,
        ..opts
    }
}

fn final_rho(traj: &dyn Trajectory, c: &InstrumentCovariance, opts: &NavOptions) -> f64 {
    rho_series(traj, c, opts).unwrap().final_rho_m()
}

/// At rest the specific force is gravity along the body's z: a g-sensitivity `G_xz` is a gyro
/// bias `G_xz g` on x, in flight and in the alignment alike; a bias temperature coefficient is
/// a bias `b dT`.
#[test]
fn candidate_terms_act_through_their_effect_on_the_sensors() {
    let traj = at_rest();
    let g = traj.site.normal_gravity();
    let opts = lenient(NavOptions::default());
    let sigma = 1e-7;
    let gsens = final_rho(&traj, &one("gyro.gsens.xz", sigma), &opts);
    let bias = final_rho(&traj, &one("gyro.bias.x", sigma * g), &opts);
    assert!(bias > 1.0, "{bias}");
    assert!((gsens / bias - 1.0).abs() < 1e-9, "{gsens} vs {bias}");
    // The same with the alignment switched off (the flight's effect alone).
    let bare = NavOptions {
        initial_attitude: InitialAttitude::Explicit(nalgebra::Matrix3::zeros()),
        ..opts.clone()
    };
    let gsens = final_rho(&traj, &one("gyro.gsens.yz", sigma), &bare);
    let bias = final_rho(&traj, &one("gyro.bias.y", sigma * g), &bare);
    assert!((gsens / bias - 1.0).abs() < 1e-9, "{gsens} vs {bias}");
    // A thermal bias acts at the flight's temperature less the reference, and not at all at it.
    let warm = NavOptions {
        temperature_delta_k: 4.0,
        ..opts.clone()
    };
    let tbias = final_rho(&traj, &one("accel.tbias.y", 1e-5), &warm);
    let bias = final_rho(&traj, &one("accel.bias.y", 4e-5), &warm);
    assert!(bias > 0.0);
    assert!((tbias / bias - 1.0).abs() < 1e-9, "{tbias} vs {bias}");
    assert_eq!(final_rho(&traj, &one("accel.tbias.y", 1e-5), &opts), 0.0);
}

/// The terms that act through the rates of change (time offset, size effect) do nothing at
/// rest and something in the snake's turns.
#[test]
fn rate_of_change_terms_act_in_the_turns_only() {
    let opts = lenient(NavOptions::default());
    let offset = one("time.gyro_accel", 1e-3);
    assert_eq!(final_rho(&at_rest(), &offset, &opts), 0.0);
    let flight = SnakeTrajectory::new(&SnakeConfig::default_config()).unwrap();
    let in_flight = final_rho(&flight, &offset, &opts);
    assert!(in_flight > 0.0 && in_flight < 10.0, "{in_flight}");
    let lever = final_rho(&flight, &one("accel.lever.xy", 0.02), &opts);
    assert!(lever > 0.0, "{lever}");
}

/// Levelling without gyrocompassing: the tilt as with the full alignment, no heading error.
#[test]
fn a_levelled_unit_takes_its_heading_from_elsewhere() {
    let flight = SnakeTrajectory::new(&SnakeConfig::default_config()).unwrap();
    let c = InstrumentCovariance::paper_without_turntable();
    let aligned = initial_covariance(&flight, &c, &NavOptions::default()).unwrap();
    let levelled = NavOptions {
        initial_attitude: InitialAttitude::Levelled,
        ..NavOptions::default()
    };
    let p = initial_covariance(&flight, &c, &levelled).unwrap();
    assert_eq!(p[(BETA + 2, BETA + 2)], 0.0);
    assert!(aligned[(BETA + 2, BETA + 2)] > 0.0);
    for i in [BETA, BETA + 1] {
        assert_eq!(p[(i, i)], aligned[(i, i)]);
    }
}

fn paper_calibration() -> CalibrationCovariance {
    let c = InstrumentCovariance::paper_with_turntable();
    let prior = InstrumentCovariance::paper_without_turntable();
    CalibrationCovariance {
        prior_sigma: c.names.iter().map(|n| prior.sigma(n).unwrap()).collect(),
        names: c.names,
        posterior: c.cov,
        reference_temperature_c: None,
    }
}

fn setting(grade: UnitGrade) -> FlightSetting {
    let o = NavOptions::default();
    FlightSetting {
        flight: SnakeConfig::default_config(),
        grade,
        noise_densities: (o.gyro_noise_density, o.accel_noise_density),
    }
}

/// The figure of a navigation-grade calibration is `rho_series`'s after the hour; its priors
/// give the uncalibrated curve; the budget names the paper's four terms.
#[test]
fn a_navigation_grade_figure_is_the_papers_hour() {
    let cal = paper_calibration();
    let f = navigation_figure(&cal, &setting(UnitGrade::Navigation)).unwrap();
    let flight = SnakeTrajectory::new(&SnakeConfig::default_config()).unwrap();
    let c = InstrumentCovariance::paper_with_turntable();
    let want = rho_series(&flight, &c, &NavOptions::default()).unwrap();
    assert_eq!(f.horizon.seconds, 3600.0);
    assert!(
        (f.rho_m / want.final_rho_m() - 1.0).abs() < 1e-12,
        "{}",
        f.rho_m
    );
    assert_eq!(f.t_s.len(), want.t.len());
    let prior = InstrumentCovariance::paper_without_turntable();
    let before = rho_series(&flight, &prior, &NavOptions::default()).unwrap();
    assert!((f.uncalibrated_rho_m / before.final_rho_m() - 1.0).abs() < 1e-12);
    let groups: Vec<&str> = f.budget.iter().map(|g| g.group.as_str()).collect();
    assert_eq!(
        groups,
        [
            "gyro_bias",
            "gyro_matrix",
            "accel_bias",
            "accel_matrix",
            "alignment",
            "sensor_noise"
        ]
    );
    assert!(f.terms.is_empty() && f.notes.is_empty());
}

/// A lesser unit's horizon is its grade's (an hour says nothing of it), and it is levelled.
#[test]
fn the_horizon_follows_the_grade() {
    let cal = paper_calibration();
    for (grade, seconds) in [(UnitGrade::Tactical, 600.0), (UnitGrade::Consumer, 60.0)] {
        let f = navigation_figure(&cal, &setting(grade)).unwrap();
        assert_eq!(f.horizon.seconds, seconds);
        assert_eq!(*f.t_s.last().unwrap(), seconds);
        assert!(
            f.horizon.reason.contains(grade.name()),
            "{}",
            f.horizon.reason
        );
        assert!(
            f.alignment.contains("external reference"),
            "{}",
            f.alignment
        );
    }
    // A flight shorter than the horizon ends it.
    let mut s = setting(UnitGrade::Navigation);
    s.flight.duration_s = 900.0;
    let f = navigation_figure(&cal, &s).unwrap();
    assert_eq!(f.horizon.seconds, 900.0);
    assert!(f.horizon.reason.contains("900 s"), "{}", f.horizon.reason);
}

/// A calibration with a g-sensitivity: the term is propagated, has its own line in the budget,
/// and the turntable's and attitude states are set aside.
#[test]
fn an_estimated_term_has_its_share_in_the_budget() {
    let mut cal = paper_calibration();
    let extra = [
        ("gyro.gsens.xz", 2e-8),
        ("gyro.gsens.yz", 2e-8),
        ("install.delta.x", 1e-5),
        ("attitude.beta.x", 1e-5),
    ];
    let n = cal.names.len();
    let mut cov = DMatrix::zeros(n + extra.len(), n + extra.len());
    cov.view_mut((0, 0), (n, n)).copy_from(&cal.posterior);
    for (k, (name, sigma)) in extra.iter().enumerate() {
        cal.names.push(name.to_string());
        cal.prior_sigma.push(sigma * 10.0);
        cov[(n + k, n + k)] = sigma * sigma;
    }
    cal.posterior = cov;
    // The term's other seven entries are missing: a calibration estimates a term whole.
    assert!(navigation_figure(&cal, &setting(UnitGrade::Navigation)).is_err());
    let g: Vec<String> = sins_model::candidates::Candidate::GyroGSensitivity
        .param_names()
        .into_iter()
        .filter(|n| !cal.names.contains(n))
        .collect();
    for name in &g {
        let k = cal.names.len();
        cal.names.push(name.clone());
        cal.prior_sigma.push(1e-6);
        let mut c = DMatrix::zeros(k + 1, k + 1);
        c.view_mut((0, 0), (k, k)).copy_from(&cal.posterior);
        c[(k, k)] = 1e-18;
        cal.posterior = c;
    }
    let f = navigation_figure(&cal, &setting(UnitGrade::Navigation)).unwrap();
    let share = f
        .budget
        .iter()
        .find(|b| b.group == "gyro_g_sensitivity")
        .expect("the term's line")
        .rho_m;
    assert!(share > 10.0, "{share}");
    assert_eq!(f.terms.len(), 1);
    assert!(f.terms[0].propagated);
    assert_eq!(f.not_in_flight, ["install.delta.x"]);
    let without = navigation_figure(&paper_calibration(), &setting(UnitGrade::Navigation));
    assert!(f.rho_m > without.unwrap().rho_m);
}
