//! Every transition and measurement Jacobian of the calibration model against central finite
//! differences of the nonlinear model it linearises.

use calib::config::RunConfig;
use calib::covariance::layout_for;
use calib::layout::StateLayout;
use calib::model::LinearModel;
use nalgebra::{Matrix3, Vector3};
use sins_model::attitude::{apply_attitude_error, attitude_error, exp_so3, log_so3};
use sins_model::terms::{Sensor, SensorInput};
use turntable::gimbal::c_platform_to_base;
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
            };
            model.substep(&layout, &s.c_body_to_enu, &input, &p);
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

/// Nonlinear specific-force measurement averaged over [t0, t1] with constant beta.
fn nonlinear_accel(
    kin: &Kinematics,
    layout: &StateLayout,
    t0: f64,
    t1: f64,
    beta: &Vector3<f64>,
    p: &[f64],
) -> Vector3<f64> {
    let n = 100;
    let dt = (t1 - t0) / n as f64;
    let mut sum = Vector3::zeros();
    for k in 0..n {
        let s = kin.sample(t0 + (k as f64 + 0.5) * dt);
        let input = SensorInput {
            omega_body: s.omega_body,
            f_body: s.f_body,
        };
        let f_meas = s.f_body + layout.model.error(Sensor::Accel, p, &input);
        sum += apply_attitude_error(beta, &s.c_body_to_enu) * f_meas * dt;
    }
    sum / (t1 - t0) - kin.specific_force_enu()
}

#[test]
fn accel_measurement_matches_finite_differences() {
    let (_, layout, kin) = setup(false);
    let p = nominal_params(&layout);
    let (t0, t1) = (1000.0, 1001.0);
    let mut model = LinearModel::new(&layout, 0.01, &kin.earth_rate_enu(), 0.0);
    for k in 0..100 {
        let s = kin.sample(t0 + (k as f64 + 0.5) * 0.01);
        let input = SensorInput {
            omega_body: s.omega_body,
            f_body: s.f_body,
        };
        model.substep(&layout, &s.c_body_to_enu, &input, &p);
    }
    // Linearisation point: zero attitude error, parameters p; the beta block then uses the
    // measured (erroneous) specific force in ENU, as estimation does.
    let beta = Vector3::zeros();
    let f_meas_enu = nonlinear_accel(&kin, &layout, t0, t1, &beta, &p) + kin.specific_force_enu();
    let h = model.accel_h(&f_meas_enu);
    for j in 0..StateLayout::INSTRUMENT + layout.n_instrument() {
        let (fd, eps) = if j < 3 {
            let mut e = Vector3::zeros();
            e[j] = 1e-6;
            (
                (nonlinear_accel(&kin, &layout, t0, t1, &(beta + e), &p)
                    - nonlinear_accel(&kin, &layout, t0, t1, &(beta - e), &p))
                    / 2e-6,
                1e-6,
            )
        } else {
            let i = j - 3;
            let e = layout.entries()[j].prior_sigma;
            let mut pp = p.clone();
            pp[i] += e;
            let mut pm = p.clone();
            pm[i] -= e;
            (
                (nonlinear_accel(&kin, &layout, t0, t1, &beta, &pp)
                    - nonlinear_accel(&kin, &layout, t0, t1, &beta, &pm))
                    / (2.0 * e),
                e,
            )
        };
        let col = Vector3::new(h[(0, j)], h[(1, j)], h[(2, j)]);
        let tol = 1e-6 * fd.norm().max(col.norm()) + 1e-9;
        assert!(
            (fd - col).norm() < tol,
            "{} (eps {eps}): fd {fd:?} vs {col:?}",
            layout.entries()[j].name
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
        let pa = calib::covariance::covariance_analysis(&a, tt).unwrap();
        let pb = calib::covariance::covariance_analysis(&b, tt).unwrap();
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
