//! The navigation errors along a trajectory as a linear response to the instrument errors:
//! propagated once, evaluated for any covariance of the instrument parameters.
//!
//! The instrument parameters `c` are constant, the initial navigation errors are `M c` (the
//! alignment, [`crate::model::model_alignment_map`]; with the take-off option also the velocity
//! error it leaves) plus an explicit attitude error `w` uncorrelated with `c`, and the sensors'
//! white noise enters linearly. So at every time
//!
//! ```text
//! x_nav(t) = S(t) c + Phi(t, 0) w + n(t),    S(t) = Phi(t, 0) M + S_f(t)
//! P_nav(t) = S P S^T + Phi P_w Phi^T + N(t)
//! ```
//!
//! with `Phi(t, 0)` the transition of the navigation errors, `S_f` the response to the
//! instrument errors acting in flight, and `N` the covariance the noise leaves. Over a step
//! `[Phi, Phi_c; 0, I]` (see [`mod@crate::propagate`]): `S_f' = Phi S_f + Phi_c`,
//! `Phi(t1, 0) = Phi Phi(t0, 0)`, `N' = Phi N Phi^T + Q_d`. This is the propagation of
//! `[P_nn, P_nc]` written per unit instrument error: in exact arithmetic the same covariance
//! (`P_nc = S P`), but one pass serves every covariance of `c` (a calibration's posterior and
//! its priors, each group of an error budget, every program a design compares).

use nalgebra::{Matrix2, Matrix3, SMatrix, Vector3};
use sins_model::earth::{Site, WGS84_A};
use sins_model::terms::SensorInput;

use crate::NavError;
use crate::instruments::InstrumentModel;
use crate::model::{
    BETA, DLAT, DLON, DV, JacobianWork, NAV_DIM, NavMatrix, NavModelMatrix, model_alignment_map,
    nav_dynamics,
};
use crate::propagate::{InitialAttitude, NavOptions, NavSnapshot, RhoSeries};
use crate::trajectory::{Trajectory, TrajectoryPoint};

/// Which part of the navigation covariance to evaluate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Everything: `S P S^T + Phi P_w Phi^T + N`.
    All,
    /// The instrument errors alone (through the alignment and in flight), no explicit initial
    /// attitude and no noise: `S P S^T`.
    Instruments,
    /// The initial (alignment) errors alone, the instrument errors switched off in flight:
    /// `(Phi M) P (Phi M)^T + Phi P_w Phi^T`.
    Alignment,
    /// The sensors' white noise alone: `N`.
    Noise,
}

/// The response at one recorded time.
#[derive(Clone, Debug, PartialEq)]
pub struct ResponsePoint {
    /// Time \[s\].
    pub t: f64,
    /// True latitude \[rad\].
    pub latitude: f64,
    /// `Phi(t, 0)`: the navigation errors at `t` per unit initial navigation error.
    pub transition: NavMatrix,
    /// `S(t)`: the navigation errors at `t` per unit instrument parameter (7 x n).
    pub response: NavModelMatrix,
    /// `N(t)`: the covariance the sensors' white noise leaves (zero at the start).
    pub noise: NavMatrix,
}

/// The navigation errors along a trajectory per unit instrument error (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct NavResponse {
    names: Vec<String>,
    initial: NavModelMatrix,
    p_w: NavMatrix,
    points: Vec<ResponsePoint>,
}

/// The running state of the propagation.
struct Running {
    transition: NavMatrix,
    flight: NavModelMatrix,
    noise: NavMatrix,
}

