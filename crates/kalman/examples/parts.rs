use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use kalman::KalmanFilter;
use std::hint::black_box;
use std::time::Instant;
#[path = "../tests/common/mod.rs"]
mod common;
use common::*;

fn time<F: FnMut()>(name: &str, mut f: F) {
    for _ in 0..1000 {
        f();
    }
    let iters = 20000;
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        for _ in 0..iters {
            f();
        }
        best = best.min(t.elapsed().as_secs_f64() / iters as f64);
    }
    println!("{name:40} {:8.3} us", best * 1e6);
}

fn main() {
    for n in [28usize, 60] {
        let mut rng = Rng::new(1);
        let a = rng.mat(n, n);
        let b = rng.mat(n, n);
        let mut c = Mat::<f64>::zeros(n, n);
        time(&format!("matmul {n}^3"), || {
            matmul(
                c.as_mut(),
                Accum::Replace,
                black_box(a.as_ref()),
                black_box(b.as_ref()),
                1.0,
                Par::Seq,
            )
        });
        time(&format!("matmul {n}^3 bT"), || {
            matmul(
                c.as_mut(),
                Accum::Add,
                black_box(a.as_ref()),
                black_box(b.transpose()),
                1.0,
                Par::Seq,
            )
        });
        let h = rng.mat(6, n);
        let mut bb = Mat::<f64>::zeros(n, 6);
        time(&format!("P H^T n={n}"), || {
            matmul(
                bb.as_mut(),
                Accum::Replace,
                black_box(a.as_ref()),
                black_box(h.transpose()),
                1.0,
                Par::Seq,
            )
        });
        let w = rng.mat(n, 12);
        let w2 = rng.mat(n, 12);
        time(&format!("P -= W1 W2^T n={n}"), || {
            matmul(
                c.as_mut(),
                Accum::Add,
                black_box(w.as_ref()),
                black_box(w2.transpose()),
                -1.0,
                Par::Seq,
            )
        });
        let pt = rng.mat(3, n);
        let mut t = Mat::<f64>::zeros(3, n);
        time(&format!("phi_top P n={n}"), || {
            matmul(
                t.as_mut(),
                Accum::Replace,
                black_box(pt.as_ref()),
                black_box(a.as_ref()),
                1.0,
                Par::Seq,
            )
        });
        let mut pp = rng.spd(n);
        time(&format!("symmetrise n={n}"), || {
            kalman::symmetrise(black_box(pp.as_mut()))
        });
        let mut buf = MemBuffer::new(kalman::predict::predict_dense_scratch(n));
        time(&format!("temp_mat_zeroed n={n}"), || {
            let (mut t, _) =
                faer::linalg::temp_mat_zeroed::<f64, _, _>(n, n, MemStack::new(&mut buf));
            black_box(faer::mat::AsMatMut::as_mat_mut(&mut t));
        });

        let p0 = rng.spd(n);
        let sys = Structured::random(&mut rng, 3, n, 0.01);
        let (phi, q) = sys.full(n);
        let r = rng.spd(6);
        let z = rng.vec(6);
        let mut kf = KalmanFilter::new(&rng.vec(n), p0.as_ref(), 6).unwrap();
        time(&format!("predict dense + update n={n}"), || {
            kf.predict(black_box(phi.as_ref()), black_box(q.as_ref()))
                .unwrap();
            kf.update(black_box(&z), black_box(h.as_ref()), black_box(r.as_ref()))
                .unwrap();
        });
        time(&format!("predict struct + update n={n}"), || {
            kf.predict_structured(
                black_box(sys.phi_top.as_ref()),
                black_box(sys.q_top.as_ref()),
            )
            .unwrap();
            kf.update(black_box(&z), black_box(h.as_ref()), black_box(r.as_ref()))
                .unwrap();
        });
        time(&format!("update n={n}"), || {
            black_box(
                kf.update(black_box(&z), black_box(h.as_ref()), black_box(r.as_ref()))
                    .unwrap(),
            );
        });
        time(&format!("update_cov n={n}"), || {
            kf.update_covariance(black_box(h.as_ref()), black_box(r.as_ref()))
                .unwrap();
        });
    }
}
