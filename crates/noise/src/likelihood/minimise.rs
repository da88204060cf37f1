//! Minimisers of the likelihood: Brent's method in one dimension and Nelder-Mead in more.

/// Brent's minimisation of `f` on `[a, b]` from `x` (`f(x)` = `fx`), to `tol` in `x`.
pub(super) fn brent(
    f: &mut dyn FnMut(f64) -> f64,
    mut a: f64,
    mut b: f64,
    x0: f64,
    fx0: f64,
    tol: f64,
) -> (f64, f64) {
    const CGOLD: f64 = 0.381_966_011_250_105;
    let (mut x, mut w, mut v) = (x0, x0, x0);
    let (mut fx, mut fw, mut fv) = (fx0, fx0, fx0);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..100 {
        let xm = 0.5 * (a + b);
        let tol1 = tol + 1e-12 * x.abs();
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = d;
            if p.abs() < (0.5 * q * etemp).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = if xm >= x { tol1 } else { -tol1 };
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + if d >= 0.0 { tol1 } else { -tol1 }
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, w, x) = (w, x, u);
            (fv, fw, fx) = (fw, fx, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, w) = (w, u);
                (fv, fw) = (fw, fu);
            } else if fu <= fv || v == x || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    (x, fx)
}

/// Minimise `f` of one variable from `x0`: bracket the minimum by steps of `step` growing
/// downhill, then Brent. `(x, f(x))`.
pub(super) fn minimise_1d(
    f: &mut dyn FnMut(f64) -> f64,
    x0: f64,
    step: f64,
    tol: f64,
) -> (f64, f64) {
    let f0 = f(x0);
    let (fp, fm) = (f(x0 + step), f(x0 - step));
    if f0 <= fp && f0 <= fm {
        return brent(f, x0 - step, x0 + step, x0, f0, tol);
    }
    let dir = if fp < fm { 1.0 } else { -1.0 };
    let (mut prev, mut cur, mut fcur) = (x0, x0 + dir * step, fp.min(fm));
    let mut h = step;
    for _ in 0..60 {
        h *= 2.0;
        let next = cur + dir * h;
        let fnext = f(next);
        if fnext >= fcur {
            let (lo, hi) = if dir > 0.0 {
                (prev, next)
            } else {
                (next, prev)
            };
            return brent(f, lo, hi, cur, fcur, tol);
        }
        (prev, cur, fcur) = (cur, next, fnext);
    }
    (cur, fcur)
}

/// Nelder-Mead minimisation of `f` from `x0` with initial steps `step`, to a spread of `ftol`
/// in `f` (or `max_eval` evaluations), restarted `restarts` times from the best point (a
/// collapsed simplex stops short of the minimum). `(x, f(x))`.
pub(super) fn nelder_mead(
    f: &mut dyn FnMut(&[f64]) -> f64,
    x0: &[f64],
    step: f64,
    ftol: f64,
    max_eval: usize,
    restarts: usize,
) -> (Vec<f64>, f64) {
    let n = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((x0.to_vec(), f(x0)));
    for i in 0..n {
        let mut x = x0.to_vec();
        x[i] += step;
        let fx = f(&x);
        simplex.push((x, fx));
    }
    let mut evals = n + 1;
    let at = |c: &[f64], w: &[f64], t: f64| -> Vec<f64> {
        c.iter().zip(w).map(|(c, w)| c + t * (w - c)).collect()
    };
    let mut restarted = 0;
    loop {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let spread = simplex[n].1 - simplex[0].1;
        if evals >= max_eval {
            break;
        }
        if spread <= ftol {
            if restarted >= restarts {
                break;
            }
            restarted += 1;
            let best = simplex[0].clone();
            simplex.truncate(1);
            for i in 0..n {
                let mut x = best.0.clone();
                x[i] += 0.1 * step;
                let fx = f(&x);
                simplex.push((x, fx));
            }
            evals += n;
            continue;
        }
        let mut c = vec![0.0; n];
        for (x, _) in &simplex[..n] {
            for (ci, xi) in c.iter_mut().zip(x) {
                *ci += xi / n as f64;
            }
        }
        let worst = simplex[n].0.clone();
        let xr = at(&c, &worst, -1.0);
        let fr = f(&xr);
        evals += 1;
        if fr < simplex[0].1 {
            let xe = at(&c, &worst, -2.0);
            let fe = f(&xe);
            evals += 1;
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (xc, fc) = if fr < simplex[n].1 {
                let x = at(&c, &worst, -0.5);
                let fx = f(&x);
                (x, fx)
            } else {
                let x = at(&c, &worst, 0.5);
                let fx = f(&x);
                (x, fx)
            };
            evals += 1;
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (xc, fc);
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    s.0 = at(&best, &s.0, 0.5);
                    s.1 = f(&s.0);
                }
                evals += n;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}
