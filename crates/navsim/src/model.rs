//! The SINS error model in geographic (ENU) axes and the initial alignment.
//!
//! Navigation state (7): `[dphi, dlambda, dV_E, dV_N, beta_E, beta_N, beta_U]` — latitude and
//! longitude errors \[rad\], horizontal velocity errors (m/s), attitude errors \[rad\] with the
//! paper's sign (the computed body-to-ENU DCM is `exp(-skew(beta)) C`, so the computed specific
//! force in ENU is `f + f x beta + C df`). The vertical channel (height and vertical velocity
//! errors) is left out: the figure of merit is horizontal, and it is unstable on its own anyway.
//!
//! Continuous dynamics `x_dot = F_nav x + F_instr c + noise`, with `c` the 21 constant
//! instrument parameters (see [`crate::instruments`]):
//!
//! ```text
//! dphi_dot    = dV_N / (R_M+h)
//! dlambda_dot = dV_E / ((R_N+h) cos phi) + V_E tan phi / ((R_N+h) cos phi) dphi
//! dV_E_dot    = f_N beta_U - f_U beta_N + W_U dV_N + V_N dW_U + (C df)_E
//! dV_N_dot    = f_U beta_E - f_E beta_U - W_U dV_E - V_E dW_U + (C df)_N
//! beta_dot    = beta x omega + d_omega + C nu
//! ```
//!
//! where `f` is the true specific force in ENU, `W = 2 Omega_ie + omega_en`,
//! `W_U = 2 Omega sin phi + V_E tan phi / (R_N+h)`,
//! `dW_U = (2 Omega cos phi + V_E / ((R_N+h) cos^2 phi)) dphi + tan phi / (R_N+h) dV_E`,
//! `omega = Omega_ie + omega_en` the rate of the ENU frame, and its error
//! `d_omega = (-dV_N/(R_M+h), -Omega sin phi dphi + dV_E/(R_N+h),
//!            Omega cos phi dphi + tan phi dV_E/(R_N+h) + V_E dphi / ((R_N+h) cos^2 phi))`.
//! `nu = nu0 + Theta w_body`, `df = df0 + Gamma f_body` use the true body rate (Earth rate +
//! transport rate + turn rate) and the true body specific force.

use nalgebra::{Const, Dyn, Matrix3, OMatrix, SMatrix, Vector3};
use sins_model::attitude::skew;
use sins_model::earth::Site;
use sins_model::terms::{ErrorModel, Sensor, SensorInput};

use crate::NavError;
// The instrument model is the instruments module's (its parameters are navigation's instrument
// state); re-exported here, where navigation takes its Jacobians.
use crate::instruments::INSTRUMENT_DIM;
pub use crate::instruments::paper_model;
use crate::trajectory::TrajectoryPoint;

/// Number of navigation error states.
pub const NAV_DIM: usize = 7;
/// Names of the navigation error states, in state order.
pub const NAV_NAMES: [&str; NAV_DIM] = [
    "nav.dlat",
    "nav.dlon",
    "nav.dv.e",
    "nav.dv.n",
    "nav.beta.e",
    "nav.beta.n",
    "nav.beta.u",
];
/// Index of the latitude error \[rad\].
pub const DLAT: usize = 0;
/// Index of the longitude error \[rad\].
pub const DLON: usize = 1;
/// Index of the east velocity error (m/s) (north follows).
pub const DV: usize = 2;
/// Index of the east attitude error \[rad\] (north, up follow).
pub const BETA: usize = 4;

/// 7x7 matrix over the navigation states.
pub type NavMatrix = SMatrix<f64, NAV_DIM, NAV_DIM>;
/// 7x21 matrix mapping instrument parameters into navigation-state rates.
pub type NavInstrumentMatrix = SMatrix<f64, NAV_DIM, INSTRUMENT_DIM>;
/// 3x21 map from instrument parameters to the attitude error after alignment.
pub type AlignmentMap = SMatrix<f64, 3, INSTRUMENT_DIM>;

/// 7xn matrix mapping the parameters of an [`crate::InstrumentModel`] into navigation-state
/// rates (or, in the response, navigation errors).
pub type NavModelMatrix = OMatrix<f64, Const<NAV_DIM>, Dyn>;