impl NavResponse {
    /// Propagate along `traj` for the instruments of `model` with `opts`; the response is
    /// recorded at the start, on the grid `k dt` and at the end.
    pub fn new<T: Trajectory + ?Sized>(
        traj: &T,
        model: &InstrumentModel,
        opts: &NavOptions,
    ) -> Result<Self, NavError> {
        opts.check()?;
        let (initial, p_w) = initial_maps(traj, model, opts)?;
        let n = model.len();
        let q = noise_psd(opts);
        let em = model.error_model();
        let derivatives = em.uses_rate_derivatives();
        let steps = step_times(traj, opts.dt_s);
        let mut points = Vec::with_capacity(steps.len() + 1);
        let mut run = Running {
            transition: NavMatrix::identity(),
            flight: NavModelMatrix::zeros(n),
            noise: NavMatrix::zeros(),
        };
        let mut work = StepWork {
            jacobian: JacobianWork::new(n),
            f_instr: NavModelMatrix::zeros(n),
        };
        let mut p0 = traj.point(0.0);
        points.push(run.point(0.0, p0.latitude, &initial));
        let mut t0 = 0.0;
        for (t1, record) in steps {
            let p1 = traj.point(t1);
            let h = t1 - t0;
            let mid = traj.point(0.5 * (t0 + t1));
            let input = sensor_input(&mid, (&p0, &p1, h), opts, derivatives);
            let f_nav = nav_dynamics(&mid, opts.earth_rate_rad_s);
            work.jacobian
                .instrument_dynamics(em, &mid.c_body_to_enu, &input, &mut work.f_instr);
            let (phi, s) = taylor(&f_nav, h, opts.taylor_order);
            run.step(&phi, &s, &q, h, &mut work);
            if record {
                points.push(run.point(t1, p1.latitude, &initial));
            }
            t0 = t1;
            p0 = p1;
        }
        Ok(Self {
            names: model.names().to_vec(),
            initial,
            p_w,
            points,
        })
    }

    /// The instrument parameters' names (the columns of the response).
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The recorded points, the start first.
    pub fn points(&self) -> &[ResponsePoint] {
        &self.points
    }

    /// `M`: the initial navigation errors per unit instrument parameter (7 x n).
    pub fn initial_map(&self) -> &NavModelMatrix {
        &self.initial
    }

    /// The navigation covariance at recorded point `k` for the instrument covariance `p`
    /// (n x n, in [`Self::names`] order), the part `part` of it.
    pub fn covariance(&self, k: usize, p: &nalgebra::DMatrix<f64>, part: Part) -> NavMatrix {
        let pt = &self.points[k];
        let through = |s: &NavModelMatrix| s * p * s.transpose();
        let explicit = || pt.transition * self.p_w * pt.transition.transpose();
        match part {
            Part::All => through(&pt.response) + explicit() + pt.noise,
            Part::Instruments => through(&pt.response),
            Part::Alignment => through(&(pt.transition * &self.initial)) + explicit(),
            Part::Noise => pt.noise,
        }
    }

    /// rho \[m\] at recorded point `k` for the instrument covariance `p`, the part `part` of
    /// it (the position rows only: cheaper than [`Self::covariance`]).
    pub fn rho_m(&self, k: usize, p: &nalgebra::DMatrix<f64>, part: Part) -> f64 {
        let pt = &self.points[k];
        let var = |row: usize| {
            let explicit = || {
                let r = pt.transition.row(row);
                (r * self.p_w).dot(&r)
            };
            match part {
                Part::All => quadratic(&pt.response, row, p) + explicit() + pt.noise[(row, row)],
                Part::Instruments => quadratic(&pt.response, row, p),
                Part::Alignment => {
                    let s = pt.transition.row(row) * &self.initial;
                    (&s * p).dot(&s) + explicit()
                }
                Part::Noise => pt.noise[(row, row)],
            }
        };
        let c = pt.latitude.cos();
        WGS84_A * (var(DLAT) + c * c * var(DLON)).max(0.0).sqrt()
    }

    /// rho over time for the instrument covariance `p`, the part `part` of it.
    pub fn rho_series(&self, p: &nalgebra::DMatrix<f64>, part: Part) -> RhoSeries {
        RhoSeries {
            t: self.points.iter().map(|x| x.t).collect(),
            rho_m: (0..self.points.len())
                .map(|k| self.rho_m(k, p, part))
                .collect(),
        }
    }

