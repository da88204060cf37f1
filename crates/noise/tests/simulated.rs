//! The noise terms of simulated static recordings, identified by `noise` within its stated
//! uncertainties.
//!
//! The generator is the test's own: white rate noise `N` (rad/s at 1 Hz: an increment gets
//! `N sqrt(dt) z`), a bias random walk `K` (rad/s/sqrt(s): the bias steps by `K sqrt(dt) z`
//! each record, the increment gets the mean bias over the record) and, optionally, a
//! first-order Gauss-Markov bias. Seeds and thresholds were written down before any result was
//! seen; the expected scatter behind each threshold is in its comment.

#![allow(clippy::single_range_in_vec_init)] // one interval: the whole recording

use noise::analyse_axis;
use noise::fit::{NoiseFit, Term};
use noise::likelihood::{MlFit, fit_ml};
use rand::{SeedableRng, rngs::Xoshiro256PlusPlus};
use rand_distr::{Distribution, StandardNormal};

const DEG_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;

/// The acceptance levels: 0.1 deg/h (1-s average) and 0.037 deg/h/sqrt(h).
const WHITE: f64 = 0.1 * DEG_H;
const WALK: f64 = 0.037 * DEG_H / 60.0;

/// Static increments of one axis (rad): `records` at `rate_hz`, white level `white`, bias walk
/// `walk`, Gauss-Markov bias `(sigma, correlation time)`.
fn axis(
    seed: u64,
    records: usize,
    rate_hz: f64,
    white: f64,
    walk: f64,
    gauss_markov: Option<(f64, f64)>,
) -> Vec<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let dt = 1.0 / rate_hz;
    let (sw, sk) = (white * dt.sqrt(), walk * dt.sqrt());
    let (phi, sg) = gauss_markov.map_or((0.0, 0.0), |(s, tc)| {
        let phi = (-dt / tc).exp();
        (phi, s * (1.0 - phi * phi).sqrt())
    });
    let mut gm: f64 = gauss_markov.map_or(0.0, |(s, _)| {
        let z: f64 = StandardNormal.sample(&mut rng);
        s * z
    });
    let mut b = 0.0;
    let mut out = Vec::with_capacity(records);
    for _ in 0..records {
        let z: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(&mut rng));
        let b_next = b + sk * z[1];
        let gm_next = phi * gm + sg * z[2];
        out.push(sw * z[0] + 0.5 * (b + b_next + gm + gm_next) * dt);
        b = b_next;
        gm = gm_next;
    }
    out
}

fn fit_of(data: &[f64], rate_hz: f64) -> NoiseFit {
    analyse_axis(data, 1.0 / rate_hz, &[0..data.len()])
        .expect("analysis")
        .fit
}

/// The acceptance case: 4 h at 100 Hz, white 0.1 deg/h, walk 0.037 deg/h/sqrt(h):
/// the white level within 15 % and the walk within a factor 1.5 on each axis. Seed 22 (the
/// issue's number), one stream per axis.
///
/// Ignored until the fit required its terms to be supported inside the fitted range
/// (`fit::supported`; seed and thresholds unchanged). On axis 1 the long-tau Allan variances
/// come out 1.22, 1.96 and 2.55 times the truth at 1311, 2621 and 5243 s (8.4, 3.2 and 1.2
/// degrees of freedom), a rise steeper than a walk's, and white + bias instability + rate ramp
/// (chi2 12.97 / 17) beat white + walk (16.57 / 18) by Akaike's criterion. In that model the
/// bias instability carries half the sum at no fitted point: it only fills the gap between the
/// white and the ramp, a shape the data do not show on their own, so the rule leaves that
/// subset out and white + walk is taken. The rule was written for quantisation terms on the
/// shipped rests, not for this case. Axis 2 gets white + walk at chi2 43.71 / 18: that fit fails
/// its own chi-square check (which this test does not ask about); its levels pass. Checked
/// before as a cause and ruled out: the chi-square model of the logarithm of an estimate with
/// few degrees of freedom (a Monte-Carlo of 3000 pure walks of 22 500 records finds it
/// overstates the offset and the variance: at 1.2 degrees of freedom -1.03 and 3.62 where the
/// estimates give -0.78 and 1.89), whose correction left the choice as it was. The
/// maximum-likelihood twin [`ml_acceptance_four_hours_at_100_hz`] passes on the same data.
#[test]
fn acceptance_four_hours_at_100_hz() {
    for ax in 0..3u64 {
        let data = axis(22 * 10 + ax, 4 * 3600 * 100, 100.0, WHITE, WALK, None);
        let f = fit_of(&data, 100.0);
        let n = f.term(Term::White);
        let k = f.term(Term::RandomWalk);
        println!(
            "axis {ax}: white {:.5} +- {:.5} deg/h (true 0.1), walk {:.5} +- {:.5} deg/h/sqrt(h) \
             (true 0.037), chi2 {:.2} / {} dof",
            n.value / DEG_H,
            n.sigma / DEG_H,
            k.value / DEG_H * 60.0,
            k.sigma / DEG_H * 60.0,
            f.chi2,
            f.dof
        );
        assert!(
            (n.value / WHITE - 1.0).abs() < 0.15,
            "axis {ax}: white {}",
            n.value / DEG_H
        );
        assert!(k.included, "axis {ax}: no walk found");
        let r = k.value / WALK;
        assert!(
            r > 1.0 / 1.5 && r < 1.5,
            "axis {ax}: walk {} deg/h/sqrt(h)",
            k.value / DEG_H * 60.0
        );
    }
}

