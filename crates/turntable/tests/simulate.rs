//! Truth simulation: exact increments, error and noise models, turntable clock and delay.

use nalgebra::Vector3;
use rand::SeedableRng;
use sins_model::attitude::{exp_so3, log_so3};
use sins_model::earth::Site;
use sins_model::terms::{ErrorModel, PaperPriors};
use turntable::kinematics::{Kinematics, Mounting};
use turntable::program::Program;
use turntable::sensor::AngleSensor;
use turntable::simulate::{
    GaussLegendre, SimConfig, SimRng, Truth, draw_parameters, increments_at, simulate,
    simulate_imu, simulate_turntable,
};

fn site() -> Site {
    Site::from_degrees(55.7, 37.6, 150.0)
}

/// One full turn about the bank gimbal (instrument x along East), a dwell, a full turn about
/// pitch after a heading move, a heading turn; durations multiples of 0.02 s.
fn program() -> Program {
    Program::from_toml_str(
        r#"
name = "test"
start_deg = [0.0, 0.0, 0.0]
[[segment]]
kind = "rotate"
gimbal = 2
rate_deg_s = 10.0
duration_s = 36.0
[[segment]]
kind = "dwell"
duration_s = 4.0
[[segment]]
kind = "move"
target_deg = [-90.0, 0.0, 30.0]
rate_deg_s = 10.0
[[segment]]
kind = "rotate"
gimbal = 3
rate_deg_s = -15.0
duration_s = 24.0
[[segment]]
kind = "rotate"
gimbal = 1
rate_deg_s = 20.0
duration_s = 18.0
"#,
        "test",
    )
    .unwrap()
}

fn mounting() -> Mounting {
    Mounting {
        delta_z: Vector3::new(2e-3, -1e-3, 5e-4),
        gamma_p: Vector3::new(-3e-4, 2e-4, 1e-3),
    }
}

fn model() -> ErrorModel {
    ErrorModel::paper(&PaperPriors::paper())
}

fn quiet() -> SimConfig {
    SimConfig::default()
}

fn sensor() -> AngleSensor {
    AngleSensor {
        sigma: [0.0; 3],
        rate_hz: 50.0,
        tau: 0.013,
        clock: turntable::sensor::Clock {
            turntable_offset_s: 1234.5678,
            turntable_rate_error: 2e-5,
        },
    }
}

#[test]
fn refining_the_quadrature_changes_nothing() {
    let kin = Kinematics::new(program(), mounting(), site());
    let m = model();
    let mut rng = SimRng::seed_from_u64(3);
    let p = draw_parameters(&m, &mut rng);
    let r5 = GaussLegendre::new(5).unwrap();
    let r16 = GaussLegendre::new(16).unwrap();
    // Intervals inside pieces, across piece boundaries (36 s, 40 s) and long ones.
    for (a, b) in [
        (0.0, 0.01),
        (35.995, 36.005),
        (39.99, 40.03),
        (12.0, 12.5),
        (50.0, 53.0),
    ] {
        let (t5, v5) = increments_at(&kin, &m, &p, &r5, a, b, 0.0);
        let (t16, v16) = increments_at(&kin, &m, &p, &r16, a, b, 0.0);
        assert!((t5 - t16).norm() <= 1e-12 * t16.norm(), "[{a}, {b}]");
        assert!((v5 - v16).norm() <= 1e-12 * v16.norm(), "[{a}, {b}]");
    }
}

