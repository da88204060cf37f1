//! Every transition and measurement Jacobian of the calibration model against central finite
//! differences of the nonlinear model it linearises.

use calib::config::RunConfig;
use calib::model::layout::StateLayout;
use calib::model::layout::layout_for;
use calib::model::{AngleSample, LinearModel, MeasurementKind};
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::attitude::{apply_attitude_error, attitude_error, exp_so3, log_so3};
use sins_model::terms::{Sensor, SensorInput};
use turntable::gimbal::{c_platform_to_base, gimbal_jacobian};
use turntable::kinematics::{Kinematics, Mounting};

fn setup(with_base: bool) -> (RunConfig, StateLayout, Kinematics) {
    let mut config = RunConfig::paper();
    config.filter.estimate_base_misalignment = with_base;
    let layout = layout_for(&config, true);
    let kin = Kinematics::new(
        config.program().unwrap(),
        Mounting::default(),
        config.site(),
    );
    (config, layout, kin)
}

/// A nominal parameter vector of realistic size (instrument part).
fn nominal_params(layout: &StateLayout) -> Vec<f64> {
    layout
        .entries()
        .iter()
        .skip(StateLayout::INSTRUMENT)
        .take(layout.n_instrument())
        .enumerate()
        .map(|(i, e)| e.prior_sigma * (0.5 + 0.1 * i as f64).sin())
        .collect()
}

/// Nonlinear attitude error after integrating the true and the erroneous gyro from t0 to t1.
fn nonlinear_beta(
    kin: &Kinematics,
    layout: &StateLayout,
    t0: f64,
    t1: f64,
    beta0: &Vector3<f64>,
    p: &[f64],
) -> Vector3<f64> {
    let n = 4000;
    let dt = (t1 - t0) / n as f64;
    let u = kin.earth_rate_enu();
    let mut c = kin.sample(t0).c_body_to_enu;
    let mut cc = apply_attitude_error(beta0, &c);
    for k in 0..n {
        let s = kin.sample(t0 + (k as f64 + 0.5) * dt);
        let input = SensorInput {
            omega_body: s.omega_body,
            f_body: s.f_body,
            ..SensorInput::default()
        };
        let nu = layout.model.error(Sensor::Gyro, p, &input);
        let e = exp_so3(&(-u * dt));
        cc = e * cc * exp_so3(&((s.omega_body - nu) * dt));
        c = kin.sample(t0 + (k + 1) as f64 * dt).c_body_to_enu;
    }
    attitude_error(&cc, &c)
}

#[test]
fn transition_matches_finite_differences_of_strapdown() {
    let (config, layout, kin) = setup(false);
    let p = nominal_params(&layout);
    // Inside cycle 1 (spinning about East), across a rate reversal and inside a re-orientation.
    for (t0, t1) in [(100.0, 101.0), (449.5, 450.5), (902.0, 903.0)] {
        let imu_dt = 1.0 / config.filter.imu_rate_hz;
        let mut model = LinearModel::new(&layout, imu_dt, &kin.earth_rate_enu(), 0.0);
        let steps = ((t1 - t0) / imu_dt).round() as usize;
        for k in 0..steps {
            let s = kin.sample(t0 + (k as f64 + 0.5) * imu_dt);
            let input = SensorInput {
                omega_body: s.omega_body,
                f_body: s.f_body,
                ..SensorInput::default()
            };
            model.substep(&layout, &s.c_body_to_enu, &input, &p, None);
        }
        let phi = model.phi_top();
        // Each Jacobian is checked at its linearisation point (zero attitude error); away from it
        // the nonlinear model has cross terms (beta x nu-effect) the linear model leaves out.
        let beta0 = Vector3::zeros();
        let p0 = vec![0.0; p.len()];
        // Attitude columns.
        for j in 0..3 {
            let mut e = Vector3::zeros();
            e[j] = 1e-6;
            let fd = (nonlinear_beta(&kin, &layout, t0, t1, &(beta0 + e), &p0)
                - nonlinear_beta(&kin, &layout, t0, t1, &(beta0 - e), &p0))
                / 2e-6;
            let col = Vector3::new(phi[(0, j)], phi[(1, j)], phi[(2, j)]);
            assert!(
                (fd - col).norm() < 1e-8,
                "t0 {t0}: beta column {j}: fd {fd:?} vs {col:?}"
            );
        }
        // Instrument columns (accelerometer ones must be zero).
        for i in 0..layout.n_instrument() {
            let h = layout.entries()[StateLayout::INSTRUMENT + i].prior_sigma;
            let mut pp = p0.clone();
            pp[i] += h;
            let mut pm = p0.clone();
            pm[i] -= h;
            let fd = (nonlinear_beta(&kin, &layout, t0, t1, &beta0, &pp)
                - nonlinear_beta(&kin, &layout, t0, t1, &beta0, &pm))
                / (2.0 * h);
            let j = StateLayout::INSTRUMENT + i;
            let col = Vector3::new(phi[(0, j)], phi[(1, j)], phi[(2, j)]);
            let scale = fd.norm().max(col.norm()).max(1e-12);
            assert!(
                (fd - col).norm() < 1e-4 * scale + 1e-12,
                "t0 {t0}: {}: fd {fd:?} vs {col:?}",
                layout.entries()[j].name
            );
        }
    }
}