/// Ten seeds (1001..=1010), three axes each, 2 h at 50 Hz with the acceptance levels: 30
/// estimates each of the white level and of the walk.
fn seed_set() -> Vec<NoiseFit> {
    let mut fits = Vec::new();
    for seed in 1001..=1010u64 {
        for ax in 0..3u64 {
            let data = axis(seed * 10 + ax, 2 * 3600 * 50, 50.0, WHITE, WALK, None);
            fits.push(fit_of(&data, 50.0));
        }
    }
    fits
}

/// The stated sigmas are honest over the seed set: every error below 4 sigma (for 60
/// Gaussian errors the chance of one beyond 4 sigma is 0.4 %), and between 30 and 51 of the 60
/// within 1 sigma (a binomial with p = 0.683 has mean 41 and standard deviation 3.6: the band
/// is about 3 standard deviations each way).
///
/// Ignored while it failed (thresholds and seeds unchanged since they were written). First
/// version (octave estimates taken as independent): the walk left out of the fit in 9 of 30
/// fits, errors down to -4.7 sigma, the white level about 1 sigma low on average. Generalised
/// least squares with the octave correlations: 29 of 60 within 1 sigma, a bias instability
/// instead of the walk in 17 of the 30 two-hour recordings, and a walk kept at a chance low
/// value with too small a first-order sigma (0.44 of the truth, -8 sigma). With the fit in the
/// logarithm and the supported-term rule (`fit::supported`) it passes, at the lower end of its
/// band: 30 of 60 within 1 sigma, the largest error 2.63 sigma. The selection still leaves
/// the walk out in 16 of the 30 fits (a bias instability in 7, a rate ramp in 9); there the
/// error is measured against the level the data could hide, which covers the truth.
/// docs/noise.md, "What the checks say".
#[test]
fn seed_set_levels_within_stated_uncertainties() {
    let fits = seed_set();
    let mut within_one = 0;
    let mut worst: (f64, String) = (0.0, String::new());
    let mut left_out = 0;
    for (i, f) in fits.iter().enumerate() {
        for (term, truth) in [(Term::White, WHITE), (Term::RandomWalk, WALK)] {
            let e = f.term(term);
            let z = (e.value - truth) / e.sigma;
            println!(
                "fit {i:2} {term:?}: {:.5} of the truth, error {z:+.2} sigma{}",
                e.value / truth,
                if e.included {
                    String::new()
                } else {
                    format!(
                        " (not in the fit; fit has {:?}, chi2 {:.1}/{})",
                        f.terms
                            .iter()
                            .filter(|t| t.included)
                            .map(|t| t.term)
                            .collect::<Vec<_>>(),
                        f.chi2,
                        f.dof
                    )
                }
            );
            if !e.included {
                left_out += 1;
            }
            if z.abs() > worst.0 {
                worst = (z.abs(), format!("fit {i} {term:?}"));
            }
            if z.abs() <= 1.0 {
                within_one += 1;
            }
        }
    }
    println!(
        "{within_one} of 60 within 1 sigma, largest error {:.2} sigma ({}), {left_out} terms \
         left out of their fit",
        worst.0, worst.1
    );
    assert!(worst.0 < 4.0, "{}: {} sigma", worst.1, worst.0);
    assert!(
        (30..=51).contains(&within_one),
        "{within_one} of 60 within one sigma: expected 30 to 51"
    );
}

