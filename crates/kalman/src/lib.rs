//! A generic linear Kalman filter and covariance engine on [faer], built for the small, dense,
//! many-step problems of instrument calibration: tens of states, measurements of a few
//! components, and hundreds of thousands of steps.
//!
//! - **No allocation in the step loop.** [`KalmanFilter`] allocates all scratch for a state
//!   dimension `n` and a maximum measurement dimension `m_max` when it is built; `predict*` and
//!   `update*` then allocate nothing. Everything runs sequentially on the calling thread.
//! - **Structured predict.** When only the first `k` states are dynamic (e.g. three attitude
//!   errors) and the rest are constant parameters, [`KalmanFilter::predict_structured`] costs
//!   `O(k n^2)` instead of the `O(n^3)` of [`KalmanFilter::predict`].
//! - **Joseph-form update** in `O(n^2 m)` ([`KalmanFilter::update`]), which returns the
//!   normalised innovation squared (NIS) and `ln det S` for consistency checks. For the optimal
//!   gain the Joseph form is `P - B S^{-1} B^T` (`B = P H^T`), which the filter forms as
//!   `P - W W^T` with `W = B L^{-T}`, `S = L L^T`: exactly symmetric, one rank-`m` update.
//! - **Covariance-only mode** ([`KalmanFilter::predict_covariance`],
//!   [`KalmanFilter::predict_structured_covariance`], [`KalmanFilter::update_covariance`]) for
//!   covariance analysis without data.
//! - **Normalisation by prior sigma** ([`Scaling`]), so that states of very different magnitudes
//!   (`1e-9 rad/s` next to `0.05 s`) stay well conditioned for everything around the filter.
//!
//! The structured predict and the update of [`KalmanFilter`] run on hand-written kernels for
//! these small sizes (the filter keeps its covariance in 64-byte aligned column-major storage
//! with the leading dimension rounded up to a multiple of 8, and picks AVX-512, AVX2 + FMA or
//! portable code at run time); the dense predict uses faer's matrix product.
//!
//! The building blocks are also available as free functions on faer matrix views of any
//! strides, in faer's style (views in, a [`Par`](faer::Par) setting and a scratch
//! [`MemStack`](faer::dyn_stack::MemStack) whose size a `*_scratch` function gives): see
//! [`predict`] and [`update`]; they go through faer's products and accept any gain in the
//! Joseph form ([`update::joseph_covariance`]). [`reference`](mod@reference) holds a naive loop
//! implementation used as the ground truth by the tests, and [`dense`] the plain dense faer
//! filter that the benchmarks compare against.
//!
//! Performance figures and what they depend on are in `docs/performance.md` of the repository.
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

#![deny(missing_docs)]

pub mod dense;
mod error;
mod filter;
mod gemm;
mod kernels;
pub mod predict;
pub mod reference;
mod scaling;
mod small;
mod symmetric;
pub mod update;

pub use error::KalmanError;
pub use filter::{KalmanFilter, UpdateInfo};
pub use scaling::Scaling;
pub use symmetric::symmetrise;
