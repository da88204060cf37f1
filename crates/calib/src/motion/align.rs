//! Coarse alignment of the start attitude from the rotation program (IMU-only calibration).
//!
//! Without the turntable's angle sensors the filter learns the start attitude only from the
//! accelerometers (tilt) and, slowly and confounded with the East gyro bias, from the Earth rate
//! (heading: about 0.35 deg after the paper's program). The installation misalignment, degrees,
//! sits in that start attitude; a linear error model with a degree-level attitude error leaves
//! second-order terms, and a heading known only to its prior leaves prior-driven errors in the
//! gyro biases (both measured: errors of several sigma on noiseless data).
//!
//! The program says more: the platform turns about known axes. The mean body rates the gyros
//! measure while the platform turns are the platform's rates rotated by the unknown mounting, so
//! the mounting follows from a fit of the two sets of directions (Wahba's problem, solved by
//! SVD). Its error comes from the gyro errors, `Theta` first (the fit sees `(I - Theta) w`), and
//! from the gyro noise; both are modelled: [`Alignment::jacobian`] is the derivative of the
//! start attitude error with respect to the instrument parameters (by finite differences of the
//! fit), so the filter's prior of the start attitude error is `beta_0 = B p + eps`, correlated
//! with the parameters, with `eps` the fit's noise. The fit needs rotations about two axes at
//! least (the paper's program turns about three); otherwise there is no alignment and the
//! start attitude keeps the installation prior.

use crate::model::engine::RateChanges;
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::attitude::log_so3;
use sins_model::earth::Site;
use sins_model::terms::{ErrorModel, Sensor, SensorInput};
use turntable::gimbal::c_platform_to_base;
use turntable::kinematics::{Kinematics, Mounting};
use turntable::program::Program;

/// Mean measured body rate and specific force over a short bin of IMU records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateBin {
    /// Start and end of the bin on the IMU clock (s).
    pub t0: f64,
    /// End of the bin (s).
    pub t1: f64,
    /// Mean measured angular rate (rad/s, body axes).
    pub rate: Vector3<f64>,
    /// Mean measured specific force (m/s^2, body axes).
    pub f: Vector3<f64>,
}

/// Accumulates IMU records into [`RateBin`]s of a fixed length.
#[derive(Clone, Debug)]
pub struct RateBinner {
    bin_s: f64,
    bins: Vec<RateBin>,
    open: Option<(f64, f64, Vector3<f64>, Vector3<f64>)>,
}

impl RateBinner {
    /// Bins of `bin_s` seconds.
    pub fn new(bin_s: f64) -> Self {
        Self {
            bin_s,
            bins: Vec::new(),
            open: None,
        }
    }

    /// Add the record whose interval is `(t - dt, t]` with angle and velocity increments
    /// `dth` (rad) and `dv` (m/s).
    pub fn push(&mut self, t: f64, dt: f64, dth: &Vector3<f64>, dv: &Vector3<f64>) {
        let (t0, _, sum_dth, sum_dv) =
            self.open
                .get_or_insert((t - dt, t, Vector3::zeros(), Vector3::zeros()));
        let t0 = *t0;
        *sum_dth += dth;
        *sum_dv += dv;
        let (sum_dth, sum_dv) = (*sum_dth, *sum_dv);
        self.open = Some((t0, t, sum_dth, sum_dv));
        if t - t0 >= self.bin_s * (1.0 - 1e-9) {
            self.close();
        }
    }

    fn close(&mut self) {
        if let Some((t0, t1, dth, dv)) = self.open.take() {
            let span = t1 - t0;
            self.bins.push(RateBin {
                t0,
                t1,
                rate: dth / span,
                f: dv / span,
            });
        }
    }

    /// The bins (a last, shorter one included).
    pub fn finish(mut self) -> Vec<RateBin> {
        self.close();
        self.bins
    }
}

