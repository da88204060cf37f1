use kalman::KalmanFilter;
#[path = "../tests/common/mod.rs"]
mod common;
use common::*;
fn main() {
    let n = 28;
    let mut rng = Rng::new(42 + n as u64);
    let x0 = rng.vec(n);
    let p0 = rng.spd(n);
    let sys = Structured::random(&mut rng, 3, n, 0.01);
    let h = rng.mat(6, n);
    let r = rng.spd(6);
    let z = rng.vec(6);
    let mut kf = KalmanFilter::new(&x0, p0.as_ref(), 6).unwrap();
    for it in 0..=400000usize {
        kf.predict_structured(sys.phi_top.as_ref(), sys.q_top.as_ref())
            .unwrap();
        kf.update(&z, h.as_ref(), r.as_ref()).unwrap();
        if it % 50000 == 0 {
            let p = kf.covariance();
            let mut sub = 0;
            let mut mx = 0.0f64;
            let mut mn = f64::INFINITY;
            for j in 0..n {
                for i in 0..n {
                    let v = p[(i, j)].abs();
                    if v != 0.0 && v < f64::MIN_POSITIVE {
                        sub += 1;
                    }
                    mx = mx.max(v);
                    if v > 0.0 {
                        mn = mn.min(v);
                    }
                }
            }
            let dmin = (0..n).map(|i| p[(i, i)]).fold(f64::INFINITY, f64::min);
            println!("{it}: subnormal {sub}, max {mx:e}, min {mn:e}, min diag {dmin:e}");
        }
    }
}