/// Nonlinear window measurements over [t0, t1] from the state at t0: the computed attitude is
/// integrated from the erroneous gyro (start error `beta0`); returns the mean specific-force
/// residual `mean(C' f') - f_x` and the mean turntable residual `y` over the IMU step ends, with
/// the turntable late by `tau` and the mounting `delta`.
fn nonlinear_window(
    kin: &Kinematics,
    layout: &StateLayout,
    (t0, t1): (f64, f64),
    beta0: &Vector3<f64>,
    p: &[f64],
    delta: &Vector3<f64>,
    tau: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let imu_steps = 100;
    let sub = 20;
    let dt = (t1 - t0) / (imu_steps * sub) as f64;
    let u = kin.earth_rate_enu();
    let e = exp_so3(&(-u * dt));
    let truth = Kinematics::new(
        kin.program.clone(),
        Mounting {
            delta_z: *delta,
            gamma_p: Vector3::zeros(),
        },
        kin.site,
    );
    let mut cc = apply_attitude_error(beta0, &truth.sample(t0).c_body_to_enu);
    let (mut acc, mut y) = (Vector3::zeros(), Vector3::zeros());
    for k in 0..imu_steps * sub {
        let s = truth.sample(t0 + (k as f64 + 0.5) * dt);
        let input = SensorInput {
            omega_body: s.omega_body,
            f_body: s.f_body,
            ..SensorInput::default()
        };
        let nu = layout.model.error(Sensor::Gyro, p, &input);
        let f_meas = s.f_body + layout.model.error(Sensor::Accel, p, &input);
        let half = exp_so3(&((s.omega_body - nu) * dt * 0.5));
        let c_mid = exp_so3(&(-u * dt * 0.5)) * cc * half;
        acc += c_mid * f_meas * dt;
        cc = e * cc * half * half;
        if (k + 1) % sub == 0 {
            // The turntable reports the angles of t - tau and assumes a perfect mounting.
            let t = t0 + (k + 1) as f64 * dt;
            let (k_late, _) = kin.program.state(t - tau);
            let c_tt: Matrix3<f64> = c_platform_to_base(&k_late);
            y += -log_so3(&(cc * c_tt.transpose()));
        }
    }
    (
        acc / (t1 - t0) - kin.specific_force_enu(),
        y / imu_steps as f64,
    )
}

