//! A linear Kalman filter and covariance engine on [faer], built for the small, dense,
//! many-step problems of instrument calibration: tens of states, measurements of a few
//! components, and hundreds of thousands of steps.
//!
//! There is one engine, [`KalmanFilter`], with two stages:
//!
//! - **Structured predict** ([`KalmanFilter::predict`]). The transition is the identity except
//!   its first `k` rows (`phi_top`, `k x n`) and the process noise is zero except its top-left
//!   `k x k` block: the first `k` states are dynamic (e.g. three attitude errors), the rest are
//!   constant parameters. The step costs `O(k n^2)` instead of the `O(n^3)` of a dense
//!   `Phi P Phi^T`; with `k = n` it is the general dense predict.
//! - **Optimal-gain update** ([`KalmanFilter::update`]) in `O(n^2 m)`: with `B = P H^T`,
//!   `S = H B + R = L L^T` and `W = B L^{-T}`, the covariance becomes `P - W W^T` (the Joseph
//!   form for the optimal gain), computed on the lower triangle and mirrored, so it is exactly
//!   symmetric. The update returns the normalised innovation squared (NIS) and `ln det S`.
//!   [`KalmanFilter::update_correlated`] takes measurement noise correlated with the state's
//!   error (`M = E[e v^T]`): `B = P H^T + M`, `S = H B + R + M^T H^T`, the rest the same.
//!
//! Both stages have a covariance-only form ([`KalmanFilter::predict_covariance`],
//! [`KalmanFilter::update_covariance`], [`KalmanFilter::update_covariance_correlated`]) for
//! covariance analysis without data.
//!
//! **Normalised states.** The filter holds a scale factor `sigma_i` per state (by default the
//! prior standard deviation) and works on `x_i / sigma_i` inside, so that states of very
//! different magnitudes (`1e-9 rad/s` next to `0.05 s`) stay well conditioned. Its public face
//! is in the caller's units: it takes and returns the state, the covariance and the model
//! matrices (`phi_top`, `Q`, `H`, `R`) unscaled, and converts them on the way in and out.
//!
//! **No allocation in the step loop.** The constructor allocates the state, the covariance, the
//! results of the last update and one scratch buffer (faer's [`MemBuffer`](faer::dyn_stack))
//! sized for `n` states and measurements of up to `m_max` components; `predict*` and `update*`
//! take their temporaries from that buffer and allocate nothing. Every step runs sequentially
//! ([`Par::Seq`](faer::Par)) on the calling thread, and checks its inputs before it writes
//! anything: after an error the filter is unchanged.
//!
//! **Small problems.** Up to 32 states the products of both stages are the engine's own column
//! loops (faer's fixed cost per product call is most of a step at these sizes), compiled for
//! AVX2 as well and chosen at run time through pulp's safe dispatch; above 32 states they are
//! faer's. The two give the same results to rounding (tested against a naive reference on both
//! sides of the switch).
//!
//! Performance figures and the commands that measure them are in `docs/performance.md` of the
//! repository.
//!
//! # Example: estimating a constant from noisy measurements
//!
//! ```
//! use faer::mat;
//! use kalman::KalmanFilter;
//!
//! // One state with prior mean 0 and prior sigma 10; measurements z = x + v, var(v) = 4.
//! let mut kf = KalmanFilter::from_diagonal(&[0.0], &[10.0], 1)?;
//! let (h, r) = (mat![[1.0]], mat![[4.0]]);
//! for z in [5.3, 4.6, 5.1, 4.9, 5.2] {
//!     let info = kf.update(&[z], h.as_ref(), r.as_ref())?;
//!     assert!(info.nis < 20.0); // chi-square with one degree of freedom
//! }
//! // Posterior variance 1 / (1/100 + 5/4); mean close to the sample mean 5.02.
//! assert!((kf.covariance()[(0, 0)] - 1.0 / (0.01 + 1.25)).abs() < 1e-12);
//! assert!((kf.state()[0] - 5.02).abs() < 0.05);
//! # Ok::<(), kalman::KalmanError>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod error;
mod filter;
mod predict;
mod small;
mod update;

pub use error::KalmanError;
pub use filter::{KalmanFilter, UpdateInfo};