/// The start attitude from the program's rotations.
#[derive(Clone, Debug)]
pub struct Alignment {
    /// Estimated mounting: body to platform.
    pub c_body_to_platform: Matrix3<f64>,
    /// Start attitude (body to ENU) at the start of the first IMU record.
    pub c_start: Matrix3<f64>,
    /// Derivative of the start attitude error `beta_0` (rad, ENU; `C_true = exp(beta_0) C_start`)
    /// with respect to the instrument parameters (3 x parameters).
    pub jacobian: DMatrix<f64>,
    /// Standard deviation of the fit's noise about each ENU axis (rad).
    pub sigma_noise: f64,
    /// Bins used.
    pub bins_used: usize,
}

/// Smallest ratio of the smallest to the largest eigenvalue of the rotation information
/// `sum (|r|^2 I - r r^T)` for a fit: below it the rotations do not span two axes.
const MIN_AXIS_SPREAD: f64 = 1e-3;

/// Rates below this (rad/s, about 0.6 deg/s) carry no direction worth fitting.
const MIN_RATE: f64 = 0.01;

/// Align the start attitude to `program`, which starts at IMU time `program_start`, from the
/// rate bins of the data: bin `i` of `n_bins` made on demand by `bin` (the same bin each time),
/// in memory independent of `n_bins`: the usable bins are kept as runs of indices, and made
/// again for the second sum. `t_start` is the start of the first record. `None` when the program
/// does not turn about two axes within the data.
#[allow(clippy::too_many_arguments)]
pub fn align_to_program_by(
    n_bins: usize,
    bin: &dyn Fn(usize) -> RateBin,
    program: &Program,
    site: &Site,
    program_start: f64,
    t_start: f64,
    model: &ErrorModel,
    gyro_psd: f64,
) -> Option<Alignment> {
    let bins = ProgramBins {
        bin,
        kin: Kinematics::new(program.clone(), Mounting::default(), *site),
        changes: RateChanges::new(program),
        program_start,
    };
    let sums = bins.sums(n_bins);
    let eig = sums.info.symmetric_eigenvalues();
    let mut sorted = [eig[0], eig[1], eig[2]];
    sorted.sort_by(f64::total_cmp);
    // Rotations about one axis only leave the rotation about that axis unknown.
    let spread_enough = sorted[2] > 0.0 && sorted[0] / sorted[2] >= MIN_AXIS_SPREAD;
    if sums.used == 0 || !spread_enough {
        return None;
    }
    let r_platform_to_body = wahba(&sums.b_sum)?;
    let c_body_to_platform = r_platform_to_body.transpose();
    let (k0, _) = program.state(t_start - program_start);
    let c_p0 = c_platform_to_base(&k0);
    let c_start = c_p0 * c_body_to_platform;
    let jacobian = bins.start_jacobian(&sums, model, &c_p0, &c_start);
    // Noise: white rate noise of PSD q on a bin of length w has variance q / w; the fit's
    // attitude covariance is then q info^-1 (platform axes); take its largest value, with a
    // floor of 1e-6 rad for what the model leaves out.
    let sigma_noise = (gyro_psd / sorted[0].max(1e-300)).sqrt().max(1e-6);
    Some(Alignment {
        c_body_to_platform,
        c_start,
        jacobian,
        sigma_noise,
        bins_used: sums.used,
    })
}

/// The rate bins of [`align_to_program_by`] against the program's platform rates.
struct ProgramBins<'b> {
    /// Bin `i`, made on demand.
    bin: &'b dyn Fn(usize) -> RateBin,
    kin: Kinematics,
    changes: RateChanges,
    program_start: f64,
}

/// What one reading of the bins gives the fit.
struct BinSums {
    /// The usable bins as runs `[first, end)` of indices (a program's turns come in pieces).
    runs: Vec<(usize, usize)>,
    /// Usable bins.
    used: usize,
    /// The rotation information `sum (|r|^2 I - r r^T) w`.
    info: Matrix3<f64>,
    /// Wahba's `B = sum rate r^T w`.
    b_sum: Matrix3<f64>,
}