#[test]
fn integral_of_body_rate_matches_closed_form_and_fine_numerical_integration() {
    // Bank turn with instrument = platform = ENU at k = 0: c_body_to_enu = rot_x(k2), so
    // omega_body = w e1 + rot_x(-k2) u, which integrates in closed form.
    let kin = Kinematics::new(program(), Mounting::default(), site());
    let m = ErrorModel::new();
    let rule = GaussLegendre::new(6).unwrap();
    let u = kin.earth_rate_enu();
    let w = 10f64.to_radians();
    for (a, b) in [(0.0, 0.01), (3.21, 3.23), (10.0, 17.5)] {
        let (dtheta, _) = increments_at(&kin, &m, &[], &rule, a, b, 0.0);
        let (ka, kb) = (w * a, w * b);
        let int_cos = (kb.sin() - ka.sin()) / w;
        let int_sin = -(kb.cos() - ka.cos()) / w;
        let exact = Vector3::new(
            w * (b - a) + u.x * (b - a),
            u.y * int_cos + u.z * int_sin,
            -u.y * int_sin + u.z * int_cos,
        );
        assert!(
            (dtheta - exact).norm() <= 1e-13 * exact.norm(),
            "[{a}, {b}]: {dtheta:?} vs {exact:?}"
        );
    }
    // The same against a 1e5-step composite Simpson rule over an interval spanning pieces.
    let kin = Kinematics::new(program(), mounting(), site());
    let (a, b) = (49.0, 51.0); // the move's heading leg ends at 49 s, its pitch leg follows
    let (dtheta, dv) = increments_at(&kin, &m, &[], &rule, a, b, 0.0);
    let n = 100_000;
    let h = (b - a) / n as f64;
    let (mut st, mut sv) = (Vector3::zeros(), Vector3::zeros());
    for i in 0..=n {
        let wgt = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let s = kin.sample(a + i as f64 * h);
        st += s.omega_body * wgt;
        sv += s.f_body * wgt;
    }
    st *= h / 3.0;
    sv *= h / 3.0;
    // Simpson is only first-order accurate across the rate discontinuity at 49 s
    // (unless 49 s falls on a node: a + 50000 h = 50 s, so it does not).
    assert!(
        (dtheta - st).norm() < 1e-9 * dtheta.norm(),
        "{dtheta:?} vs {st:?}"
    );
    assert!((dv - sv).norm() < 1e-9 * dv.norm());
}

#[test]
fn full_bank_turn_sums_to_two_pi_about_east() {
    // Instrument x along East: the Earth rate's East component is zero and its other
    // components rotate through a full turn, so they integrate to zero.
    let kin = Kinematics::new(program(), Mounting::default(), site());
    let cfg = SimConfig {
        duration_s: Some(36.0),
        ..quiet()
    };
    let imu = simulate_imu(
        &kin,
        &ErrorModel::new(),
        &[],
        &cfg,
        &mut SimRng::seed_from_u64(0),
    )
    .unwrap();
    assert_eq!(imu.len(), 3600);
    let sum: Vector3<f64> = imu.iter().map(|s| s.dtheta).sum();
    let expected = Vector3::new(2.0 * std::f64::consts::PI, 0.0, 0.0);
    assert!((sum - expected).norm() < 1e-12, "{sum:?}");
}

#[test]
fn coning_integration_of_increments_reproduces_the_attitude() {
    let kin = Kinematics::new(program(), mounting(), site());
    let cfg = quiet();
    let imu = simulate_imu(
        &kin,
        &ErrorModel::new(),
        &[],
        &cfg,
        &mut SimRng::seed_from_u64(0),
    )
    .unwrap();
    let dt = 1.0 / cfg.imu_rate_hz;
    assert_eq!(imu.len() % 2, 0);
    // Body to inertial (= ENU at t = 0): two-sample coning algorithm on pairs of increments.
    let mut c_body_to_inertial = kin.sample(0.0).c_body_to_enu;
    for pair in imu.chunks(2) {
        let (a, b) = (pair[0].dtheta, pair[1].dtheta);
        let phi = a + b + a.cross(&b) * (2.0 / 3.0);
        c_body_to_inertial *= exp_so3(&phi);
    }
    let t_end = imu.len() as f64 * dt;
    assert!((imu.last().unwrap().t - t_end).abs() < 1e-9);
    // ENU turns with the Earth: c_body_to_enu(t) = exp(-skew(u) t) c_body_to_inertial(t).
    let c = exp_so3(&(-kin.earth_rate_enu() * t_end)) * c_body_to_inertial;
    let truth = kin.sample(t_end).c_body_to_enu;
    let err = log_so3(&(c * truth.transpose()));
    assert!(err.norm() < 1e-10, "attitude error {err:?} rad");
    // Without the Earth-rate correction the check fails by far more: it is not vacuous.
    let err_no_earth = log_so3(&(c_body_to_inertial * truth.transpose()));
    assert!(err_no_earth.norm() > 1e-3);
}

#[test]
fn static_dwell_velocity_increment_is_f_body_dt() {
    let kin = Kinematics::new(program(), mounting(), site());
    let cfg = quiet();
    let imu = simulate_imu(
        &kin,
        &ErrorModel::new(),
        &[],
        &cfg,
        &mut SimRng::seed_from_u64(0),
    )
    .unwrap();
    let dt = 0.01;
    let f = kin.sample(38.0).f_body;
    let w = kin.sample(38.0).omega_body;
    for s in imu
        .iter()
        .filter(|s| s.t > 36.0 + 1e-9 && s.t < 40.0 - 1e-9)
    {
        assert!((s.dv - f * dt).norm() < 1e-14 * f.norm(), "t {}", s.t);
        assert!((s.dtheta - w * dt).norm() < 1e-14 * w.norm(), "t {}", s.t);
    }
}