/// The maximum-likelihood fits ([`noise::likelihood`]) of the seed set of
/// [`seed_set_levels_within_stated_uncertainties`] (same seeds, generator and levels), two
/// threads.
fn ml_seed_set() -> Vec<MlFit> {
    let jobs: Vec<u64> = (1001..=1010u64)
        .flat_map(|seed| (0..3u64).map(move |ax| seed * 10 + ax))
        .collect();
    let mut fits: Vec<Option<MlFit>> = vec![None; jobs.len()];
    std::thread::scope(|s| {
        for (chunk_jobs, chunk_fits) in jobs.chunks(15).zip(fits.chunks_mut(15)) {
            s.spawn(move || {
                for (&j, out) in chunk_jobs.iter().zip(chunk_fits) {
                    let data = axis(j, 2 * 3600 * 50, 50.0, WHITE, WALK, None);
                    *out = Some(fit_ml(&data, 1.0 / 50.0, &[0..data.len()]).expect("ml fit"));
                }
            });
        }
    });
    fits.into_iter().map(|f| f.expect("a fit")).collect()
}

/// The maximum-likelihood twin of [`seed_set_levels_within_stated_uncertainties`], with the
/// same seeds and thresholds: every truth within 4 half-widths of its profile interval (the
/// half-width on the truth's side), and 30 to 51 of the 60 truths inside their 68 % interval.
#[test]
fn ml_seed_set_levels_within_profile_intervals() {
    let start = std::time::Instant::now();
    let fits = ml_seed_set();
    let mut inside = 0;
    let mut worst: (f64, String) = (0.0, String::new());
    let mut mean_z = [0.0; 2];
    let mut mean_ratio = [0.0; 2];
    let mut gm = 0;
    for (i, f) in fits.iter().enumerate() {
        if f.gauss_markov.is_some() {
            gm += 1;
        }
        for (j, (name, level, truth)) in [("white", f.white, WHITE), ("walk", f.walk, WALK)]
            .into_iter()
            .enumerate()
        {
            // The truth's position in half-widths: positive when the estimate is low.
            let z = level.z(truth);
            mean_z[j] += -z / fits.len() as f64;
            mean_ratio[j] += level.value / truth / fits.len() as f64;
            println!(
                "fit {i:2} {name}: {:.5} of the truth [{:.5}, {:.5}], truth at {z:+.2} \
                 half-widths{}",
                level.value / truth,
                level.lower / truth,
                level.upper / truth,
                match f.gauss_markov {
                    Some(g) => format!(
                        " (Gauss-Markov selected, p {:.4}: sigma {:.3} deg/h, tc {:.0} s)",
                        f.lr_p_value,
                        g.sigma.value / DEG_H,
                        g.correlation_time_s
                    ),
                    None => String::new(),
                }
            );
            if z.abs() > worst.0 {
                worst = (z.abs(), format!("fit {i} {name}"));
            }
            if z.abs() <= 1.0 {
                inside += 1;
            }
        }
    }
    println!(
        "{inside} of 60 truths inside their 68 % interval, largest miss {:.2} half-widths ({}), \
         mean z (estimate - truth, in half-widths) white {:+.3}, walk {:+.3}, mean estimate / \
         truth white {:.5}, walk {:.4}; Gauss-Markov selected in {gm} of 30\n(fits took {:.1} s)",
        worst.0,
        worst.1,
        mean_z[0],
        mean_z[1],
        mean_ratio[0],
        mean_ratio[1],
        start.elapsed().as_secs_f64()
    );
    let mut p: Vec<f64> = fits
        .iter()
        .map(|f| f.whiteness.map_or(f64::NAN, |w| w.p_value))
        .collect();
    p.sort_by(f64::total_cmp);
    println!(
        "whiteness check of the innovations: median p-value {:.3}, smallest {:.4}",
        0.5 * (p[14] + p[15]),
        p[0]
    );
    assert!(worst.0 < 4.0, "{}: {} half-widths", worst.1, worst.0);
    assert!(
        (30..=51).contains(&inside),
        "{inside} of 60 inside their interval: expected 30 to 51"
    );
}

