//! The filter's form of the inverse: the sensor models of an error model at the filter's
//! parameters inverted on increments at every IMU step ([`Compensation`]).

use super::*;
/// The filter's form of the inverse ([`crate::estimate`]'s pass, at every IMU step): the sensor
/// models of an [`ErrorModel`] at parameters `p` (the terms' own effects) inverted on
/// increments: the true increments solve
/// `dth' = dth - nu(p; w, f) dt` and `dv' = dv + df(p; w, f) dt`, with the errors evaluated at the
/// true rate and specific force. Three fixed-point passes: the first alone (errors evaluated at
/// the measured values) would leave `Theta^2 w`, a 3e-6 relative scale error for a 1e-3 `Theta`,
/// which is twenty times the scale-factor sigma the paper's program reaches.
///
/// When every term is affine in the input (the paper's model) the errors are evaluated through
/// matrices computed once per change of the parameters, not term by term at every step.
///
/// Terms that use the rate derivatives (size effect, time offset) are compensated after the
/// fixed point of the others, from the differences of this step's and the previous step's
/// increments so compensated: `integral of dw/dt over the step = w_k - w_{k-1}` (mean rates of
/// the steps), which telescopes over steps as the simulator's `w(b) - w(a)` does, jumps
/// included. Taking the differences inside the fixed point instead would need it converged: the
/// first iterate carries the whole bias, and three passes left `(d / dt)^3` of it in the
/// time-offset part (a 1.2-sigma accelerometer bias error at 100 Hz with a 1-ms offset).
#[derive(Clone, Debug)]
pub struct Compensation {
    /// The affine forms of the gyro and accelerometer errors at the current parameters.
    affine: Option<(AffineError, AffineError)>,
    /// With affine errors and no rate-derivative terms, the three fixed-point passes in closed
    /// form: `x_3 = n raw + m_offset dt` for `x = (dth, dv)` (see [`Compensation::new`]).
    pub(super) closed: Option<ClosedForm>,
    /// With errors affine in each orthant of the rate (a scale asymmetry) and no
    /// rate-derivative terms: the closed form of each orthant, indexed by the signs of the
    /// rate's components ([`orthant_index`]).
    pub(super) orthants: Option<Box<[ClosedForm; 8]>>,
    /// Whether any term uses the rate derivatives.
    derivatives: bool,
}

/// The compensation's fixed point in closed form: `x = n raw + m_offset dt` ([`closed_form`]).
type ClosedForm = (Matrix6<f64>, Vector6<f64>);

/// Largest entry of the fixed point's matrix (the errors' derivatives by rate and force) below
/// which three passes stand for the fixed point (their error is the fourth power of it).
const LARGE_ERRORS: f64 = 1e-2;

/// A step's increments compensated for every term but those that use the rate derivatives, as
/// mean rate and specific force: what the next step's derivatives are differences to.
#[derive(Clone, Copy, Debug)]
pub struct CompensatedMeans {
    /// Mean rate over the step (rad/s).
    pub omega_body: Vector3<f64>,
    /// Mean specific force over the step (m/s^2).
    pub f_body: Vector3<f64>,
}

impl Compensation {
    /// The compensation for parameters `p` of `model`.
    pub fn new(model: &ErrorModel, p: &[f64]) -> Self {
        let affine = model
            .affine(Sensor::Gyro, p)
            .zip(model.affine(Sensor::Accel, p));
        let derivatives = model.uses_rate_derivatives_at(p);
        // One fixed-point pass is `x' = raw + o dt + B x` with `x = (dth, dv)`,
        // `B = [G_w G_f; -A_w -A_f]` and `o = (g_0, -a_0)` (the inputs are `x / dt`). From
        // `x_0 = raw`, three passes give `x_3 = (I + B + B^2 + B^3) raw + (I + B + B^2) o dt`:
        // one 6x6 product per step instead of six affine evaluations, equal to rounding.
        let closed = affine
            .filter(|_| !derivatives)
            .map(|(g, a)| closed_form(&g, &a));
        // Without them the general path evaluates every term three times per step (the
        // consumer-grade model of `calibrate --free-motion`: half its CPU) and stops at three
        // fixed-point passes, short of the fixed point for per-cent errors.
        let orthants = match (&affine, derivatives, model.affine(Sensor::Accel, p)) {
            (None, false, Some(a)) => {
                let forms: Option<Vec<ClosedForm>> = (0..8)
                    .map(|k| {
                        model
                            .affine_in_orthant(Sensor::Gyro, p, &orthant_signs(k))
                            .map(|g| closed_form(&g, &a))
                    })
                    .collect();
                forms.and_then(|v| <[_; 8]>::try_from(v).ok()).map(Box::new)
            }
            _ => None,
        };
        Self {
            affine,
            closed,
            orthants,
            derivatives,
        }
    }