#[test]
fn instrument_errors_shift_the_increments_with_the_documented_signs() {
    let kin = Kinematics::new(program(), mounting(), site());
    let m = model();
    let cfg = quiet();
    let mut rng = SimRng::seed_from_u64(0);
    let clean = simulate_imu(&kin, &m, &[0.0; 21], &cfg, &mut rng).unwrap();
    let mut p = vec![0.0; 21];
    let gyro_bias = Vector3::new(3e-6, -2e-6, 1e-6);
    let accel_bias = Vector3::new(0.01, -0.02, 0.005);
    p[0..3].copy_from_slice(gyro_bias.as_slice());
    p[12..15].copy_from_slice(accel_bias.as_slice());
    let theta_xy = 1e-3;
    p[4] = theta_xy;
    let biased = simulate_imu(&kin, &m, &p, &cfg, &mut rng).unwrap();
    let dt = 0.01;
    let n = clean.len() as f64;
    let mut mean_dw = Vector3::zeros();
    let mut mean_df = Vector3::zeros();
    for (c, b) in clean.iter().zip(&biased) {
        // w' = w - nu0 - Theta w: dtheta' - dtheta = -(bias + Theta dtheta/dt) dt.
        let theta_term = Vector3::new(theta_xy * c.dtheta.y, 0.0, 0.0);
        let expected = -(gyro_bias * dt + theta_term);
        assert!((b.dtheta - c.dtheta - expected).norm() < 1e-15, "t {}", c.t);
        mean_dw += (b.dtheta - c.dtheta + theta_term) / dt / n;
        // f' = f + df0: dv' - dv = +bias dt.
        assert!((b.dv - c.dv - accel_bias * dt).norm() < 1e-15, "t {}", c.t);
        mean_df += (b.dv - c.dv) / dt / n;
    }
    assert!((mean_dw + gyro_bias).norm() < 1e-12);
    assert!((mean_df - accel_bias).norm() < 1e-12);
}

#[test]
fn noise_variance_matches_psd_times_dt() {
    let kin = Kinematics::new(program(), mounting(), site());
    let m = ErrorModel::new();
    let clean = simulate_imu(&kin, &m, &[], &quiet(), &mut SimRng::seed_from_u64(0)).unwrap();
    let gyro_psd = (0.01f64.to_radians() / 60.0).powi(2); // 0.01 deg/sqrt(h) ARW
    let accel_psd = 1e-6;
    let cfg = SimConfig {
        gyro_psd,
        accel_psd,
        ..quiet()
    };
    let noisy = simulate_imu(&kin, &m, &[], &cfg, &mut SimRng::seed_from_u64(42)).unwrap();
    let dt = 0.01;
    let dof = (clean.len() * 3) as f64;
    let (mut sg, mut sa, mut mg, mut ma) = (0.0, 0.0, 0.0, 0.0);
    for (c, n) in clean.iter().zip(&noisy) {
        let eg = n.dtheta - c.dtheta;
        let ea = n.dv - c.dv;
        sg += eg.norm_squared() / (gyro_psd * dt);
        sa += ea.norm_squared() / (accel_psd * dt);
        mg += eg.sum() / (gyro_psd * dt).sqrt();
        ma += ea.sum() / (accel_psd * dt).sqrt();
    }
    // sum of squares of dof standard normals: chi-square, mean dof, sd sqrt(2 dof); 5-sigma band.
    let band = 5.0 * (2.0 * dof).sqrt();
    assert!((sg - dof).abs() < band, "gyro {sg} vs {dof}");
    assert!((sa - dof).abs() < band, "accel {sa} vs {dof}");
    // Sums of the normalised noise: mean 0, sd sqrt(dof).
    assert!(mg.abs() < 5.0 * dof.sqrt() && ma.abs() < 5.0 * dof.sqrt());
}

