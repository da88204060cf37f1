use faer::prelude::*;
use faer::{Mat, MatMut, unzip, zip};
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

fn sym_rec(p: MatMut<'_, f64>) {
    let n = p.nrows();
    if n <= 8 {
        let mut p = p;
        for j in 0..n {
            for i in (j + 1)..n {
                let a = 0.5 * (p[(i, j)] + p[(j, i)]);
                p[(i, j)] = a;
                p[(j, i)] = a;
            }
        }
        return;
    }
    let h = n / 2;
    let (a11, a12, a21, a22) = p.split_at_mut(h, h);
    zip!(a21, a12.transpose_mut()).for_each(|unzip!(x, y)| {
        let a = 0.5 * (*x + *y);
        *x = a;
        *y = a;
    });
    sym_rec(a11);
    sym_rec(a22);
}

fn sym_ptr(p: MatMut<'_, f64>) {
    let n = p.nrows();
    assert_eq!(n, p.ncols());
    let rs = p.row_stride();
    let cs = p.col_stride();
    let ptr = p.as_ptr_mut();
    for j in 0..n {
        for i in (j + 1)..n {
            unsafe {
                let a = ptr.offset(i as isize * rs + j as isize * cs);
                let b = ptr.offset(j as isize * rs + i as isize * cs);
                let m = 0.5 * (*a + *b);
                *a = m;
                *b = m;
            }
        }
    }
}

fn sym_tile(mut p: MatMut<'_, f64>) {
    // tiles of 8x8: process block (I,J) with I>J against (J,I)
    let n = p.nrows();
    const B: usize = 8;
    let mut j0 = 0;
    while j0 < n {
        let bj = B.min(n - j0);
        // diagonal block
        for j in j0..j0 + bj {
            for i in (j + 1)..j0 + bj {
                let a = 0.5 * (p[(i, j)] + p[(j, i)]);
                p[(i, j)] = a;
                p[(j, i)] = a;
            }
        }
        let mut i0 = j0 + bj;
        while i0 < n {
            let bi = B.min(n - i0);
            let (top, bottom) = p.rb_mut().split_at_row_mut(i0);
            let lower = bottom.submatrix_mut(0, j0, bi, bj);
            let upper = top.submatrix_mut(j0, i0, bj, bi);
            zip!(lower, upper.transpose_mut()).for_each(|unzip!(x, y)| {
                let a = 0.5 * (*x + *y);
                *x = a;
                *y = a;
            });
            i0 += bi;
        }
        j0 += bj;
    }
}

fn main() {
    for n in [6usize, 28, 60] {
        let mut rng = Rng::new(1);
        let mode = std::env::args().nth(1).unwrap_or_default();
        let mut p = match mode.as_str() {
            "spd" => rng.spd(n),
            "symhelper" => sym(rng.mat(n, n)),
            "spdnosym" => {
                let a = rng.mat(n, n);
                &a * a.transpose() * (1.0 / n as f64)
            }
            "scaled" => {
                let a = rng.mat(n, n);
                let mut m = &a * a.transpose() * (1.0 / n as f64);
                for j in 0..n {
                    for i in 0..n {
                        m[(i, j)] = m[(i, j)] * 4.0 + 0.0;
                    }
                }
                m
            }
            "small" => sym(rng.mat(n, n) * 0.2),
            "spdasym" => {
                let mut m = rng.spd(n);
                m[(0, 1)] += 1e-3;
                m
            }
            "symthenprod" => {
                let a = rng.mat(n, n);
                let m = &a * a.transpose();
                sym(m)
            }
            "prodnotsym" => {
                let a = rng.mat(n, n);
                let b = rng.mat(n, n);
                &a * &b
            }
            "randtimesid" => { let a = rng.mat(n,n); &a * Mat::<f64>::identity(n,n) }, "randplus" => { let a = rng.mat(n,n); let b = rng.mat(n,n); &a + &b }, "sumof3" => { let a = rng.mat(n,n); let b = rng.mat(n,n); let c = rng.mat(n,n); Mat::from_fn(n,n,|i,j| a[(i,j)]*b[(i,j)] + c[(i,j)]) }, "diag" => {
                let mut m = rng.mat(n, n);
                for i in 0..n {
                    m[(i, i)] += 0.1;
                }
                m
            }
            _ => rng.mat(n, n),
        };
        let p0 = p.clone();
        {
            let mut c = 0;
            let mut z = 0;
            for j in 0..n {
                for i in 0..n {
                    if p[(i, j)].is_subnormal() {
                        c += 1;
                    }
                    if p[(i, j)] == 0.0 {
                        z += 1;
                    }
                }
            }
            println!("subnormal {c} zero {z}");
        }
        println!(
            "cs {} ptr%64 {} p01 {:e} p10 {:e}",
            p.col_stride(),
            p.as_ptr() as usize % 64,
            p[(0, 1)],
            p[(1, 0)]
        );
        time(&format!("faer-index n={n}"), || {
            kalman::symmetrise(black_box(p.as_mut()))
        });
        time(&format!("rec n={n}"), || sym_rec(black_box(p.as_mut())));
        time(&format!("ptr n={n}"), || sym_ptr(black_box(p.as_mut())));
        time(&format!("tile n={n}"), || sym_tile(black_box(p.as_mut())));
        let mut a = p0.clone();
        kalman::symmetrise(a.as_mut());
        let mut b = p0.clone();
        sym_rec(b.as_mut());
        let mut c = p0.clone();
        sym_ptr(c.as_mut());
        let mut d = p0.clone();
        sym_tile(d.as_mut());
        assert_eq!(a, b);
        assert_eq!(a, c);
        assert_eq!(a, d);
    }
}
