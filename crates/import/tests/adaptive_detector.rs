//! The static detector on simulated hand-turned recordings: short rests of a consumer-grade unit
//! found with the defaults (the window and minimum duration taken from the data), long rests of
//! a navigation-grade unit found as before, and rests too short to use reported as missed.

use calib::motion::detect::{DetectorSettings, MissReason, Segmentation, Source};

/// The detector on the records (given from memory at every reading), checked against the
/// segmentation the code gave before the detector had one implementation, missed stretches and
/// suggestions included, to the last bit (`fixtures/segmentations/NAME.json`; how they were made:
/// `fixtures/README.md`).
fn detect_static(
    name: &str,
    t: &[f64],
    w: &[[f64; 3]],
    f: &[[f64; 3]],
    settings: &DetectorSettings,
) -> Result<Segmentation, String> {
    let seg = calib::motion::detect::detect_static_streamed(
        &mut |visit| {
            for i in 0..t.len() {
                visit(t[i], w[i], f[i]);
            }
            Ok(())
        },
        None,
        settings,
    );
    if let Ok(s) = &seg {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/segmentations")
            .join(format!("{name}.json"));
        let before = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        let now = serde_json::to_string_pretty(s).unwrap() + "\n";
        assert!(now == before, "{name}: not the segmentation of {path:?}");
    }
    seg
}

/// A xorshift stream with Box-Muller normals: fixed seeds, the same recording on every machine.
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn between(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    fn gauss(&mut self) -> f64 {
        let (a, b) = (self.uniform(), self.uniform());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    }
}

/// A recording of rests joined by turns about body axes.
struct Spec {
    rate_hz: f64,
    /// White noise per sample: gyro (rad/s), accelerometer (m/s^2).
    sigma_w: f64,
    sigma_f: f64,
    bias_w: [f64; 3],
    bias_f: [f64; 3],
    /// Duration of every rest (s).
    rests: Vec<f64>,
    /// Range of the turns' durations (s) and angles (deg).
    turn_s: (f64, f64),
    turn_deg: (f64, f64),
    seed: u64,
}

struct Recording {
    t: Vec<f64>,
    w: Vec<[f64; 3]>,
    f: Vec<[f64; 3]>,
    /// The true rests, first and last time at rest (s).
    rests: Vec<(f64, f64)>,
}

type Mat = [[f64; 3]; 3];