/// `C nu` and `C df` as linear maps of the instrument state: rows 0..3 give the gyro error in ENU,
/// rows 3..6 the accelerometer error in ENU. The sensor errors' Jacobians are those of the
/// instrument model ([`paper_model`]) at the true body rate and specific force.
pub fn instrument_errors_enu(
    c_body_to_enu: &Matrix3<f64>,
    w_body: &Vector3<f64>,
    f_body: &Vector3<f64>,
) -> SMatrix<f64, 6, INSTRUMENT_DIM> {
    let input = SensorInput {
        omega_body: *w_body,
        f_body: *f_body,
        ..SensorInput::default()
    };
    let m = model_errors_enu(paper_model(), c_body_to_enu, &input);
    SMatrix::<f64, 6, INSTRUMENT_DIM>::from_fn(|i, j| m[(i, j)])
}

/// [`instrument_errors_enu`] for any instrument model and sensor input (the rates of change
/// and the temperature included): rows 0..3 `C nu`, rows 3..6 `C df`, one column per
/// parameter of `model`.
pub fn model_errors_enu(
    model: &ErrorModel,
    c_body_to_enu: &Matrix3<f64>,
    input: &SensorInput,
) -> OMatrix<f64, Const<6>, Dyn> {
    let n = model.n_params();
    let mut m = OMatrix::<f64, Const<6>, Dyn>::zeros(n);
    let mut work = JacobianWork::new(n);
    work.rotated(model, c_body_to_enu, input, |row, k, v| {
        m.fixed_view_mut::<3, 1>(row, k).copy_from(v)
    });
    m
}

/// Scratch space of the sensor Jacobians (no allocation per call in the propagation).
pub(crate) struct JacobianWork {
    p: Vec<f64>,
    cols: Vec<Vector3<f64>>,
}

impl JacobianWork {
    pub(crate) fn new(n: usize) -> Self {
        Self {
            p: vec![0.0; n],
            cols: vec![Vector3::zeros(); n],
        }
    }

    /// Every column of the gyro (`row` 0) and accelerometer (`row` 3) Jacobians of `model` at
    /// `input`, rotated into ENU, passed to `put(row, parameter, column)`.
    pub(crate) fn rotated(
        &mut self,
        model: &ErrorModel,
        c_body_to_enu: &Matrix3<f64>,
        input: &SensorInput,
        mut put: impl FnMut(usize, usize, &Vector3<f64>),
    ) {
        for (row, sensor) in [(0, Sensor::Gyro), (3, Sensor::Accel)] {
            model.jacobian(sensor, &self.p, input, &mut self.cols);
            for (k, col) in self.cols.iter().enumerate() {
                put(row, k, &(c_body_to_enu * col));
            }
        }
    }

    /// `F_instr` of [`instrument_dynamics`] written into `b` (7 x n).
    pub(crate) fn instrument_dynamics(
        &mut self,
        model: &ErrorModel,
        c_body_to_enu: &Matrix3<f64>,
        input: &SensorInput,
        b: &mut NavModelMatrix,
    ) {
        self.rotated(model, c_body_to_enu, input, |row, k, v| {
            if row == 0 {
                b.fixed_view_mut::<3, 1>(BETA, k).copy_from(v);
            } else {
                b[(DV, k)] = v.x;
                b[(DV + 1, k)] = v.y;
            }
        });
    }
}

/// The continuous-time error dynamics at one point of the trajectory.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorDynamics {
    /// `F_nav` (7x7): coupling among navigation errors.
    pub f_nav: NavMatrix,
    /// `F_instr` (7x21): how the instrument parameters drive the navigation errors.
    pub f_instr: NavInstrumentMatrix,
}

/// The error dynamics (see the module doc) at trajectory point `p` for an Earth rotating at
/// `earth_rate` (rad/s), with the paper's instrument model.
pub fn error_dynamics(p: &TrajectoryPoint, earth_rate: f64) -> ErrorDynamics {
    let input = SensorInput {
        omega_body: p.body_rate(earth_rate),
        f_body: p.specific_force_body(earth_rate),
        ..SensorInput::default()
    };
    let b = instrument_dynamics(paper_model(), &p.c_body_to_enu, &input);
    ErrorDynamics {
        f_nav: nav_dynamics(p, earth_rate),
        f_instr: NavInstrumentMatrix::from_fn(|i, j| b[(i, j)]),
    }
}