impl ProgramBins<'_> {
    /// The platform-frame reference rate of a usable bin: one clear of the program's rate
    /// changes whose reference rate is above [`MIN_RATE`].
    fn usable(&self, b: &RateBin) -> Option<Vector3<f64>> {
        let start = self.program_start;
        if !self.changes.clear(b.t0 - start, b.t1 - start) {
            return None;
        }
        let mid = 0.5 * (b.t0 + b.t1) - start;
        let r = self.kin.sample(mid).omega_body;
        (r.norm() > MIN_RATE).then_some(r)
    }

    /// The sums over the usable bins of the `n_bins`, and where they are.
    fn sums(&self, n_bins: usize) -> BinSums {
        let mut sums = BinSums {
            runs: Vec::new(),
            used: 0,
            info: Matrix3::zeros(),
            b_sum: Matrix3::zeros(),
        };
        for i in 0..n_bins {
            let bin = (self.bin)(i);
            let Some(r) = self.usable(&bin) else { continue };
            match sums.runs.last_mut() {
                Some(run) if run.1 == i => run.1 = i + 1,
                _ => sums.runs.push((i, i + 1)),
            }
            sums.used += 1;
            let w = bin.t1 - bin.t0;
            sums.info += (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * w;
            sums.b_sum += bin.rate * r.transpose() * w;
        }
        sums
    }

    /// `d beta_0 / d p` (3 x parameters of `model`) by central differences of the fit: a
    /// parameter `p_i` changes the measured rates by `-d nu / d p_i`, hence the fit's `B` by
    /// `-sum (d nu / d p_i) r^T w` over the usable bins (made again).
    fn start_jacobian(
        &self,
        sums: &BinSums,
        model: &ErrorModel,
        c_p0: &Matrix3<f64>,
        c_start: &Matrix3<f64>,
    ) -> DMatrix<f64> {
        let n = model.n_params();
        let mut d_b = vec![Matrix3::zeros(); n];
        let mut jac = vec![Vector3::zeros(); n];
        for i in sums.runs.iter().flat_map(|&(a, b)| a..b) {
            let bin = (self.bin)(i);
            let r = self.usable(&bin).expect("a usable bin");
            let w = bin.t1 - bin.t0;
            let input = SensorInput {
                omega_body: bin.rate,
                f_body: bin.f,
                ..SensorInput::default()
            };
            model.jacobian(Sensor::Gyro, &vec![0.0; n], &input, &mut jac);
            for (d, j) in d_b.iter_mut().zip(&jac) {
                *d -= j * r.transpose() * w;
            }
        }
        let mut jacobian = DMatrix::zeros(3, n);
        let scale = sums.b_sum.norm();
        for (i, d) in d_b.iter().enumerate() {
            if d.norm() == 0.0 {
                continue;
            }
            let h = 1e-6 * scale / d.norm();
            let attitude = |s: f64| wahba(&(sums.b_sum + d * s)).map(|r| c_p0 * r.transpose());
            let (Some(plus), Some(minus)) = (attitude(h), attitude(-h)) else {
                continue;
            };
            // beta_0(p) = log(C_true C_start(p)^T), C_true the fit without the error.
            let col = (log_so3(&(c_start * plus.transpose()))
                - log_so3(&(c_start * minus.transpose())))
                / (2.0 * h);
            jacobian.set_column(i, &col);
        }
        jacobian
    }
}