#[test]
fn window_measurements_match_finite_differences() {
    let (_, layout, kin) = setup(false);
    let p = nominal_params(&layout);
    let zero = Vector3::zeros();
    // Spinning about East with the window mean of beta moving, across a reversal, and in a
    // re-orientation.
    for (t0, t1) in [(1000.0, 1001.0), (100.0, 101.0), (902.0, 903.0)] {
        let imu_dt = (t1 - t0) / 100.0;
        let mut model = LinearModel::new(&layout, imu_dt, &kin.earth_rate_enu(), 0.0);
        for k in 0..100 {
            let s = kin.sample(t0 + (k as f64 + 0.5) * imu_dt);
            let input = SensorInput {
                omega_body: s.omega_body,
                f_body: s.f_body,
                ..SensorInput::default()
            };
            model.substep(&layout, &s.c_body_to_enu, &input, &p, Some(&zero));
            let s = kin.sample(t0 + (k + 1) as f64 * imu_dt);
            model.add_angle_sample(&AngleSample {
                y: zero,
                c_body_to_enu: s.c_body_to_enu,
                platform_rate_enu: s.platform_rate_enu,
                gimbal_jacobian: gimbal_jacobian(&s.k),
                records: &[(k, 1.0)],
            });
        }
        // In terms of the state at t0: H_end * Phi.
        let n = layout.dim();
        let mut phi = DMatrix::<f64>::identity(n, n);
        let top = model.phi_top();
        for i in 0..3 {
            for j in 0..n {
                phi[(i, j)] = top[(i, j)];
            }
        }
        let as_dmatrix = |h: faer::MatRef<'_, f64>| DMatrix::from_fn(3, n, |i, j| h[(i, j)]);
        model
            .accel_measurement(&kin.specific_force_enu(), 1e-6)
            .unwrap();
        let ha = as_dmatrix(model.h(MeasurementKind::Accel)) * &phi;
        model.turntable_measurement(&layout, 1e-10).unwrap();
        let ht = as_dmatrix(model.h(MeasurementKind::Turntable)) * &phi;
        let p0 = vec![0.0; p.len()];
        let f = |beta: &Vector3<f64>, pp: &[f64], d: &Vector3<f64>, tau: f64| {
            nonlinear_window(&kin, &layout, (t0, t1), beta, pp, d, tau)
        };
        let check = |j: usize,
                     plus: (Vector3<f64>, Vector3<f64>),
                     minus: (Vector3<f64>, Vector3<f64>),
                     h: f64| {
            let fa = (plus.0 - minus.0) / (2.0 * h);
            let ft = (plus.1 - minus.1) / (2.0 * h);
            let ca = Vector3::new(ha[(0, j)], ha[(1, j)], ha[(2, j)]);
            let ct = Vector3::new(ht[(0, j)], ht[(1, j)], ht[(2, j)]);
            let name = &layout.entries()[j].name;
            assert!(
                // Absolute part: rounding of the 2000-sub-step sums of g-sized terms.
                (fa - ca).norm() <= 1e-4 * fa.norm().max(ca.norm()) + 1e-5,
                "t0 {t0}: specific force, {name}: fd {fa:?} vs {ca:?}"
            );
            assert!(
                (ft - ct).norm() <= 1e-4 * ft.norm().max(ct.norm()) + 1e-9,
                "t0 {t0}: turntable, {name}: fd {ft:?} vs {ct:?}"
            );
        };
        for j in 0..3 {
            let mut e = Vector3::zeros();
            e[j] = 1e-6;
            check(j, f(&e, &p0, &zero, 0.0), f(&-e, &p0, &zero, 0.0), 1e-6);
        }
        for i in 0..layout.n_instrument() {
            let j = StateLayout::INSTRUMENT + i;
            let h = layout.entries()[j].prior_sigma * 1e-2;
            let (mut pp, mut pm) = (p0.clone(), p0.clone());
            pp[i] += h;
            pm[i] -= h;
            check(j, f(&zero, &pp, &zero, 0.0), f(&zero, &pm, &zero, 0.0), h);
        }
        let k = layout.install.unwrap();
        for a in 0..3 {
            let mut e = Vector3::zeros();
            e[a] = 1e-7;
            check(k + a, f(&zero, &p0, &e, 0.0), f(&zero, &p0, &-e, 0.0), 1e-7);
        }
        let k = layout.tau.unwrap();
        check(
            k,
            f(&zero, &p0, &zero, 1e-5),
            f(&zero, &p0, &zero, -1e-5),
            1e-5,
        );
    }
}

/// Nonlinear turntable measurement: the small rotation y with C_imu C_tt^T = exp(-skew(y)).
fn nonlinear_turntable(
    kin: &Kinematics,
    t: f64,
    beta: &Vector3<f64>,
    delta: &Vector3<f64>,
    tau: f64,
    gamma_p: &Vector3<f64>,
) -> Vector3<f64> {
    let truth = Kinematics::new(
        kin.program.clone(),
        Mounting {
            delta_z: *delta,
            gamma_p: *gamma_p,
        },
        kin.site,
    );
    let c_true = truth.sample(t).c_body_to_enu;
    let c_imu = apply_attitude_error(beta, &c_true);
    // The turntable reports the angles of t - tau and assumes a perfect mounting.
    let (k_late, _) = kin.program.state(t - tau);
    let c_tt: Matrix3<f64> = c_platform_to_base(&k_late);
    -log_so3(&(c_imu * c_tt.transpose()))
}