    /// The navigation covariance at every recorded point for the instrument covariance `p`.
    pub fn snapshots(&self, p: &nalgebra::DMatrix<f64>) -> Vec<NavSnapshot> {
        (0..self.points.len())
            .map(|k| NavSnapshot {
                t: self.points[k].t,
                latitude: self.points[k].latitude,
                p_nav: self.covariance(k, p, Part::All),
            })
            .collect()
    }
}

/// Scratch space of a step.
struct StepWork {
    jacobian: JacobianWork,
    f_instr: NavModelMatrix,
}

impl Running {
    /// One step with transition `phi`, `s = sum_k F^(k-1) h^k / k!` (so that
    /// `Phi_c = s F_instr`, `F_instr` in `work`) and noise PSD `q` over `h`.
    fn step(&mut self, phi: &NavMatrix, s: &NavMatrix, q: &NavMatrix, h: f64, work: &mut StepWork) {
        // S_f' = Phi S_f + s F_instr, column by column (7x7 products: no dynamic-size
        // kernel, which costs more than the arithmetic at this size).
        for k in 0..self.flight.ncols() {
            let col = phi * self.flight.fixed_view::<NAV_DIM, 1>(0, k)
                + s * work.f_instr.fixed_view::<NAV_DIM, 1>(0, k);
            self.flight
                .fixed_view_mut::<NAV_DIM, 1>(0, k)
                .copy_from(&col);
        }
        self.transition = phi * self.transition;
        let nn = phi * self.noise * phi.transpose() + (phi * q * phi.transpose() + q) * (0.5 * h);
        self.noise = 0.5 * (nn + nn.transpose());
    }

    /// The recorded point at `t`.
    fn point(&self, t: f64, latitude: f64, initial: &NavModelMatrix) -> ResponsePoint {
        let mut response = self.flight.clone();
        for k in 0..response.ncols() {
            let col = self.transition * initial.fixed_view::<NAV_DIM, 1>(0, k);
            let mut r = response.fixed_view_mut::<NAV_DIM, 1>(0, k);
            r += col;
        }
        ResponsePoint {
            t,
            latitude,
            transition: self.transition,
            response,
            noise: self.noise,
        }
    }
}

/// `s P s^T` for the row `row` of `m` (no allocation: the hot path of every figure).
fn quadratic(m: &NavModelMatrix, row: usize, p: &nalgebra::DMatrix<f64>) -> f64 {
    let n = m.ncols();
    let mut sum = 0.0;
    for j in 0..n {
        let sj = m[(row, j)];
        if sj == 0.0 {
            continue;
        }
        let col = p.column(j);
        let mut acc = 0.0;
        for i in 0..n {
            acc += m[(row, i)] * col[i];
        }
        sum += acc * sj;
    }
    sum
}

/// `Phi = exp(F h)` and `sum_k F^(k-1) h^k / k!` by Taylor series of order `order`.
fn taylor(f_nav: &NavMatrix, h: f64, order: usize) -> (NavMatrix, NavMatrix) {
    let x = f_nav * h;
    let mut phi = NavMatrix::identity();
    let mut term = NavMatrix::identity();
    let mut s_term = NavMatrix::identity() * h;
    let mut s = s_term;
    for j in 1..=order {
        term = term * x / j as f64;
        phi += term;
        if j < order {
            s_term = s_term * x / (j + 1) as f64;
            s += s_term;
        }
    }
    (phi, s)
}

/// The white-noise PSD matrix `diag(0, 0, q_a, q_a, q_g, q_g, q_g)`.
fn noise_psd(opts: &NavOptions) -> NavMatrix {
    let mut q = NavMatrix::zeros();
    q.fixed_view_mut::<2, 2>(DV, DV)
        .copy_from(&(Matrix2::identity() * opts.accel_noise_density.powi(2)));
    q.fixed_view_mut::<3, 3>(BETA, BETA)
        .copy_from(&(Matrix3::identity() * opts.gyro_noise_density.powi(2)));
    q
}