/// How well the two kinds of direction are known before calibration: the scale of the errors
/// that turn a measured direction away from the true one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionErrors {
    /// Gyro bias (rad/s).
    pub gyro_bias: f64,
    /// Gyro scale and misalignment (dimensionless, rad).
    pub gyro_matrix: f64,
    /// Accelerometer bias (m/s^2).
    pub accel_bias: f64,
    /// Accelerometer scale and non-orthogonality (dimensionless, rad).
    pub accel_matrix: f64,
    /// Prior of the mounting about each axis (rad): the nominal mounting enters the fit as a
    /// pseudo-measurement with this weight, so that a direction the data do not fix stays
    /// at the nominal one.
    pub mounting: f64,
}

/// The mounting (body to platform) that best turns the platform-frame directions of the
/// program into the measured body-frame ones: the measured mean rates and specific forces of
/// every bin that does not straddle a change of the platform rate, each weighted by how well its
/// direction is known ([`DirectionErrors`]), and the nominal mounting as a pseudo-measurement.
/// Levelling from the specific force where the platform rests, and the full mounting from the
/// rotation axes where it turns. Used as the point the calibration linearises about, not as
/// information.
pub fn fit_mounting(
    bins: &[RateBin],
    program: &Program,
    site: &Site,
    program_start: f64,
    errors: &DirectionErrors,
) -> Option<Matrix3<f64>> {
    let kin = Kinematics::new(program.clone(), Mounting::default(), *site);
    let changes = RateChanges::new(program);
    let usable: Vec<&RateBin> = bins
        .iter()
        .filter(|b| changes.clear(b.t0 - program_start, b.t1 - program_start))
        .collect();
    let total: f64 = usable.iter().map(|b| b.t1 - b.t0).sum();
    let mut b = Matrix3::identity() / errors.mounting.powi(2);
    for bin in usable {
        let s = kin.sample(0.5 * (bin.t0 + bin.t1) - program_start);
        let w = (bin.t1 - bin.t0) / total;
        // A direction's error is about sigma_dir |r| per axis: weight 1 / (sigma_dir |r|)^2.
        // The errors are systematic (biases, scale factors), so the data as a whole weigh as
        // one direction of each kind, not as many independent ones: bins share the weight by
        // their length.
        let mut add = |measured: &Vector3<f64>, r: &Vector3<f64>, sigma_dir: f64| {
            let r2 = r.norm_squared();
            if r2 > 0.0 && sigma_dir.is_finite() {
                b += measured * r.transpose() * (w / (sigma_dir * sigma_dir * r2));
            }
        };
        let rate = s.omega_body.norm();
        let sigma_rate = errors.gyro_matrix.hypot(errors.gyro_bias / rate);
        add(&bin.rate, &s.omega_body, sigma_rate);
        let f = s.f_body.norm();
        let sigma_f = errors.accel_matrix.hypot(errors.accel_bias / f);
        add(&bin.f, &s.f_body, sigma_f);
    }
    wahba(&b).map(|r| r.transpose())
}

/// The rotation `R` minimising `sum w |b - R r|^2` from `B = sum w b r^T` (SVD solution of
/// Wahba's problem).
fn wahba(b: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let svd = b.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let d = (u * v_t).determinant().signum();
    Some(u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t)
}

/// The start attitude aligned to `program` from the rate bins and the prior covariance of all
/// states of `layout` with the start attitude error tied to the alignment
/// ([`aligned_covariance`]; the copy of the start attitude error, if carried, made equal to
/// it). `None` when the program does not turn about two axes.
pub fn aligned_prior(
    config: &crate::config::RunConfig,
    site: &Site,
    layout: &crate::model::layout::StateLayout,
    bins: &[RateBin],
    program: &Program,
    program_start: f64,
    t_start: f64,
) -> Option<(Matrix3<f64>, DMatrix<f64>)> {
    aligned_prior_by(
        config,
        site,
        layout,
        BinsByIndex {
            count: bins.len(),
            at: &|i| bins[i],
        },
        program,
        program_start,
        t_start,
    )
}