/// The acceptance case ([`acceptance_four_hours_at_100_hz`], same data) with the
/// maximum-likelihood fit: white within 15 %, walk within a factor 1.5, each axis.
#[test]
fn ml_acceptance_four_hours_at_100_hz() {
    for ax in 0..3u64 {
        let start = std::time::Instant::now();
        let data = axis(22 * 10 + ax, 4 * 3600 * 100, 100.0, WHITE, WALK, None);
        let f = fit_ml(&data, 0.01, &[0..data.len()]).expect("ml fit");
        let (n, k) = (f.white, f.walk);
        println!(
            "axis {ax}: white {:.5} [{:.5}, {:.5}] deg/h (true 0.1), walk {:.4} [{:.4}, {:.4}] \
             deg/h/sqrt(h) (true 0.037), Gauss-Markov {}, LR p {:.3}, {} blocks of {} s, {:.2} s",
            n.value / DEG_H,
            n.lower / DEG_H,
            n.upper / DEG_H,
            k.value / DEG_H * 60.0,
            k.lower / DEG_H * 60.0,
            k.upper / DEG_H * 60.0,
            f.gauss_markov.is_some(),
            f.lr_p_value,
            f.blocks,
            f.block_s,
            start.elapsed().as_secs_f64()
        );
        assert!((n.value / WHITE - 1.0).abs() < 0.15, "axis {ax}: white");
        let r = k.value / WALK;
        assert!(r > 1.0 / 1.5 && r < 1.5, "axis {ax}: walk {r} of the truth");
    }
}

/// A measurement, not a pass/fail test (its seeds were chosen here, after the seed set above
/// passed, and it has no thresholds): the maximum-likelihood fit on recordings with a
/// Gauss-Markov bias (0.05 deg/h, 100 s) on top of the acceptance levels, seeds 2001..=2010,
/// three axes, 2 h at 50 Hz. Prints how often the bias is selected, how many truths (white,
/// walk, and the Gauss-Markov sigma where selected) lie inside their 68 % intervals, and the
/// largest miss. docs/noise.md reports the figures.
#[test]
#[ignore = "a measurement without thresholds, about 65 s in release: run with --ignored --nocapture"]
fn ml_gauss_markov_seed_set_report() {
    let gm = Some((0.05 * DEG_H, 100.0));
    let jobs: Vec<u64> = (2001..=2010u64)
        .flat_map(|s| (0..3u64).map(move |a| s * 10 + a))
        .collect();
    let mut res: Vec<Option<MlFit>> = vec![None; jobs.len()];
    std::thread::scope(|sc| {
        for (j, o) in jobs.chunks(15).zip(res.chunks_mut(15)) {
            sc.spawn(move || {
                for (&s, out) in j.iter().zip(o) {
                    let d = axis(s, 2 * 3600 * 50, 50.0, WHITE, WALK, gm);
                    *out = Some(fit_ml(&d, 0.02, &[0..d.len()]).expect("ml fit"));
                }
            });
        }
    });
    let (mut selected, mut inside, mut n, mut worst) = (0, 0, 0, (0.0f64, String::new()));
    for (i, f) in res.iter().map(|r| r.as_ref().expect("a fit")).enumerate() {
        let mut zs = vec![("white", f.white.z(WHITE)), ("walk", f.walk.z(WALK))];
        if let Some(g) = f.gauss_markov {
            selected += 1;
            zs.push(("gauss-markov sigma", g.sigma.z(0.05 * DEG_H)));
        }
        println!(
            "fit {i:2}: Gauss-Markov {} (tc {:?} s), truths at {:?} half-widths, check p {:?}",
            f.gauss_markov.is_some(),
            f.gauss_markov.map(|g| g.correlation_time_s.round()),
            zs.iter()
                .map(|(_, z)| (z * 100.0).round() / 100.0)
                .collect::<Vec<_>>(),
            f.whiteness.map(|w| w.p_value)
        );
        for (name, z) in zs {
            n += 1;
            if z.abs() <= 1.0 {
                inside += 1;
            }
            if z.abs() > worst.0 {
                worst = (z.abs(), format!("fit {i} {name}"));
            }
        }
    }
    println!(
        "Gauss-Markov selected in {selected} of 30; {inside} of {n} truths inside their 68 % \
         interval; largest miss {:.2} half-widths ({})",
        worst.0, worst.1
    );
}

/// The fit's chi-square is a usable check of the model on data the model describes: the
/// median p-value of the 30 fits between 0.1 and 0.9 (for uniform p-values the median of 30
/// has a standard deviation of 0.09), and none below 1e-4.
#[test]
fn seed_set_chi_square_is_calibrated() {
    let fits = seed_set();
    let mut p: Vec<f64> = fits.iter().map(|f| f.p_value).collect();
    p.sort_by(f64::total_cmp);
    println!("p-values: {p:.3?}");
    let median = 0.5 * (p[14] + p[15]);
    assert!(
        (0.1..=0.9).contains(&median),
        "median p-value {median}: expected 0.1 to 0.9"
    );
    assert!(p[0] > 1e-4, "smallest p-value {}", p[0]);
}