/// What the sensors are exposed to over a step, at its middle `mid`: the body rate and
/// specific force there, their mean rates of change over the step from its ends `(a, b, h)`
/// when a term uses them, and the temperature's departure from the reference.
fn sensor_input(
    mid: &TrajectoryPoint,
    (a, b, h): (&TrajectoryPoint, &TrajectoryPoint, f64),
    opts: &NavOptions,
    derivatives: bool,
) -> SensorInput {
    let w = opts.earth_rate_rad_s;
    let rate = |x: Vector3<f64>, y: Vector3<f64>| {
        if derivatives && h > 0.0 {
            (y - x) / h
        } else {
            Vector3::zeros()
        }
    };
    SensorInput {
        omega_body: mid.body_rate(w),
        f_body: mid.specific_force_body(w),
        omega_dot_body: rate(a.body_rate(w), b.body_rate(w)),
        f_dot_body: rate(a.specific_force_body(w), b.specific_force_body(w)),
        temp_delta: opts.temperature_delta_k,
    }
}

/// `M` (7 x n) and `N P_w N^T` (7x7) for the options: the alignment map into the attitude
/// rows and, with the take-off option, `V0 x beta0` into the velocity rows.
pub(crate) fn initial_maps<T: Trajectory + ?Sized>(
    traj: &T,
    model: &InstrumentModel,
    opts: &NavOptions,
) -> Result<(NavModelMatrix, NavMatrix), NavError> {
    let p0 = traj.point(0.0);
    // Take-off: dV_E = V_N beta_U, dV_N = -V_E beta_U.
    let mut n = SMatrix::<f64, NAV_DIM, 3>::zeros();
    n.fixed_view_mut::<3, 3>(BETA, 0)
        .copy_from(&Matrix3::identity());
    if opts.takeoff_velocity_error {
        n[(DV, 2)] = p0.velocity_enu.y;
        n[(DV + 1, 2)] = -p0.velocity_enu.x;
    }
    let gyrocompass = match &opts.initial_attitude {
        InitialAttitude::Aligned => true,
        InitialAttitude::Levelled => false,
        InitialAttitude::Explicit(p) => {
            return Ok((NavModelMatrix::zeros(model.len()), n * p * n.transpose()));
        }
    };
    // Alignment on the ground (h = 0) at the start point, level, at the start heading.
    let site = Site {
        latitude: p0.latitude,
        longitude: p0.longitude,
        height: 0.0,
    };
    let level = crate::trajectory::c_body_to_enu(p0.heading, 0.0);
    let a = model_alignment_map(
        model.error_model(),
        &site,
        &level,
        opts.earth_rate_rad_s,
        opts.temperature_delta_k,
        gyrocompass,
    )?;
    Ok((n * a, NavMatrix::zeros()))
}

/// The step end times: the regular grid `k dt` (recorded) merged with the trajectory's
/// breakpoints (not recorded), ending exactly at the duration.
fn step_times<T: Trajectory + ?Sized>(traj: &T, dt: f64) -> Vec<(f64, bool)> {
    let duration = traj.duration_s();
    let n = (duration / dt - 1e-9).ceil().max(1.0) as usize;
    let mut grid: Vec<(f64, bool)> = (1..=n)
        .map(|k| (if k == n { duration } else { k as f64 * dt }, true))
        .collect();
    // Breakpoints closer than this to a grid time are merged into it.
    let eps = 1e-9 * dt.max(1.0);
    for b in traj.breakpoints() {
        if b > eps && b < duration - eps && grid.iter().all(|&(t, _)| (t - b).abs() > eps) {
            grid.push((b, false));
        }
    }
    grid.sort_by(|a, b| a.0.total_cmp(&b.0));
    grid
}