#[test]
fn turntable_stamps_follow_the_clock_and_angles_are_late_by_tau() {
    let kin = Kinematics::new(program(), mounting(), site());
    let s = sensor();
    let duration = 100.0;
    let tt = simulate_turntable(&kin, &s, duration, &mut SimRng::seed_from_u64(1)).unwrap();
    // Covers the IMU run on the turntable clock, on the sensor's regular grid.
    let (t0, t1) = (s.turntable_time(0.0), s.turntable_time(duration));
    assert!(tt[0].t_tt >= t0 && tt[0].t_tt - t0 < 1.0 / s.rate_hz);
    let last = tt.last().unwrap().t_tt;
    assert!(last <= t1 && t1 - last < 1.0 / s.rate_hz);
    for w in tt.windows(2) {
        assert!((w[1].t_tt - w[0].t_tt - 1.0 / s.rate_hz).abs() < 1e-9);
    }
    let mut max_lag_effect: f64 = 0.0;
    for r in &tt {
        let t_imu = s.imu_time(r.t_tt);
        let (k, _) = kin.program.state(t_imu - s.tau);
        for (read, true_angle) in r.k_deg.iter().zip(k) {
            assert!(
                (read - true_angle.to_degrees()).abs() < 1e-9,
                "t_tt {}",
                r.t_tt
            );
        }
        let (k_now, _) = kin.program.state(t_imu);
        max_lag_effect = max_lag_effect.max((k_now[1] - k[1]).abs().to_degrees());
    }
    // During the bank turn the delay shows: 10 deg/s x 13 ms = 0.13 deg.
    assert!((max_lag_effect - 0.13).abs() < 1e-6, "{max_lag_effect}");
}

#[test]
fn turntable_noise_has_the_per_sample_sigma() {
    let kin = Kinematics::new(program(), mounting(), site());
    let mut s = sensor();
    s.sigma = [1e-5, 2e-5, 5e-6];
    let clean = simulate_turntable(&kin, &sensor(), 120.0, &mut SimRng::seed_from_u64(1)).unwrap();
    let noisy = simulate_turntable(&kin, &s, 120.0, &mut SimRng::seed_from_u64(9)).unwrap();
    assert_eq!(clean.len(), noisy.len());
    let n = clean.len() as f64;
    for g in 0..3 {
        let ss: f64 = clean
            .iter()
            .zip(&noisy)
            .map(|(c, r)| ((r.k_deg[g] - c.k_deg[g]).to_radians() / s.sigma[g]).powi(2))
            .sum();
        assert!(
            (ss - n).abs() < 5.0 * (2.0 * n).sqrt(),
            "gimbal {g}: {ss} vs {n}"
        );
    }
}

#[test]
fn runs_are_reproducible_and_truth_is_complete() {
    let kin = Kinematics::new(program(), mounting(), site());
    let m = model();
    let p = draw_parameters(&m, &mut SimRng::seed_from_u64(7));
    assert_eq!(p, draw_parameters(&m, &mut SimRng::seed_from_u64(7)));
    // Drawn values have the prior's scale.
    let specs = m.params();
    let z2: f64 = p
        .iter()
        .zip(&specs)
        .map(|(v, s)| (v / s.prior_sigma).powi(2))
        .sum();
    // A chi-square with as many degrees of freedom as parameters: inside its two-sided 99.9 %
    // band (statrs quantiles).
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let chi2 = ChiSquared::new(specs.len() as f64).unwrap();
    let (lo, hi) = (chi2.inverse_cdf(0.0005), chi2.inverse_cdf(0.9995));
    assert!(z2 > lo && z2 < hi, "{z2} outside [{lo:.1}, {hi:.1}]");
    let mut s = sensor();
    s.sigma = [1e-5; 3];
    let cfg = SimConfig {
        duration_s: Some(5.0),
        gyro_psd: 1e-12,
        accel_psd: 1e-8,
        seed: 11,
        ..quiet()
    };
    let a = simulate(&kin, &m, &p, &s, &cfg).unwrap();
    let b = simulate(&kin, &m, &p, &s, &cfg).unwrap();
    assert_eq!(a.imu, b.imu);
    assert_eq!(a.turntable, b.turntable);
    let c = simulate(
        &kin,
        &m,
        &p,
        &s,
        &SimConfig {
            seed: 12,
            ..cfg.clone()
        },
    )
    .unwrap();
    assert_ne!(a.imu, c.imu);

    let truth = &a.truth;
    assert_eq!(truth.parameters.len(), 21 + 3 + 1 + 3 + 2);
    assert_eq!(truth.get("gyro.bias.x"), Some(p[0]));
    assert_eq!(truth.get("accel.gamma.zz"), Some(p[20]));
    assert_eq!(truth.get("install.delta.y"), Some(mounting().delta_z.y));
    assert_eq!(truth.get("base.gamma.z"), Some(mounting().gamma_p.z));
    assert_eq!(truth.get("turntable.tau"), Some(s.tau));
    assert_eq!(
        truth.get("turntable.clock.offset"),
        Some(s.clock.turntable_offset_s)
    );
    assert_eq!(
        truth.get("turntable.clock.rate_error"),
        Some(s.clock.turntable_rate_error)
    );
    let json = truth.to_json();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let first = &v["parameters"][0];
    assert_eq!(first["name"], "gyro.bias.x");
    assert_eq!(first["unit"], "rad/s");
    assert_eq!(first["value"].as_f64(), Some(p[0]));
    // serde_json's default float parser may be off by one ulp (its `float_roundtrip` feature
    // is not enabled in the workspace); the text itself is the shortest round-trip form.
    let back: Truth = serde_json::from_str(&json).unwrap();
    for (x, y) in back.parameters.iter().zip(&truth.parameters) {
        assert_eq!((&x.name, &x.unit), (&y.name, &y.unit));
        assert!((x.value - y.value).abs() <= 2.0 * f64::EPSILON * y.value.abs());
    }

    // Bad settings are refused, not panicked on.
    assert!(simulate(&kin, &m, &p[..20], &s, &cfg).is_err());
    assert!(
        simulate(
            &kin,
            &m,
            &p,
            &s,
            &SimConfig {
                imu_rate_hz: 0.0,
                ..cfg.clone()
            }
        )
        .is_err()
    );
    assert!(
        simulate(
            &kin,
            &m,
            &p,
            &s,
            &SimConfig {
                quadrature_points: 0,
                ..cfg
            }
        )
        .is_err()
    );
}