/// Static intervals with motion between them: 12 intervals of 10 minutes at 100 Hz out of a
/// recording whose other records turn at 10 deg/s with a ramp. The white level from the
/// intervals is within 3 sigma of the truth, the longest tau is at most half an interval, and
/// the motion, had it been taken for rest, would have shown.
#[test]
fn static_intervals_of_a_moving_recording() {
    let rate = 100.0;
    let per = 600 * 100;
    let gap = 30 * 100;
    let mut data = Vec::new();
    let mut intervals = Vec::new();
    for k in 0..12u64 {
        if k > 0 {
            for i in 0..gap {
                data.push((10.0f64 + i as f64 * 1e-3).to_radians() / rate);
            }
        }
        let start = data.len();
        data.extend(axis(500 + k, per, rate, WHITE, WALK, None));
        intervals.push(start..data.len());
    }
    let a = analyse_axis(&data, 1.0 / rate, &intervals).unwrap();
    let n = a.fit.term(Term::White);
    println!(
        "white {:.5} +- {:.5} deg/h",
        n.value / DEG_H,
        n.sigma / DEG_H
    );
    assert!(((n.value - WHITE) / n.sigma).abs() < 3.0);
    assert!(a.curve.points.last().unwrap().tau_s <= 300.0);
    // The maximum-likelihood fit: one filter per interval, likelihoods added; the white level
    // and the walk within 3 half-widths of their profile intervals.
    let ml = fit_ml(&data, 1.0 / rate, &intervals).expect("ml fit");
    println!(
        "maximum likelihood: white {:.5} [{:.5}, {:.5}] deg/h, walk {:.4} [{:.4}, {:.4}] \
         deg/h/sqrt(h), Gauss-Markov {}",
        ml.white.value / DEG_H,
        ml.white.lower / DEG_H,
        ml.white.upper / DEG_H,
        ml.walk.value / DEG_H * 60.0,
        ml.walk.lower / DEG_H * 60.0,
        ml.walk.upper / DEG_H * 60.0,
        ml.gauss_markov.is_some()
    );
    assert!(ml.white.z(WHITE).abs() < 3.0, "white {:?}", ml.white);
    assert!(ml.walk.z(WALK).abs() < 3.0, "walk {:?}", ml.walk);
    let whole = analyse_axis(&data, 1.0 / rate, &[0..data.len()]).unwrap();
    assert!(whole.curve.points.last().unwrap().adev > 100.0 * WHITE);
}

/// A first-order Gauss-Markov bias (0.05 deg/h, 100 s) on top of the acceptance levels, 4 h
/// at 100 Hz, seed 7: the white level stays within 15 % (the Gauss-Markov process adds little
/// below its correlation time) and the fit reports something between the white and the walk
/// (a bias instability or a larger walk) rather than nothing.
#[test]
fn gauss_markov_bias_leaves_the_white_level() {
    let gm = Some((0.05 * DEG_H, 100.0));
    let data = axis(7, 4 * 3600 * 100, 100.0, WHITE, WALK, gm);
    let f = fit_of(&data, 100.0);
    let n = f.term(Term::White);
    println!(
        "white {:.5} deg/h, instability {:.5} deg/h (included {}), walk {:.5} deg/h/sqrt(h)",
        n.value / DEG_H,
        f.term(Term::BiasInstability).value / DEG_H,
        f.term(Term::BiasInstability).included,
        f.term(Term::RandomWalk).value / DEG_H * 60.0
    );
    assert!((n.value / WHITE - 1.0).abs() < 0.15);
    assert!(
        f.term(Term::BiasInstability).included || f.term(Term::RandomWalk).value > WALK,
        "the Gauss-Markov bias left no trace in the fit"
    );
    // The maximum-likelihood fit has the Gauss-Markov process in its model: it should select
    // it (p < 0.01) and find its deviation and the white level within their intervals' reach.
    let ml = fit_ml(&data, 0.01, &[0..data.len()]).expect("ml fit");
    println!("maximum likelihood: {ml:?}");
    assert!((ml.white.value / WHITE - 1.0).abs() < 0.15);
    let g = ml.gauss_markov.expect("the Gauss-Markov bias selected");
    println!(
        "  Gauss-Markov sigma {:.4} [{:.4}, {:.4}] deg/h (true 0.05), tc {:.0} s (true 100), \
         white z {:+.2}, walk z {:+.2}, sigma z {:+.2}",
        g.sigma.value / DEG_H,
        g.sigma.lower / DEG_H,
        g.sigma.upper / DEG_H,
        g.correlation_time_s,
        ml.white.z(WHITE),
        ml.walk.z(WALK),
        g.sigma.z(0.05 * DEG_H)
    );
}