/// `F_nav` (7x7) at trajectory point `p` for an Earth rotating at `earth_rate` (rad/s).
pub fn nav_dynamics(p: &TrajectoryPoint, earth_rate: f64) -> NavMatrix {
    let (sp, cp) = p.latitude.sin_cos();
    let tp = sp / cp;
    let rm = p.radius_north();
    let rn = p.radius_east();
    let (ve, vn) = (p.velocity_enu.x, p.velocity_enu.y);
    let om = earth_rate;
    let f = p.specific_force_enu(earth_rate);
    let omega = p.earth_rate_enu(earth_rate) + p.transport_rate_enu();
    let w_u = 2.0 * om * sp + ve * tp / rn;
    let dwu_dlat = 2.0 * om * cp + ve / (rn * cp * cp);
    let dwu_dve = tp / rn;

    let mut a = NavMatrix::zeros();
    let (e, n, u) = (BETA, BETA + 1, BETA + 2);
    let (dve, dvn) = (DV, DV + 1);
    // Position.
    a[(DLAT, dvn)] = 1.0 / rm;
    a[(DLON, DLAT)] = ve * tp / (rn * cp);
    a[(DLON, dve)] = 1.0 / (rn * cp);
    // Velocity (horizontal).
    a[(dve, DLAT)] = vn * dwu_dlat;
    a[(dve, dve)] = vn * dwu_dve;
    a[(dve, dvn)] = w_u;
    a[(dve, n)] = -f.z;
    a[(dve, u)] = f.y;
    a[(dvn, DLAT)] = -ve * dwu_dlat;
    a[(dvn, dve)] = -w_u - ve * dwu_dve;
    a[(dvn, e)] = f.z;
    a[(dvn, u)] = -f.x;
    // Attitude: beta x omega = -skew(omega) beta, plus the error of the computed frame rate.
    a.fixed_view_mut::<3, 3>(BETA, BETA)
        .copy_from(&(-skew(&omega)));
    a[(e, dvn)] += -1.0 / rm;
    a[(n, DLAT)] += -om * sp;
    a[(n, dve)] += 1.0 / rn;
    a[(u, DLAT)] += om * cp + ve / (rn * cp * cp);
    a[(u, dve)] += tp / rn;
    a
}

/// `F_instr` (7xn) of `model`: the sensor errors at `input` (body axes) rotated into ENU by
/// `c_body_to_enu`, the gyro errors into the attitude rows and the horizontal accelerometer
/// errors into the velocity rows.
pub fn instrument_dynamics(
    model: &ErrorModel,
    c_body_to_enu: &Matrix3<f64>,
    input: &SensorInput,
) -> NavModelMatrix {
    let n = model.n_params();
    let mut b = NavModelMatrix::zeros(n);
    JacobianWork::new(n).instrument_dynamics(model, c_body_to_enu, input, &mut b);
    b
}

/// The attitude error left by a stationary self-alignment, as a linear map `beta0 = A c` of the
/// instrument parameters `c` (alignment noise averaged out).
///
/// The vehicle stands level at `site` with body-to-ENU DCM `c_body_to_enu`; its gyros sense the
/// Earth rate `u = (0, Omega cos phi, Omega sin phi)` (body: `C^T u`), its accelerometers
/// `(0, 0, g)` (body: `C^T (0,0,g)`). Levelling makes the computed horizontal specific force zero,
/// `f x beta + C df = 0` horizontally; gyrocompassing makes the computed east Earth-rate
/// component zero, `(u x beta - C nu)_E = 0`:
///
/// ```text
/// beta_E = -(C df)_N / g
/// beta_N =  (C df)_E / g
/// beta_U =  (C nu)_E / (Omega cos phi) + tan(phi) beta_N
/// ```
///
/// Fails when `Omega cos phi` is zero (no azimuth from gyrocompassing), e.g. with Earth rotation
/// switched off.
pub fn alignment_map(
    site: &Site,
    c_body_to_enu: &Matrix3<f64>,
    earth_rate: f64,
) -> Result<AlignmentMap, NavError> {
    let a = model_alignment_map(paper_model(), site, c_body_to_enu, earth_rate, 0.0, true)?;
    Ok(AlignmentMap::from_fn(|i, j| a[(i, j)]))
}