/// The accelerometers sampling `d` late, `f'(t) = f(t - d)`: the increments with the time-offset
/// term are the plain increments over the interval shifted by `d`, to second order in `d`,
/// inside a piece and across the program's rate changes (0 s: the rotation starts; 36 s: it
/// stops), where the first-order model itself is off by a known amount.
#[test]
fn time_offset_increments_are_the_shifted_increments() {
    use sins_model::candidates::Candidate;
    let kin = Kinematics::new(program(), mounting(), site());
    let plain = ErrorModel::new();
    let mut late = ErrorModel::new();
    late.push(Candidate::GyroAccelTimeOffset.term(1e-3).unwrap());
    let d = 1e-3;
    let rule = GaussLegendre::new(6).unwrap();
    for (a, b) in [(0.0, 0.01), (12.0, 12.01), (35.995, 36.005), (50.0, 50.01)] {
        let (_, v_late) = increments_at(&kin, &late, &[d], &rule, a, b, 0.0);
        let (_, v_plain) = increments_at(&kin, &plain, &[], &rule, a, b, 0.0);
        let (_, v_shift) = increments_at(&kin, &plain, &[], &rule, a - d, b - d, 0.0);
        let effect = (v_shift - v_plain).norm();
        assert!(effect > 1e-6, "[{a}, {b}]: effect {effect:e}");
        // Second order in d inside a piece; across a kink of f (36 s: the rotation stops, df/dt
        // jumps by about w g) the first-order model is off by |jump of df/dt| d^2 / 2.
        let kink = if [0.0, 36.0].iter().any(|&k| a - d < k && k < b) {
            0.5 * d * d * 10f64.to_radians() * 9.82
        } else {
            0.0
        };
        assert!(
            (v_late - v_shift).norm() < 1e-3 * effect + 1.1 * kink,
            "[{a}, {b}]: {:e} vs effect {effect:e}",
            (v_late - v_shift).norm()
        );
    }
}

