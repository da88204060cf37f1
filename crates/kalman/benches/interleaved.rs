//! Structured engine versus dense baseline, measured in interleaved batches.
//!
//! The benchmark machine is a shared virtual machine whose speed drifts by up to a factor of
//! four over seconds, and faer's product kernels are sometimes several times slower in a process
//! that has already run other work (see `docs/performance.md`). So the two engines alternate in
//! batches of 500 steps in a fresh process per size, each round timing both, and the report
//! gives the fastest batch of each (the machine's uncontended speed), the medians, and the
//! median of the per-round ratios (both sides of each ratio ran within milliseconds of each
//! other).
//!
//! The structured engine is [`KalmanFilter`] (`predict` with the k = 3 top rows of the
//! transition + `update`, normalised states), the dense one the plain dense faer baseline
//! [`dense::DenseFilter`] (`predict` with the equivalent full Phi and Q + `update`).
//!
//! Run with `cargo bench -p kalman` (both sizes in one process) or
//! `cargo bench -p kalman --bench interleaved -- 28` (or `-- 60`).

use std::hint::black_box;
use std::time::Instant;

use kalman::KalmanFilter;

mod dense;
use dense::DenseFilter;

#[path = "../tests/common/mod.rs"]
mod common;
use common::{Rng, Structured};

const M: usize = 6;
const K: usize = 3;
const BATCH: usize = 500;
const WARMUP: usize = 20;
const ROUNDS: usize = 400;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Times `a` and `b` in alternating batches; prints one table row.
fn pair(label: &str, n: usize, mut a: impl FnMut(), mut b: impl FnMut()) {
    let (mut ta, mut tb, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    for round in 0..WARMUP + ROUNDS {
        let t = Instant::now();
        for _ in 0..BATCH {
            a();
        }
        let x = t.elapsed().as_secs_f64() / BATCH as f64 * 1e6;
        let t = Instant::now();
        for _ in 0..BATCH {
            b();
        }
        let y = t.elapsed().as_secs_f64() / BATCH as f64 * 1e6;
        if round >= WARMUP {
            ta.push(x);
            tb.push(y);
            ratio.push(y / x);
        }
    }
    let best = |v: &[f64]| v.iter().cloned().fold(f64::INFINITY, f64::min);
    println!(
        "| {label} | {n} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
        best(&ta),
        best(&tb),
        median(&mut ta),
        median(&mut tb),
        median(&mut ratio)
    );
}

fn main() {
    // `cargo bench` passes `--bench`; a number among the other arguments selects that `n` only.
    let only: Option<usize> = std::env::args().skip(1).find_map(|a| a.parse().ok());
    println!(
        "| case | n | structured best (us) | dense best (us) | structured median (us) | \
         dense median (us) | median per-round ratio |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- |");
    for n in [28usize, 60] {
        if only.is_some_and(|o| o != n) {
            continue;
        }
        let mut rng = Rng::new(42 + n as u64);
        let x0 = rng.vec(n);
        let p0 = rng.spd(n);
        let sys = Structured::random(&mut rng, K, n, 0.01);
        let (phi, q) = sys.full(n);
        let h = rng.mat(M, n);
        let r = rng.spd(M);
        let zs: Vec<Vec<f64>> = (0..256).map(|_| rng.vec(M)).collect();

        // predict + update
        let mut structured = KalmanFilter::new(&x0, p0.as_ref(), M).unwrap();
        let mut dense = DenseFilter::new(&x0, p0.as_ref(), M);
        let (mut i, mut j) = (0usize, 0usize);
        pair(
            "step",
            n,
            || {
                i = (i + 1) % zs.len();
                structured
                    .predict(
                        black_box(sys.phi_top.as_ref()),
                        black_box(sys.q_top.as_ref()),
                    )
                    .unwrap();
                black_box(
                    structured
                        .update(black_box(&zs[i]), h.as_ref(), r.as_ref())
                        .unwrap(),
                );
            },
            || {
                j = (j + 1) % zs.len();
                dense.predict(black_box(phi.as_ref()), black_box(q.as_ref()));
                black_box(
                    dense
                        .update(black_box(&zs[j]), h.as_ref(), r.as_ref())
                        .unwrap(),
                );
            },
        );

        // the time update alone (covariance reset every 1024 steps to stay bounded)
        let fresh = KalmanFilter::new(&x0, p0.as_ref(), M).unwrap();
        let mut structured = fresh.clone();
        let mut dense = DenseFilter::new(&x0, p0.as_ref(), M);
        let (mut i, mut j) = (0usize, 0usize);
        pair(
            "predict only",
            n,
            || {
                i += 1;
                if i.is_multiple_of(1024) {
                    structured.clone_from(&fresh);
                }
                structured
                    .predict(
                        black_box(sys.phi_top.as_ref()),
                        black_box(sys.q_top.as_ref()),
                    )
                    .unwrap();
            },
            || {
                j += 1;
                if j.is_multiple_of(1024) {
                    dense.covariance_mut().copy_from(&p0);
                }
                dense.predict(black_box(phi.as_ref()), black_box(q.as_ref()));
            },
        );
    }
}