/// [`alignment_map`] for any instrument model, the sensors at `temp_delta` (K) from the
/// reference of its thermal terms. Without `gyrocompass` the heading is given by an external
/// reference without error (`beta_U = 0`, and no horizontal Earth rate is needed): the
/// levelling alone.
pub fn model_alignment_map(
    model: &ErrorModel,
    site: &Site,
    c_body_to_enu: &Matrix3<f64>,
    earth_rate: f64,
    temp_delta: f64,
    gyrocompass: bool,
) -> Result<OMatrix<f64, Const<3>, Dyn>, NavError> {
    let g = site.normal_gravity();
    let u = Vector3::new(
        0.0,
        earth_rate * site.latitude.cos(),
        earth_rate * site.latitude.sin(),
    );
    let horizontal_rate = u.y;
    if gyrocompass && (horizontal_rate.is_nan() || horizontal_rate.abs() <= 1e-9) {
        return Err(NavError::AlignmentImpossible(format!(
            "the horizontal Earth rate is {horizontal_rate} rad/s: gyrocompassing cannot find the azimuth; \
             give the initial attitude covariance explicitly"
        )));
    }
    let input = SensorInput {
        omega_body: c_body_to_enu.transpose() * u,
        f_body: c_body_to_enu.transpose() * Vector3::new(0.0, 0.0, g),
        temp_delta,
        ..SensorInput::default()
    };
    let m = model_errors_enu(model, c_body_to_enu, &input);
    let nu_e = m.row(0);
    let df_e = m.row(3);
    let df_n = m.row(4);
    let mut a = OMatrix::<f64, Const<3>, Dyn>::zeros(m.ncols());
    a.set_row(0, &(-df_n / g));
    a.set_row(1, &(df_e / g));
    if gyrocompass {
        a.set_row(
            2,
            &(nu_e / horizontal_rate + df_e * (site.latitude.tan() / g)),
        );
    }
    Ok(a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::SnakeConfig;
    use crate::instruments::{ACCEL_BIAS, ACCEL_GAMMA, GYRO_BIAS, GYRO_THETA, INSTRUMENT_NAMES};
    use crate::trajectory::{SnakeTrajectory, StaticTrajectory, Trajectory, c_body_to_enu};
    use nalgebra::SVector;
    use sins_model::attitude::attitude_error;
    use sins_model::earth::EARTH_RATE;

    /// The sensor errors of design.md, evaluated exactly (not linearised).
    fn sensor_errors(
        c: &SVector<f64, INSTRUMENT_DIM>,
        w: &Vector3<f64>,
        f: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let nu0 = Vector3::new(c[0], c[1], c[2]);
        let theta = Matrix3::from_row_slice(&c.as_slice()[GYRO_THETA..GYRO_THETA + 9]);
        let df0 = Vector3::new(c[ACCEL_BIAS], c[ACCEL_BIAS + 1], c[ACCEL_BIAS + 2]);
        let g = &c.as_slice()[ACCEL_GAMMA..];
        let gamma = Matrix3::new(g[0], 0.0, 0.0, g[1], g[2], 0.0, g[3], g[4], g[5]);
        (nu0 + theta * w, df0 + gamma * f)
    }

    #[test]
    fn jacobians_match_the_sensor_model() {
        let w = Vector3::new(0.3, -0.2, 0.1);
        let f = Vector3::new(1.0, -2.0, 9.0);
        let c = SVector::<f64, 21>::from_fn(|i, _| (i as f64 * 0.37).sin());
        let (nu, df) = sensor_errors(&c, &w, &f);
        let m = instrument_errors_enu(&Matrix3::identity(), &w, &f) * c;
        assert!((nu - m.fixed_rows::<3>(0)).norm() < 1e-14);
        assert!((df - m.fixed_rows::<3>(3)).norm() < 1e-14);
        // The Gamma columns follow the documented name order.
        for (k, name) in INSTRUMENT_NAMES[ACCEL_GAMMA..].iter().enumerate() {
            let mut e = SVector::<f64, 21>::zeros();
            e[ACCEL_GAMMA + k] = 1.0;
            let (_, d) = sensor_errors(&e, &w, &f);
            let row = match &name[12..13] {
                "x" => 0,
                "y" => 1,
                _ => 2,
            };
            let col = match &name[13..14] {
                "x" => 0,
                "y" => 1,
                _ => 2,
            };
            assert_eq!(d[row], f[col], "{name}");
        }
    }

    /// Nonlinear analytic alignment from the measured (erroneous) sensor outputs: up along the
    /// measured specific force, east along (measured rate) x up.
    fn align(w_meas: &Vector3<f64>, f_meas: &Vector3<f64>) -> Matrix3<f64> {
        let up = f_meas.normalize();
        let east = w_meas.cross(&up).normalize();
        let north = up.cross(&east);
        // Rows of c_body_to_enu are the ENU axes in body coordinates.
        Matrix3::from_rows(&[east.transpose(), north.transpose(), up.transpose()])
    }

    #[test]
    fn alignment_map_matches_a_nonlinear_alignment() {
        for (lat, heading) in [(55.7f64, 0.0f64), (30.0, 130.0), (-45.0, -70.0)] {
            let site = Site::from_degrees(lat, 37.6, 150.0);
            let c0 = c_body_to_enu(heading.to_radians(), 0.0);
            let a = alignment_map(&site, &c0, EARTH_RATE).unwrap();
            let u = Vector3::new(
                0.0,
                EARTH_RATE * site.latitude.cos(),
                EARTH_RATE * site.latitude.sin(),
            );
            let w = c0.transpose() * u;
            let f = c0.transpose() * Vector3::new(0.0, 0.0, site.normal_gravity());
            // Realistic instrument errors (sigma of the paper's priors), scaled down so that
            // second-order terms are negligible; then the finite difference must match A.
            let sig = crate::instruments::InstrumentCovariance::diagonal_from_paper_table(
                0.5, 1e-3, 3.0, 0.02, 1e-3, 3.0,
            );
            for k in 0..INSTRUMENT_DIM {
                let h = 1e-3 * sig.cov[(k, k)].sqrt();
                let mut c = SVector::<f64, 21>::zeros();
                c[k] = h;
                let (nu, df) = sensor_errors(&c, &w, &f);
                let cp = align(&(w - nu), &(f + df));
                let beta_p = attitude_error(&cp, &c0);
                let (nu, df) = sensor_errors(&(-c), &w, &f);
                let cm = align(&(w - nu), &(f + df));
                let beta_m = attitude_error(&cm, &c0);
                let fd = (beta_p - beta_m) / (2.0 * h);
                let col = a.column(k);
                let scale = col.norm().max(1e-12);
                assert!(
                    (fd - col).norm() < 1e-6 * scale + 1e-9,
                    "lat {lat} heading {heading} param {}: {fd} vs {col}",
                    INSTRUMENT_NAMES[k]
                );
            }
            // Closed form of the classic result at heading 0.
            if heading == 0.0 {
                let g = site.normal_gravity();
                assert!((a[(1, ACCEL_BIAS)] - 1.0 / g).abs() < 1e-15); // beta_N = df_E / g
                assert!((a[(0, ACCEL_BIAS + 1)] + 1.0 / g).abs() < 1e-15); // beta_E = -df_N / g
                let want = 1.0 / (EARTH_RATE * site.latitude.cos());
                assert!((a[(2, GYRO_BIAS)] / want - 1.0).abs() < 1e-12); // beta_U = nu_E / (Omega cos phi)
                assert!((a[(2, ACCEL_BIAS)] - site.latitude.tan() / g).abs() < 1e-15);
            }
        }
        let site = Site::from_degrees(50.0, 0.0, 0.0);
        assert!(matches!(
            alignment_map(&site, &Matrix3::identity(), 0.0),
            Err(NavError::AlignmentImpossible(_))
        ));
    }

    #[test]
    fn aligned_attitude_is_an_equilibrium_at_rest() {
        // After alignment the horizontal velocity errors and the east attitude error do not
        // start to move: dV_dot = 0 and beta_E_dot = 0 for x = (0, 0, 0, 0, A c) and any c.
        let site = Site::from_degrees(55.7, 37.6, 0.0);
        let st = StaticTrajectory {
            site,
            heading: 0.7,
            duration_s: 10.0,
        };
        let p = st.point(0.0);
        let d = error_dynamics(&p, EARTH_RATE);
        let a = alignment_map(&site, &p.c_body_to_enu, EARTH_RATE).unwrap();
        for k in 0..INSTRUMENT_DIM {
            let mut c = SVector::<f64, 21>::zeros();
            c[k] = 1.0;
            let mut x = SVector::<f64, NAV_DIM>::zeros();
            x.fixed_rows_mut::<3>(BETA).copy_from(&(a * c));
            let xdot = d.f_nav * x + d.f_instr * c;
            let scale = (d.f_instr * c).norm().max(1e-30);
            assert!(
                xdot[DV].abs() < 1e-12 * scale && xdot[DV + 1].abs() < 1e-12 * scale,
                "{k}: {xdot}"
            );
            assert!(xdot[BETA].abs() < 1e-12 * scale, "{k}: {xdot}");
        }
    }

    #[test]
    fn error_dynamics_match_a_perturbed_nonlinear_navigation() {
        // F_nav's position/velocity rows against finite differences of the nonlinear
        // navigation equations (what the computer integrates) with perturbed position and
        // velocity, on a turning point of the snake; attitude errors enter through the computed
        // specific force f + f x beta.
        let tr = SnakeTrajectory::new(&SnakeConfig::default_config()).unwrap();
        let s = tr.segments()[1];
        let p = tr.point(s.t_start + 40.0);
        let w = EARTH_RATE;
        let f = p.specific_force_enu(w);
        let d = error_dynamics(&p, w);
        // Nonlinear rates of (lat, lon, V_E, V_N) and the ENU frame rate, at a computed state.
        // The radii of curvature are frozen at the true point: F neglects their (0.3 %)
        // variation with latitude, as is usual.
        let (rm, rn) = (p.radius_north(), p.radius_east());
        let rates = |x: &SVector<f64, NAV_DIM>| {
            let lat = p.latitude + x[DLAT];
            let v = Vector3::new(p.velocity_enu.x + x[DV], p.velocity_enu.y + x[DV + 1], 0.0);
            let beta = Vector3::new(x[BETA], x[BETA + 1], x[BETA + 2]);
            let fc = f + f.cross(&beta);
            let earth = Vector3::new(0.0, w * lat.cos(), w * lat.sin());
            let transport = Vector3::new(-v.y / rm, v.x / rn, v.x * lat.tan() / rn);
            // Gravity of the true point (the vertical channel and gravity errors are excluded).
            let vdot = fc + p.gravity_enu() - (2.0 * earth + transport).cross(&v);
            (
                SVector::<f64, 4>::new(v.y / rm, v.x / (rn * lat.cos()), vdot.x, vdot.y),
                earth + transport,
            )
        };
        let steps = [1e-7, 1e-7, 1e-3, 1e-3, 1e-5, 1e-5, 1e-5];
        // Size of each row's response to the probing steps, for an absolute rounding floor.
        let floor = |r: usize| {
            (0..NAV_DIM)
                .map(|j| (d.f_nav[(r, j)] * steps[j]).abs())
                .fold(0.0, f64::max)
        };
        for k in 0..NAV_DIM {
            let mut x = SVector::<f64, NAV_DIM>::zeros();
            x[k] = steps[k];
            let (rp, wp) = rates(&x);
            let (rm_, wm) = rates(&(-x));
            let fd = (rp - rm_) / (2.0 * steps[k]);
            let dw = (wp - wm) / (2.0 * steps[k]);
            for r in 0..4 {
                let want = d.f_nav[(r, k)];
                let tol = 1e-6 * want.abs() + 1e-9 * floor(r) / steps[k];
                assert!(
                    (fd[r] - want).abs() <= tol,
                    "row {r} col {k}: {} vs {want}",
                    fd[r]
                );
            }
            // Attitude rows: beta_dot = beta x omega + d_omega.
            if k < BETA {
                for r in 0..3 {
                    let want = d.f_nav[(BETA + r, k)];
                    let tol = 1e-6 * want.abs() + 1e-9 * floor(BETA + r) / steps[k];
                    assert!(
                        (dw[r] - want).abs() <= tol,
                        "att row {r} col {k}: {} vs {want}",
                        dw[r]
                    );
                }
            }
        }
        let omega = p.earth_rate_enu(w) + p.transport_rate_enu();
        assert_eq!(
            d.f_nav.fixed_view::<3, 3>(BETA, BETA).into_owned(),
            -skew(&omega)
        );
    }
}