/// Size effect across a jump of the rate: over a run of intervals the tangential part sums to
/// `(w(end) - w(start)) x r_i` whatever the jumps inside, and a jump at an interval's end
/// belongs to the next interval (left limits).
#[test]
fn size_effect_counts_rate_jumps_once() {
    use sins_model::candidates::Candidate;
    let kin = Kinematics::new(program(), mounting(), site());
    let plain = ErrorModel::new();
    let mut lever = ErrorModel::new();
    lever.push(Candidate::AccelSizeEffect.term(0.02).unwrap());
    let p: Vec<f64> = (0..9).map(|i| 0.01 * (i as f64 - 3.5)).collect();
    let r = |i: usize| Vector3::new(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    let rule = GaussLegendre::new(8).unwrap();
    let dt = 0.01;
    // The rotation about bank stops at 36 s: intervals 35.95..36.05.
    let (t0, t1): (f64, f64) = (35.95, 36.05);
    let n = ((t1 - t0) / dt).round() as usize;
    let mut sum = Vector3::zeros();
    let mut centripetal = Vector3::zeros();
    for k in 0..n {
        let (a, b) = (t0 + k as f64 * dt, t0 + (k + 1) as f64 * dt);
        let (_, v_lever) = increments_at(&kin, &lever, &p, &rule, a, b, 0.0);
        let (_, v_plain) = increments_at(&kin, &plain, &[], &rule, a, b, 0.0);
        sum += v_lever - v_plain;
        // The centripetal part by a fine midpoint sum.
        let m = 200;
        for q in 0..m {
            let w = kin.sample(a + (q as f64 + 0.5) * dt / m as f64).omega_body;
            centripetal += Vector3::from_fn(|i, _| w.cross(&w.cross(&r(i)))[i]) * (dt / m as f64);
        }
    }
    let dw = kin.sample_left(t1).omega_body - kin.sample_left(t0).omega_body;
    let tangential = Vector3::from_fn(|i, _| dw.cross(&r(i))[i]);
    assert!(tangential.norm() > 1e-4, "the jump is there: {tangential}");
    let expect = tangential + centripetal;
    assert!(
        (sum - expect).norm() < 1e-6 * expect.norm(),
        "{sum} vs {expect}"
    );
    // A jump exactly at the end of an interval is not in it.
    let (_, v_before) = increments_at(&kin, &lever, &p, &rule, 35.99, 36.0, 0.0);
    let (_, v_after) = increments_at(&kin, &lever, &p, &rule, 36.0, 36.01, 0.0);
    let (_, p_before) = increments_at(&kin, &plain, &[], &rule, 35.99, 36.0, 0.0);
    let (_, p_after) = increments_at(&kin, &plain, &[], &rule, 36.0, 36.01, 0.0);
    assert!((v_before - p_before).norm() < 0.1 * tangential.norm());
    assert!((v_after - p_after - tangential).norm() < 0.1 * tangential.norm());
}

/// The gyro-bias random walk grows its variance as `intensity^2 t` (400 walks, 1000 steps;
/// the sample variance of 400 normals is within 20 % of the truth with probability > 0.99),
/// and the walk does not touch the noise draws of the run.
#[test]
fn gyro_bias_walk_has_the_right_variance_growth() {
    use turntable::simulate::{GyroDrift, gyro_bias_walk, simulate_imu_drifting};
    let q = [1e-6, 2e-6, 5e-7];
    let (dt, n, runs) = (0.01, 1000, 400);
    let mut var = [Vector3::<f64>::zeros(); 2];
    for seed in 0..runs {
        let w = gyro_bias_walk(
            &GyroDrift {
                intensity: q,
                seed: seed as u64,
            },
            dt,
            n,
        );
        assert_eq!(w[0], Vector3::zeros());
        var[0] += w[n / 4].component_mul(&w[n / 4]) / runs as f64;
        var[1] += w[n].component_mul(&w[n]) / runs as f64;
    }
    for (k, t) in [(0, n as f64 / 4.0 * dt), (1, n as f64 * dt)] {
        for i in 0..3 {
            let expect = q[i] * q[i] * t;
            let ratio = var[k][i] / expect;
            assert!((0.8..1.2).contains(&ratio), "t {t} axis {i}: ratio {ratio}");
        }
    }
    // The drift is in the gyros only, the same noise draws otherwise.
    let kin = Kinematics::new(program(), mounting(), site());
    let m = model();
    let p = vec![0.0; 21];
    let cfg = SimConfig {
        gyro_psd: 1e-12,
        accel_psd: 1e-8,
        duration_s: Some(2.0),
        ..quiet()
    };
    let drift = GyroDrift {
        intensity: q,
        seed: 9,
    };
    let a = simulate_imu(&kin, &m, &p, &cfg, &mut SimRng::seed_from_u64(4)).unwrap();
    let b = simulate_imu_drifting(
        &kin,
        &m,
        &p,
        &cfg,
        Some(&drift),
        &mut SimRng::seed_from_u64(4),
    )
    .unwrap();
    let walk = gyro_bias_walk(&drift, 0.01, a.len());
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        assert_eq!(x.dv, y.dv);
        let expect = -(walk[i] + walk[i + 1]) * 0.005;
        assert!((y.dtheta - x.dtheta - expect).norm() < 1e-15 * x.dtheta.norm() + 1e-22);
    }
}
