//! One predict + update step of the engine at calibration sizes.
//!
//! For n = 28 and n = 60 states and m = 6 measurement components:
//! - `structured`: `predict_structured` with k = 3 dynamic states + Joseph update (what the
//!   calibration runs),
//! - `dense`: the plain dense faer baseline, `predict` with the equivalent full Phi and Q + the
//!   same update,
//! - `naive`: the triple-loop reference of `kalman::reference` doing the same step.
//!
//! No benchmark loop allocates (all scratch is allocated before `iter`).
//!
//! Run with `cargo bench -p kalman --bench step`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kalman::KalmanFilter;
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
        let z = rng.vec(M);

        let mut group = c.benchmark_group(format!("step_n{n}_m{M}"));

        let mut kf = KalmanFilter::new(&x0, p0.as_ref(), M).unwrap();
        group.bench_function("structured", |b| {
            b.iter(|| {
                kf.predict_structured(
                    black_box(sys.phi_top.as_ref()),
                    black_box(sys.q_top.as_ref()),
                )
                .unwrap();
                black_box(
                    kf.update(black_box(&z), black_box(h.as_ref()), black_box(r.as_ref()))
                        .unwrap(),
                )
            })
        });

        let mut kf = KalmanFilter::new(&x0, p0.as_ref(), M).unwrap();
        group.bench_function("dense", |b| {
            b.iter(|| {
                kf.predict(black_box(phi.as_ref()), black_box(q.as_ref()))
                    .unwrap();
                black_box(
                    kf.update(black_box(&z), black_box(h.as_ref()), black_box(r.as_ref()))
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
        group.bench_function("naive", |b| {
            b.iter(|| {
                naive.predict(black_box(&phi_rm), black_box(&q_rm));
                black_box(
                    naive
                        .update(black_box(&z), black_box(&h_rm), black_box(&r_rm))
                        .unwrap(),
                )
            })
        });

        group.finish();
    }
}

criterion_group!(benches, step);
criterion_main!(benches);
