use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::prelude::*;
use faer::{Accum, Mat, MatMut, Par, unzip, zip};
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
    for _ in 0..7 {
        let t = Instant::now();
        for _ in 0..iters {
            f();
        }
        best = best.min(t.elapsed().as_secs_f64() / iters as f64);
    }
    println!("{name:40} {:8.3} us", best * 1e6);
}

fn mirror_lower(mut p: MatMut<'_, f64>) {
    let n = p.nrows();
    for j in 0..n {
        for i in (j + 1)..n {
            p[(j, i)] = p[(i, j)];
        }
    }
}

fn mirror_tile(mut p: MatMut<'_, f64>) {
    let n = p.nrows();
    const B: usize = 8;
    let mut j0 = 0;
    while j0 < n {
        let bj = B.min(n - j0);
        for j in j0..j0 + bj {
            for i in (j + 1)..j0 + bj {
                p[(j, i)] = p[(i, j)];
            }
        }
        let mut i0 = j0 + bj;
        while i0 < n {
            let bi = B.min(n - i0);
            let (top, bottom) = p.rb_mut().split_at_row_mut(i0);
            let lower = bottom.submatrix_mut(0, j0, bi, bj);
            let upper = top.submatrix_mut(j0, i0, bj, bi);
            zip!(upper.transpose_mut(), lower).for_each(|unzip!(x, y)| {
                *x = *y;
            });
            i0 += bi;
        }
        j0 += bj;
    }
}

fn main() {
    for n in [28usize, 60] {
        let m = 6;
        let mut rng = Rng::new(3);
        let p0 = rng.spd(n);
        let w = rng.mat(n, 3 * m) * 0.01;
        let mut p = p0.clone();
        time(&format!("copy P n={n}"), || {
            p.copy_from(black_box(&p0));
        });
        time(&format!("full + symmetrise n={n}"), || {
            p.copy_from(black_box(&p0));
            matmul(
                p.as_mut(),
                Accum::Add,
                w.subcols(0, 2 * m),
                w.subcols(m, 2 * m).transpose(),
                -1.0,
                Par::Seq,
            );
            kalman::symmetrise(p.as_mut());
        });
        time(&format!("full only n={n}"), || {
            p.copy_from(black_box(&p0));
            matmul(
                p.as_mut(),
                Accum::Add,
                w.subcols(0, 2 * m),
                w.subcols(m, 2 * m).transpose(),
                -1.0,
                Par::Seq,
            );
        });
        time(&format!("tri + mirror n={n}"), || {
            p.copy_from(black_box(&p0));
            triangular::matmul(
                p.as_mut(),
                BlockStructure::TriangularLower,
                Accum::Add,
                w.subcols(0, 2 * m),
                BlockStructure::Rectangular,
                w.subcols(m, 2 * m).transpose(),
                BlockStructure::Rectangular,
                -1.0,
                Par::Seq,
            );
            mirror_lower(p.as_mut());
        });
        time(&format!("tri + mirror_tile n={n}"), || {
            p.copy_from(black_box(&p0));
            triangular::matmul(
                p.as_mut(),
                BlockStructure::TriangularLower,
                Accum::Add,
                w.subcols(0, 2 * m),
                BlockStructure::Rectangular,
                w.subcols(m, 2 * m).transpose(),
                BlockStructure::Rectangular,
                -1.0,
                Par::Seq,
            );
            mirror_tile(p.as_mut());
        });
        time(&format!("tri only n={n}"), || {
            p.copy_from(black_box(&p0));
            triangular::matmul(
                p.as_mut(),
                BlockStructure::TriangularLower,
                Accum::Add,
                w.subcols(0, 2 * m),
                BlockStructure::Rectangular,
                w.subcols(m, 2 * m).transpose(),
                BlockStructure::Rectangular,
                -1.0,
                Par::Seq,
            );
        });
        let mut b = Mat::<f64>::zeros(n, m);
        let h = rng.mat(m, n);
        time(&format!("P H^T n={n}"), || {
            matmul(
                b.as_mut(),
                Accum::Replace,
                black_box(p0.as_ref()),
                black_box(h.transpose()),
                1.0,
                Par::Seq,
            )
        });
        let ht = h.transpose().to_owned();
        time(&format!("P Ht(colmajor) n={n}"), || {
            matmul(
                b.as_mut(),
                Accum::Replace,
                black_box(p0.as_ref()),
                black_box(ht.as_ref()),
                1.0,
                Par::Seq,
            )
        });
        let mut s = Mat::<f64>::zeros(m, m);
        time(&format!("H B n={n}"), || {
            matmul(
                s.as_mut(),
                Accum::Replace,
                black_box(h.as_ref()),
                black_box(b.as_ref()),
                1.0,
                Par::Seq,
            )
        });
        time(&format!("B^T H^T n={n}"), || {
            matmul(
                s.as_mut().transpose_mut(),
                Accum::Replace,
                black_box(b.transpose()),
                black_box(h.transpose()),
                1.0,
                Par::Seq,
            )
        });
        let mut x = Mat::<f64>::zeros(n, 1);
        let nu = rng.mat(m, 1);
        time(&format!("K nu n={n}"), || {
            matmul(
                x.as_mut(),
                Accum::Add,
                black_box(b.as_ref()),
                black_box(nu.as_ref()),
                1.0,
                Par::Seq,
            )
        });
        let sinv = rng.mat(m, m);
        let mut k = Mat::<f64>::zeros(n, m);
        time(&format!("B Sinv n={n}"), || {
            matmul(
                k.as_mut(),
                Accum::Replace,
                black_box(b.as_ref()),
                black_box(sinv.as_ref()),
                1.0,
                Par::Seq,
            )
        });
        time(&format!("is_all_finite H n={n}"), || {
            black_box(black_box(h.as_ref()).is_all_finite());
        });
        time(&format!("is_all_finite P n={n}"), || {
            black_box(black_box(p0.as_ref()).is_all_finite());
        });
    }
}
