//! `sins-calib design` by navigation: every program it evaluates gets the navigation figure
//! its covariance analysis buys (`crate::commands::analyse::figure`); without `--terms`, programs are
//! ranked by it and the best is proposed. The programs: the recorded one, it without each of
//! its parts (the program cut before each `move`: for the paper's program, its three cycles),
//! and the additions of `calib::extend::design`'s menu.

use crate::commands::design::Args;
use crate::navigation::{Flight, Navigation, distance, duration};
use crate::{Error, output, print};
use calib::config::RunConfig;
use calib::extend::design::{Proposal, candidate_programs, evaluate};
use calib::model::extension::ModelExtension;
use std::fmt::Write as _;
use turntable::program::{ProgramSpec, Segment};

/// Figures within this fraction of the best count as equal: the shorter program is proposed.
const EQUAL_WITHIN: f64 = 0.01;

/// The navigation figures of evaluated programs.
pub struct Judged {
    /// What the figures are: "rho after 1 h of the paper's snake".
    pub heading: String,
    /// Each program's figure (m), or why there is none.
    pub rho_m: Vec<Result<f64, String>>,
}

/// The navigation figure of each proposal's posterior under `config` on `flight`.
pub fn judge<'a>(
    config: &RunConfig,
    flight: &Flight,
    proposals: impl IntoIterator<Item = &'a Proposal>,
) -> Judged {
    let figures: Vec<Navigation> = proposals
        .into_iter()
        .map(|p| {
            crate::commands::analyse::figure(config, (&p.posterior, p.duration_s), flight, &[])
        })
        .collect();
    let heading = match figures.first().map(|n| &n.figure) {
        Some(Ok(f)) => format!(
            "rho after {} of {}, docs/navsim.md",
            duration(f.horizon.seconds),
            flight.name()
        ),
        _ => format!("rho on {}", flight.name()),
    };
    Judged {
        heading,
        rho_m: figures
            .into_iter()
            .map(|n| n.figure.map(|f| f.rho_m))
            .collect(),
    }
}

/// A figure for the design's lines.
pub fn rho_text(r: &Result<f64, String>) -> String {
    match r {
        Ok(m) => distance(*m),
        Err(e) => format!("none ({e})"),
    }
}

/// The recorded program without each of its parts, when it has two or more: the parts begin
/// at its `move` segments (the first part at its start).
pub fn without_parts(base: &ProgramSpec) -> Vec<(String, ProgramSpec)> {
    let mut starts: Vec<usize> = vec![0];
    starts.extend(
        base.segments
            .iter()
            .enumerate()
            .filter(|(i, s)| *i > 0 && matches!(s, Segment::Move { .. }))
            .map(|(i, _)| i),
    );
    let n = starts.len();
    if n < 2 {
        return Vec::new();
    }
    (0..n)
        .map(|k| {
            let (a, b) = (
                starts[k],
                starts.get(k + 1).copied().unwrap_or(base.segments.len()),
            );
            let mut p = base.clone();
            p.segments.drain(a..b);
            let what = format!(
                "the recorded program without its part {} of {n} (segments {} to {})",
                k + 1,
                a + 1,
                b
            );
            p.name = format!("{} without part {} of {n}", base.name, k + 1);
            (what, p)
        })
        .collect()
}

/// `design` without `--terms`: the programs ranked by their navigation figure, the best
/// proposed (of figures within [`EQUAL_WITHIN`] of it, the shortest).
pub fn run(args: &Args, config: &RunConfig, flight: &Flight) -> Result<(), Error> {
    let base = config.program_spec()?;
    let mut programs = vec![("the recorded program".to_string(), base.clone())];
    programs.extend(without_parts(&base));
    programs.extend(candidate_programs(&base));
    check_steps(config, &programs)?;
    let ext = ModelExtension::default();
    let mut evaluated = Vec::new();
    for (what, p) in programs {
        evaluated.push(evaluate(config, args.with_turntable, &ext, &[], &what, p)?);
    }
    let judged = judge(config, flight, &evaluated);
    let mut order: Vec<usize> = (0..evaluated.len()).collect();
    let key = |i: usize| judged.rho_m[i].clone().unwrap_or(f64::INFINITY);
    order.sort_by(|&a, &b| key(a).total_cmp(&key(b)));
    let best = key(order[0]);
    let chosen = order
        .iter()
        .copied()
        .filter(|&i| key(i) <= best * (1.0 + EQUAL_WITHIN))
        .min_by(|&a, &b| evaluated[a].duration_s.total_cmp(&evaluated[b].duration_s))
        .unwrap_or(order[0]);
    let mut s = format!(
        "# Programs ranked by the navigation figure they buy ({}; {}):\n",
        judged.heading,
        if args.with_turntable {
            "IMU and turntable angles"
        } else {
            "the IMU alone"
        }
    );
    for (rank, &i) in order.iter().enumerate() {
        let _ = writeln!(
            s,
            "#   {:>2}. {:<84} {:>6.0} s  {}{}",
            rank + 1,
            evaluated[i].description,
            evaluated[i].duration_s,
            rho_text(&judged.rho_m[i]),
            if i == chosen { "  proposed" } else { "" }
        );
    }
    let recorded_rank = order.iter().position(|&i| i == 0).unwrap_or(0) + 1;
    let p = &evaluated[chosen];
    let _ = writeln!(
        s,
        "# The recorded program ranks {recorded_rank} of {}. Proposed: {} ({:.0} s, {}).",
        order.len(),
        p.description,
        p.duration_s,
        rho_text(&judged.rho_m[chosen])
    );
    let toml = format!(
        "# Proposed by `sins-calib design` for navigation: {}\n# Duration {:.0} s; {}: {}\n{}",
        p.description,
        p.duration_s,
        judged.heading,
        rho_text(&judged.rho_m[chosen]),
        toml::to_string(&p.program).unwrap_or_else(|e| format!("# cannot write: {e}\n"))
    );
    s += &toml;
    if let Some(path) = &args.out {
        output::write_file(path, toml.as_bytes())?;
    }
    print(&s)
}

/// Refuse a design whose analyses together would take more IMU steps than an analysis may
/// (`calib::estimate::covariance::MAX_ANALYSIS_STEPS`), before any runs.
fn check_steps(config: &RunConfig, programs: &[(String, ProgramSpec)]) -> Result<(), Error> {
    let mut total_s = 0.0;
    for (what, p) in programs {
        let program = turntable::program::Program::compile(p, "<proposed program>")
            .map_err(|e| format!("the program \"{what}\": {e}"))?;
        total_s += program.duration();
    }
    let rate_hz = config.filter.imu_rate_hz;
    let steps = total_s * rate_hz;
    let max = calib::estimate::covariance::MAX_ANALYSIS_STEPS;
    if !(steps.is_finite() && steps <= max) {
        return Err(format!(
            "program \"{}\": designing runs {} covariance analyses of {total_s} s of programs in \
             all, {steps:.3e} IMU steps at filter.imu_rate_hz = {rate_hz} Hz: expected at most \
             {max:.0e}; design with a shorter program or a lower filter.imu_rate_hz",
            config.program,
            programs.len()
        )
        .into());
    }
    Ok(())
}