    /// The true increments of the raw increments `raw_dth`, `raw_dv` over `dt`. `prev` holds the
    /// previous step's [`CompensatedMeans`] (`None` at the first step: no derivative terms) and
    /// is replaced by this step's.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn apply(
        &self,
        model: &ErrorModel,
        p: &[f64],
        raw_dth: &Vector3<f64>,
        raw_dv: &Vector3<f64>,
        dt: f64,
        temp_delta: f64,
        prev: &mut Option<CompensatedMeans>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        if let Some(forms) = &self.orthants {
            let raw = Vector6::new(
                raw_dth.x, raw_dth.y, raw_dth.z, raw_dv.x, raw_dv.y, raw_dv.z,
            );
            // The orthant of the raw rate, then of the compensated one if that differs (a rate
            // component smaller than its own error): the fixed point lies in the orthant whose
            // form gives a rate in it.
            let mut k = orthant_index(raw_dth);
            let mut x = forms[k].0 * raw + forms[k].1 * dt;
            let k2 = orthant_index(&x.fixed_rows::<3>(0).into());
            if k2 != k {
                k = k2;
                x = forms[k].0 * raw + forms[k].1 * dt;
            }
            return (x.fixed_rows::<3>(0).into(), x.fixed_rows::<3>(3).into());
        }
        if let Some((n, m_offset)) = &self.closed {
            let raw = Vector6::new(
                raw_dth.x, raw_dth.y, raw_dth.z, raw_dv.x, raw_dv.y, raw_dv.z,
            );
            let x = n * raw + m_offset * dt;
            return (x.fixed_rows::<3>(0).into(), x.fixed_rows::<3>(3).into());
        }
        let (mut dth, mut dv) = (*raw_dth, *raw_dv);
        let (mut raw_dth, mut raw_dv) = (*raw_dth, *raw_dv);
        let iterate = |raw_dth: &Vector3<f64>,
                       raw_dv: &Vector3<f64>,
                       dth: &mut Vector3<f64>,
                       dv: &mut Vector3<f64>,
                       n: usize| {
            for _ in 0..n {
                let input = SensorInput {
                    omega_body: *dth / dt,
                    f_body: *dv / dt,
                    temp_delta,
                    ..SensorInput::default()
                };
                let (nu, df) = match &self.affine {
                    Some((g, a)) => (g.at(&input), a.at(&input)),
                    None => (
                        model.error(Sensor::Gyro, p, &input),
                        model.error(Sensor::Accel, p, &input),
                    ),
                };
                *dth = raw_dth + nu * dt;
                *dv = raw_dv - df * dt;
            }
        };
        iterate(&raw_dth, &raw_dv, &mut dth, &mut dv, 3);
        if !self.derivatives {
            return (dth, dv);
        }
        let now = CompensatedMeans {
            omega_body: dth / dt,
            f_body: dv / dt,
        };
        if let Some(q) = prev.replace(now) {
            let d_omega = now.omega_body - q.omega_body;
            let d_f = now.f_body - q.f_body;
            // The derivative part is held fixed and the other terms evaluated again at the
            // increments without it: the paper's matrices act on the true force, and a size
            // effect's spike at a rate jump (5e-3 m/s in one step for 0.03 m at 10 deg/s) is
            // no part of it.
            raw_dth += model.derivative_error_integral(Sensor::Gyro, p, &d_omega, &d_f);
            raw_dv -= model.derivative_error_integral(Sensor::Accel, p, &d_omega, &d_f);
            iterate(&raw_dth, &raw_dv, &mut dth, &mut dv, 2);
        }
        (dth, dv)
    }
}

/// The signs of the rate's components of orthant `k` (bit `i` set: component `i` negative).
fn orthant_signs(k: usize) -> Vector3<f64> {
    Vector3::from_fn(|i, _| if k >> i & 1 == 1 { -1.0 } else { 1.0 })
}

/// The orthant of the rate `w` ([`orthant_signs`]); a zero component counts as positive.
#[inline(always)]
fn orthant_index(w: &Vector3<f64>) -> usize {
    usize::from(w.x < 0.0) | usize::from(w.y < 0.0) << 1 | usize::from(w.z < 0.0) << 2
}

/// The fixed point of the compensation in closed form for affine gyro and accelerometer errors
/// `g` and `a`: `x = n raw + m_offset dt` ([`Compensation::new`]).
fn closed_form(g: &AffineError, a: &AffineError) -> ClosedForm {
    let mut b = Matrix6::zeros();
    b.fixed_view_mut::<3, 3>(0, 0).copy_from(&g.d_omega);
    b.fixed_view_mut::<3, 3>(0, 3).copy_from(&g.d_f);
    b.fixed_view_mut::<3, 3>(3, 0).copy_from(&-a.d_omega);
    b.fixed_view_mut::<3, 3>(3, 3).copy_from(&-a.d_f);
    let mut o = Vector6::zeros();
    o.fixed_rows_mut::<3>(0).copy_from(&g.offset);
    o.fixed_rows_mut::<3>(3).copy_from(&-a.offset);
    // The fixed point itself, x = (I - B)^-1 (raw + o dt), where the errors are large:
    // three passes leave B^4, 1e-4 of the increments for per-cent scale factors (a 90-degree
    // turn 1e-4 rad off, a pose's |f| 6e-5 m/s^2 off, as large as its noise), which put
    // consumer-grade accelerometer scale factors 10 sigma off. For the paper's errors
    // (B about 1e-3, B^4 about 1e-12) the three passes stay, to keep the estimates of
    // programmed runs as they were.
    let large = b.amax() > LARGE_ERRORS;
    match (large, (Matrix6::identity() - b).try_inverse()) {
        (true, Some(inv)) => (inv, inv * o),
        _ => {
            let b2 = b * b;
            let m = Matrix6::identity() + b + b2;
            (m + b2 * b, m * o)
        }
    }
}