fn mul(a: &Mat, b: &Mat) -> Mat {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

/// Rotation by `angle` (rad) about body axis `axis` (0, 1, 2).
fn rotation(axis: usize, angle: f64) -> Mat {
    let (s, c) = angle.sin_cos();
    let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut m = [[0.0; 3]; 3];
    m[axis][axis] = 1.0;
    m[i][i] = c;
    m[j][j] = c;
    m[i][j] = -s;
    m[j][i] = s;
    m
}

/// Rests and turns in turn; every turn has a raised-cosine rate (zero at both ends, as a hand
/// starts and stops), about a body axis taken in turn with a random sign. The specific force in
/// body axes is gravity seen through the attitude; rates and forces carry biases and noise.
fn simulate(spec: &Spec) -> Recording {
    const G: f64 = 9.81;
    let mut rng = Rng(spec.seed);
    let dt = 1.0 / spec.rate_hz;
    // (start, end, turn: Some((axis, angle rad)))
    let mut plan = Vec::new();
    let mut rests = Vec::new();
    let mut t0 = 0.0;
    for (k, &d) in spec.rests.iter().enumerate() {
        plan.push((t0, t0 + d, None));
        rests.push((t0, t0 + d));
        t0 += d;
        if k + 1 < spec.rests.len() {
            let len = rng.between(spec.turn_s.0, spec.turn_s.1);
            let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            let angle = sign * rng.between(spec.turn_deg.0, spec.turn_deg.1).to_radians();
            plan.push((t0, t0 + len, Some((k % 3, angle))));
            t0 += len;
        }
    }
    let rate_at = |tau: f64, len: f64, angle: f64| {
        let tau = tau.clamp(0.0, len);
        angle / len * (1.0 - (2.0 * std::f64::consts::PI * tau / len).cos())
    };
    let mut c_body_to_nav: Mat = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let (mut t, mut w, mut f) = (vec![], vec![], vec![]);
    let mut piece = 0;
    let n = (t0 / dt).floor() as usize;
    for k in 0..=n {
        let tk = k as f64 * dt;
        while piece + 1 < plan.len() && tk >= plan[piece].1 {
            piece += 1;
        }
        let mut wk = [0.0; 3];
        if let (start, end, Some((axis, angle))) = plan[piece] {
            // The attitude over the step, with the rate at its middle.
            let mid = rate_at(tk - 0.5 * dt - start, end - start, angle);
            c_body_to_nav = mul(&c_body_to_nav, &rotation(axis, mid * dt));
            wk[axis] = rate_at(tk - start, end - start, angle);
        }
        // f_body = C^T (0, 0, g).
        let fk: [f64; 3] = std::array::from_fn(|i| c_body_to_nav[2][i] * G);
        t.push(tk);
        w.push(std::array::from_fn(|i| {
            wk[i] + spec.bias_w[i] + spec.sigma_w * rng.gauss()
        }));
        f.push(std::array::from_fn(|i| {
            fk[i] + spec.bias_f[i] + spec.sigma_f * rng.gauss()
        }));
    }
    Recording { t, w, f, rests }
}

/// The consumer-grade recording of the issue: 46 rests of 2 to 3 s at 200 Hz, joined by hand
/// turns of about 90 degrees over about a second.
fn consumer_46() -> Recording {
    let mut rng = Rng(46);
    simulate(&Spec {
        rate_hz: 200.0,
        sigma_w: 0.005,
        sigma_f: 0.02,
        bias_w: [0.01, -0.02, 0.015],
        bias_f: [0.1, -0.05, 0.2],
        rests: (0..46).map(|_| rng.between(2.0, 3.0)).collect(),
        turn_s: (0.8, 1.2),
        turn_deg: (70.0, 110.0),
        seed: 2014,
    })
}

/// Checks that every static interval lies in one true rest, reaching at most `tol` seconds into
/// the turns around it, and that every rest holds exactly one interval.
fn one_per_rest(rec: &Recording, seg: &Segmentation, tol: f64) {
    let mut held = vec![0; rec.rests.len()];
    for s in &seg.static_intervals {
        let k = rec
            .rests
            .iter()
            .position(|&(a, b)| s.start_s >= a - tol && s.end_s <= b + tol)
            .unwrap_or_else(|| panic!("interval {s:?} reaches into a turn"));
        held[k] += 1;
    }
    for (k, h) in held.iter().enumerate() {
        assert_eq!(*h, 1, "rest {k} ({:?}) holds {h} intervals", rec.rests[k]);
    }
}

#[test]
fn forty_six_short_rests_are_all_found_with_the_defaults() {
    let rec = consumer_46();
    let seg = detect_static(
        "consumer_46_defaults",
        &rec.t,
        &rec.w,
        &rec.f,
        &DetectorSettings::default(),
    )
    .unwrap();
    assert_eq!(seg.static_intervals.len(), 46, "{:#?}", seg.adaptation);
    one_per_rest(&rec, &seg, 1e-9);
    // The window and minimum came from the rests: shorter than the fixed 1 s and 2 s.
    let a = &seg.adaptation;
    assert_eq!((a.window, a.min_duration), (Source::Rests, Source::Rests));
    let d = a.typical_rest_s.unwrap();
    assert!((2.0..2.6).contains(&d), "typical rest {d}");
    assert!(seg.settings.window_s < 0.7 && seg.settings.min_duration_s < 1.3);
    // The motion suggests no more rests than were found.
    assert_eq!(seg.motion_events, 45);
    assert!(seg.missed_quiet_stretches.is_empty());
    assert!(seg.missed_report(|s| s.to_string()).is_none());
}

#[test]
fn the_fixed_window_loses_short_rests_and_says_so() {
    // The detector before it adapted (1-s window, 2-s minimum, as given options): the issue's
    // "finds 29 and says nothing". Now it says how many it missed and what would take them.
    let rec = consumer_46();
    let fixed = DetectorSettings {
        adapt_window: false,
        adapt_min_duration: false,
        ..DetectorSettings::default()
    };
    let seg = detect_static("consumer_46_fixed", &rec.t, &rec.w, &rec.f, &fixed).unwrap();
    let found = seg.static_intervals.len();
    assert!(found < 40, "{found}");
    assert_eq!(seg.adaptation.window, Source::Given);
    assert_eq!(seg.motion_events, 45);
    let missed = &seg.missed_quiet_stretches;
    assert_eq!(found + missed.len(), 46, "{missed:#?}");
    // Each missed stretch lies in one true rest that holds no interval.
    for m in missed {
        assert_eq!(m.reason, MissReason::TooShort);
        let k = rec
            .rests
            .iter()
            .position(|&(a, b)| m.start_s >= a - 0.2 && m.end_s <= b + 0.2)
            .unwrap_or_else(|| panic!("{m:?} is not in a rest"));
        let (a, b) = rec.rests[k];
        assert!(
            !seg.static_intervals
                .iter()
                .any(|s| s.end_s >= a && s.start_s <= b)
        );
    }
    let g = seg.missed_suggestion.as_ref().unwrap();
    assert_eq!(g.would_take, missed.len(), "{g:?}");
    assert_eq!(g.static_intervals, 46, "{g:?}");
    let report = seg
        .missed_report(|s| format!("--{}", s.trim_end_matches("_s").replace('_', "-")))
        .unwrap();
    assert!(report[0].contains("45 motion events"), "{report:#?}");
    assert!(
        report[0].contains(&format!("{} quiet stretches", missed.len())),
        "{report:#?}"
    );
    assert!(
        report.last().unwrap().contains("--window")
            && report.last().unwrap().contains("--min-duration"),
        "{report:#?}"
    );
}

#[test]
fn navigation_grade_long_rests_keep_the_fixed_defaults() {
    let mut rng = Rng(19);
    let rec = simulate(&Spec {
        rate_hz: 100.0,
        sigma_w: 2e-5,
        sigma_f: 5e-4,
        bias_w: [1e-6, -2e-6, 5e-7],
        bias_f: [1e-3, -5e-4, 2e-3],
        rests: (0..19).map(|_| rng.between(30.0, 60.0)).collect(),
        turn_s: (3.0, 6.0),
        turn_deg: (80.0, 100.0),
        seed: 7,
    });
    let seg = detect_static(
        "navigation_defaults",
        &rec.t,
        &rec.w,
        &rec.f,
        &DetectorSettings::default(),
    )
    .unwrap();
    assert_eq!(seg.static_intervals.len(), 19);
    // The slow ends of a turn of several seconds (a raised-cosine rate stays below the 0.1-rad/s
    // and 0.05-rad/s thresholds for about half a second) pass for rest at the fixed thresholds,
    // as they did before the window adapted: the intervals may reach that far into a turn.
    one_per_rest(&rec, &seg, 0.6);
    let a = &seg.adaptation;
    assert_eq!(
        (a.window, a.min_duration),
        (Source::Default, Source::Default)
    );
    assert!(a.typical_rest_s.unwrap() > 25.0);
    assert_eq!(
        (seg.settings.window_s, seg.settings.min_duration_s),
        (1.0, 2.0)
    );
    // Exactly what the fixed settings give.
    let fixed = DetectorSettings {
        adapt_window: false,
        adapt_min_duration: false,
        ..DetectorSettings::default()
    };
    let before = detect_static("navigation_fixed", &rec.t, &rec.w, &rec.f, &fixed).unwrap();
    assert_eq!(before.static_intervals, seg.static_intervals);
    assert_eq!(seg.motion_events, 18);
    assert!(seg.missed_quiet_stretches.is_empty());
}

#[test]
fn rests_too_short_to_use_are_named_in_the_report() {
    // Twelve rests of 6 to 8 s and three pauses of 1.2 s (the 4th, 8th and 12th rest): the
    // long rests set the window (1 s) and minimum (2 s), which the pauses cannot pass.
    let mut rng = Rng(3);
    let short = [3, 7, 11];
    let rests: Vec<f64> = (0..15)
        .map(|k| {
            if short.contains(&k) {
                1.2
            } else {
                rng.between(6.0, 8.0)
            }
        })
        .collect();
    let rec = simulate(&Spec {
        rate_hz: 200.0,
        sigma_w: 0.005,
        sigma_f: 0.02,
        bias_w: [0.01, -0.02, 0.015],
        bias_f: [0.1, -0.05, 0.2],
        rests,
        turn_s: (0.8, 1.2),
        turn_deg: (70.0, 110.0),
        seed: 11,
    });
    let seg = detect_static(
        "too_short_defaults",
        &rec.t,
        &rec.w,
        &rec.f,
        &DetectorSettings::default(),
    )
    .unwrap();
    assert_eq!(
        (seg.settings.window_s, seg.settings.min_duration_s),
        (1.0, 2.0)
    );
    assert_eq!(seg.static_intervals.len(), 12);
    assert_eq!(seg.motion_events, 14);
    let missed = &seg.missed_quiet_stretches;
    assert_eq!(missed.len(), 3, "{missed:#?}");
    for (m, &k) in missed.iter().zip(&short) {
        let (a, b) = rec.rests[k];
        assert!(
            m.start_s >= a - 0.2 && m.end_s <= b + 0.2,
            "{m:?} not in {a} .. {b}"
        );
        assert_eq!(m.reason, MissReason::TooShort);
    }
    let g = seg.missed_suggestion.as_ref().unwrap();
    assert_eq!((g.would_take, g.static_intervals), (3, 15), "{g:?}");
    let report = seg.missed_report(|s| format!("<{s}>")).unwrap();
    assert!(report[0].contains("14 motion events, 12 static intervals; 3 quiet stretches"));
    assert!(report[1].contains("3 too short for a 1-s window and 2-s minimum"));
    // The report names each stretch by its times.
    for m in missed {
        assert!(report[2].contains(&format!("{:.2} .. {:.2}", m.start_s, m.end_s)));
    }
    assert!(report[3].contains("<window_s>") && report[3].contains("would take 3 of them"));
}

#[test]
fn a_given_window_and_minimum_are_used_as_given() {
    let rec = consumer_46();
    let given = DetectorSettings {
        window_s: 0.5,
        min_duration_s: 1.0,
        adapt_window: false,
        adapt_min_duration: false,
        ..DetectorSettings::default()
    };
    let seg = detect_static("consumer_46_given", &rec.t, &rec.w, &rec.f, &given).unwrap();
    assert_eq!(
        (seg.settings.window_s, seg.settings.min_duration_s),
        (0.5, 1.0)
    );
    assert_eq!(seg.window_records, 101);
    let a = &seg.adaptation;
    assert_eq!((a.window, a.min_duration), (Source::Given, Source::Given));
    // Only one of the two given: the other still adapts.
    let half = DetectorSettings {
        window_s: 0.5,
        adapt_window: false,
        ..DetectorSettings::default()
    };
    let seg = detect_static("consumer_46_given_window", &rec.t, &rec.w, &rec.f, &half).unwrap();
    assert_eq!(seg.adaptation.window, Source::Given);
    assert_eq!(seg.adaptation.min_duration, Source::Rests);
}