/// Rate bins made on demand: how many there are, and the one at an index.
#[derive(Clone, Copy)]
pub struct BinsByIndex<'a> {
    /// Number of bins.
    pub count: usize,
    /// The bin at an index below `count`.
    pub at: &'a dyn Fn(usize) -> RateBin,
}

/// [`aligned_prior`] with the bins made on demand ([`align_to_program_by`]).
pub fn aligned_prior_by(
    config: &crate::config::RunConfig,
    site: &Site,
    layout: &crate::model::layout::StateLayout,
    bins: BinsByIndex,
    program: &Program,
    program_start: f64,
    t_start: f64,
) -> Option<(Matrix3<f64>, DMatrix<f64>)> {
    let al = align_to_program_by(
        bins.count,
        bins.at,
        program,
        site,
        program_start,
        t_start,
        &layout.model,
        config.gyro_psd(),
    )?;
    let off = crate::model::layout::StateLayout::INSTRUMENT;
    let p = crate::model::layout::initial_covariance(config, layout, &al.c_start);
    let mut p = aligned_covariance(&p, off..off + layout.n_instrument(), &al);
    crate::model::layout::copy_start_attitude(&mut p, layout);
    Some((al.c_start, p))
}

/// Rate bins of the ideal motion of a program (no sensor errors), as the covariance analysis
/// sees it.
pub fn ideal_bins(kin: &Kinematics, bin_s: f64) -> Vec<RateBin> {
    (0..ideal_bin_count(kin, bin_s))
        .map(|i| ideal_bin(kin, bin_s, i))
        .collect()
}

/// The number of [`ideal_bins`].
pub fn ideal_bin_count(kin: &Kinematics, bin_s: f64) -> usize {
    (kin.program.duration() / bin_s).floor() as usize
}

/// Bin `i` of [`ideal_bins`], made alone.
pub fn ideal_bin(kin: &Kinematics, bin_s: f64, i: usize) -> RateBin {
    let (t0, t1) = (i as f64 * bin_s, (i + 1) as f64 * bin_s);
    // The mean over the bin, by the midpoint rule on ten sub-intervals.
    let (mut rate, mut f) = (Vector3::zeros(), Vector3::zeros());
    for k in 0..10 {
        let s = kin.sample(t0 + (k as f64 + 0.5) * bin_s / 10.0);
        rate += s.omega_body / 10.0;
        f += s.f_body / 10.0;
    }
    RateBin { t0, t1, rate, f }
}

/// `p` with the rows and columns of the attitude error (the first three states) zero.
pub fn without_attitude(p: &DMatrix<f64>) -> DMatrix<f64> {
    let mut p = p.clone();
    let n = p.nrows();
    for i in 0..3 {
        for j in 0..n {
            p[(i, j)] = 0.0;
            p[(j, i)] = 0.0;
        }
    }
    p
}

/// The prior covariance of all states with the start attitude error tied to the alignment:
/// `beta_0 = B p + eps`, `cov(beta_0) = B P_p B^T + sigma_eps^2 I`, `cov(beta_0, p) = B P_p`,
/// `beta_0` uncorrelated with the other states. `p0` is the prior covariance without it.
pub fn aligned_covariance(
    p0: &DMatrix<f64>,
    instrument: std::ops::Range<usize>,
    alignment: &Alignment,
) -> DMatrix<f64> {
    let mut p = without_attitude(p0);
    let p_pp = p0.view(
        (instrument.start, instrument.start),
        (instrument.len(), instrument.len()),
    );
    let b = &alignment.jacobian;
    let b_p = b * p_pp;
    let beta = &b_p * b.transpose() + DMatrix::identity(3, 3) * alignment.sigma_noise.powi(2);
    for i in 0..3 {
        for j in 0..3 {
            p[(i, j)] = beta[(i, j)];
        }
        for (c, j) in instrument.clone().enumerate() {
            p[(i, j)] = b_p[(i, c)];
            p[(j, i)] = b_p[(i, c)];
        }
    }
    p
}