#[test]
fn turntable_measurement_matches_finite_differences() {
    let (_, layout, kin) = setup(true);
    let beta = Vector3::new(2e-4, -1e-4, 5e-4);
    let delta = Vector3::new(3e-3, -2e-3, 1e-3);
    let gamma = Vector3::new(2e-5, 1e-5, -3e-5);
    let tau = 0.02;
    for t in [100.0, 1000.0, 2000.0, 905.0] {
        let truth = Kinematics::new(
            kin.program.clone(),
            Mounting {
                delta_z: delta,
                gamma_p: gamma,
            },
            kin.site,
        );
        let s = truth.sample(t);
        let h = LinearModel::turntable_h(&layout, &s.c_body_to_enu, &s.platform_rate_enu);
        let y0 = nonlinear_turntable(&kin, t, &beta, &delta, tau, &gamma);
        let y_lin = beta - gamma - s.c_body_to_enu * delta - s.platform_rate_enu * tau;
        assert!(
            (y0 - y_lin).norm() < 1e-5,
            "t {t}: nonlinear {y0:?} vs linear {y_lin:?}"
        );
        let cols: Vec<(usize, Vector3<f64>)> = (0..3)
            .map(|j| {
                let mut e = Vector3::zeros();
                e[j] = 1e-6;
                (
                    j,
                    (nonlinear_turntable(&kin, t, &(beta + e), &delta, tau, &gamma)
                        - nonlinear_turntable(&kin, t, &(beta - e), &delta, tau, &gamma))
                        / 2e-6,
                )
            })
            .chain((0..3).map(|j| {
                let mut e = Vector3::zeros();
                e[j] = 1e-6;
                (
                    layout.install.unwrap() + j,
                    (nonlinear_turntable(&kin, t, &beta, &(delta + e), tau, &gamma)
                        - nonlinear_turntable(&kin, t, &beta, &(delta - e), tau, &gamma))
                        / 2e-6,
                )
            }))
            .chain(std::iter::once((
                layout.tau.unwrap(),
                (nonlinear_turntable(&kin, t, &beta, &delta, tau + 1e-4, &gamma)
                    - nonlinear_turntable(&kin, t, &beta, &delta, tau - 1e-4, &gamma))
                    / 2e-4,
            )))
            .chain((0..3).map(|j| {
                let mut e = Vector3::zeros();
                e[j] = 1e-6;
                (
                    layout.base.unwrap() + j,
                    (nonlinear_turntable(&kin, t, &beta, &delta, tau, &(gamma + e))
                        - nonlinear_turntable(&kin, t, &beta, &delta, tau, &(gamma - e)))
                        / 2e-6,
                )
            }))
            .collect();
        for (j, fd) in cols {
            let col = Vector3::new(h[(0, j)], h[(1, j)], h[(2, j)]);
            // Linearised about zero errors: neglected terms are of the order of the other errors (~5e-3).
            assert!(
                (fd - col).norm() < 1e-2 * col.norm().max(1e-3),
                "t {t}: {}: fd {fd:?} vs {col:?}",
                layout.entries()[j].name
            );
        }
    }
}

#[test]
fn the_same_filter_gives_the_same_answer_at_any_averaged_measurement_rate() {
    // Under the PSD reading the measurement rate must not change the information.
    let mut a = RunConfig::paper();
    a.filter.imu_rate_hz = 10.0;
    let mut b = a.clone();
    b.filter.accel_rate_hz = 0.5;
    b.filter.turntable_rate_hz = 0.5;
    for tt in [false, true] {
        let pa = calib::estimate::covariance::covariance_analysis(&a, tt).unwrap();
        let pb = calib::estimate::covariance::covariance_analysis(&b, tt).unwrap();
        for name in [
            "gyro.theta.xx",
            "accel.gamma.yy",
            "accel.bias.x",
            "gyro.theta.xy",
        ] {
            let (sa, sb) = (pa.sigma(name).unwrap(), pb.sigma(name).unwrap());
            assert!((sa / sb - 1.0).abs() < 0.05, "{name}: {sa} vs {sb}");
        }
    }
}
