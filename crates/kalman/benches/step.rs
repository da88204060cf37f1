//! One predict + update step of the engine at calibration sizes.
//!
//! For n = 28 and n = 60 states and m = 6 measurement components:
//! - `structured`: `predict_structured` with k = 3 dynamic states + Joseph update (what the
//!   calibration runs),
//! - `dense`: the plain dense faer baseline ([`kalman::dense::DenseFilter`]): dense predict with
//!   the equivalent full Phi and Q, and the textbook Joseph update on faer products and faer's
//!   Cholesky,
//! - `naive`: the triple-loop reference of `kalman::reference` doing the same step,
//! - `predict_structured` / `predict_dense`: the time update alone (engine / baseline).
//!
//! No benchmark loop allocates (all scratch is allocated before `iter`).
//!
//! Run with `cargo bench -p kalman --bench step`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kalman::KalmanFilter;
use kalman::dense::DenseFilter;
use kalman::reference::NaiveFilter;

#[path = "../tests/common/mod.rs"]
mod common;
use common::{Rng, Structured, to_row_major};

const M: usize = 6;
const K: usize = 3;

fn step(c: &mut Criterion) {
    for n in [28usize, 60] {
        let mut rng = Rng::new(42 + n as u64);
        let x0 = rng.vec(n);
        let p0 = rng.spd(n);
        let sys = Structured::random(&mut rng, K, n, 0.01);
        let (phi, q) = sys.full(n);
        let h = rng.mat(M, n);
        let r = rng.spd(M);
        // Measurements vary from step to step (a fixed z would drive the innovation to zero
        // and the benchmark into subnormal arithmetic).
        let zs: Vec<Vec<f64>> = (0..256).map(|_| rng.vec(M)).collect();

        let mut group = c.benchmark_group(format!("step_n{n}_m{M}"));

        let mut kf = KalmanFilter::new(&x0, p0.as_ref(), M).unwrap();
        let mut i = 0usize;
        group.bench_function("structured", |b| {
            b.iter(|| {
                i = (i + 1) % zs.len();
                let z = &zs[i];
                kf.predict_structured(
                    black_box(sys.phi_top.as_ref()),
                    black_box(sys.q_top.as_ref()),
                )
                .unwrap();
                black_box(
                    kf.update(black_box(z), black_box(h.as_ref()), black_box(r.as_ref()))
                        .unwrap(),
                )
            })
        });

        let mut kf = DenseFilter::new(&x0, p0.as_ref(), M);
        let mut i = 0usize;
        group.bench_function("dense", |b| {
            b.iter(|| {
                i = (i + 1) % zs.len();
                let z = &zs[i];
                kf.predict(black_box(phi.as_ref()), black_box(q.as_ref()))
                    .unwrap();
                black_box(
                    kf.update(black_box(z), black_box(h.as_ref()), black_box(r.as_ref()))
                        .unwrap(),
                )
            })
        });

        let (phi_rm, q_rm, h_rm, r_rm) = (
            to_row_major(&phi),
            to_row_major(&q),
            to_row_major(&h),
            to_row_major(&r),
        );
        let mut naive = NaiveFilter::new(&x0, &to_row_major(&p0), M);
        let mut i = 0usize;
        group.bench_function("naive", |b| {
            b.iter(|| {
                i = (i + 1) % zs.len();
                let z = &zs[i];
                naive.predict(black_box(&phi_rm), black_box(&q_rm));
                black_box(
                    naive
                        .update(black_box(z), black_box(&h_rm), black_box(&r_rm))
                        .unwrap(),
                )
            })
        });

        // The time update alone (state and covariance), where the structure is exploited. The
        // covariance is reset every 1024 steps so that it stays bounded without updates.
        let mut kf = KalmanFilter::new(&x0, p0.as_ref(), M).unwrap();
        let mut i = 0usize;
        group.bench_function("predict_structured", |b| {
            b.iter(|| {
                i += 1;
                if i.is_multiple_of(1024) {
                    kf.covariance_mut().copy_from(&p0);
                }
                kf.predict_structured(
                    black_box(sys.phi_top.as_ref()),
                    black_box(sys.q_top.as_ref()),
                )
                .unwrap();
            })
        });
        let mut kf = DenseFilter::new(&x0, p0.as_ref(), M);
        let mut i = 0usize;
        group.bench_function("predict_dense", |b| {
            b.iter(|| {
                i += 1;
                if i.is_multiple_of(1024) {
                    kf.covariance_mut().copy_from(&p0);
                }
                kf.predict(black_box(phi.as_ref()), black_box(q.as_ref()))
                    .unwrap();
            })
        });

        group.finish();
    }
}

criterion_group!(benches, step);
criterion_main!(benches);
