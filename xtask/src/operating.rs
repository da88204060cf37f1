//! `cargo xtask operating-characteristic`: the verdict's false-alarm and detection rates per
//! class of run, effect and size, as the table of docs/verdict.md
//! (`workspace_tests::operating`). Seeds are fixed: clean runs 1001, 1002, ...; the runs of
//! every effect row 2001, 2002, ...

use std::process::ExitCode;
use workspace_tests::operating::{
    Class, Power, Row, binomial_interval, count, power, sized_values,
};

/// The base-parameter shifts (sigmas) the effect rows are sized to.
const SIZES: [f64; 3] = [1.0, 3.0, 10.0];

/// The targets: at most this false-alarm rate per class.
const MAX_FALSE_ALARM: f64 = 0.05;
/// At 10 sigma, at least this detection rate per effect.
const MIN_DETECTION_AT_10: f64 = 0.95;

fn rate(k: usize, n: usize) -> String {
    let (lo, hi) = binomial_interval(k, n);
    format!(
        "{k}/{n} = {:.1} % [{:.1}, {:.1}]",
        100.0 * k as f64 / n.max(1) as f64,
        100.0 * lo,
        100.0 * hi
    )
}

/// Run `clean` clean runs and `effect_runs` runs per effect and size for every class (or
/// those whose name contains `only`); print the table; non-zero exit when a target is missed.
pub fn operating_characteristic(clean: usize, effect_runs: usize, only: Option<&str>) -> ExitCode {
    println!(
        "| class | effect | size (base shift) | runs | exit 3 | exit 3 naming the term, or carried | exit 0 at >= 10 sigma: term named nowhere / as a blind spot | score test: non-centrality (dof); predicted power of the verdict's test / of the best test at 1 % |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut missed = Vec::new();
    for class in Class::ALL
        .into_iter()
        .filter(|c| only.is_none_or(|o| c.name().contains(o)))
    {
        let row = count(class, None, &[], 1001, clean);
        print_row(class.name(), "none (clean)", "-", &row, None);
        eprintln!(
            "{}: clean runs exiting 3: seeds {:?}",
            class.name(),
            row.odd_seeds
        );
        if (row.exit3 as f64) > MAX_FALSE_ALARM * row.runs as f64 {
            missed.push(format!(
                "{}: false alarms {}",
                class.name(),
                rate(row.exit3, row.runs)
            ));
        }
        for term in class.effects() {
            for k in SIZES {
                let (values, z_ref) = sized_values(class, term, k);
                let row = count(class, Some(term), &values, 2001, effect_runs);
                let power = power(class, term, &values);
                print_row(
                    class.name(),
                    term.id(),
                    &format!("{k} sigma (z_ref {z_ref:.3e})"),
                    &row,
                    power,
                );
                if !row.odd_seeds.is_empty() {
                    eprintln!(
                        "{} / {} / {k} sigma: not named on seeds {:?}",
                        class.name(),
                        term.id(),
                        row.odd_seeds
                    );
                }
                if k >= 10.0 && (row.named as f64) < MIN_DETECTION_AT_10 * row.runs as f64 {
                    missed.push(format!(
                        "{} / {}: detection at 10 sigma {}{}",
                        class.name(),
                        term.id(),
                        rate(row.named, row.runs),
                        feasibility(power)
                    ));
                }
                if row.silent_10_sigma > 0 {
                    missed.push(format!(
                        "{} / {} / {k} sigma: {} runs exit 0 with a base parameter 10 sigma off and \
                         the term named nowhere",
                        class.name(),
                        term.id(),
                        row.silent_10_sigma
                    ));
                }
            }
        }
    }
    if missed.is_empty() {
        println!("\nevery target met");
        ExitCode::SUCCESS
    } else {
        println!("\ntargets missed:\n  {}", missed.join("\n  "));
        ExitCode::FAILURE
    }
}

/// Whether the detection target was within reach of any test at 1 % ([`Power::best_test`]).
fn feasibility(power: Option<Power>) -> String {
    match power {
        Some(p) if p.best_test < MIN_DETECTION_AT_10 => format!(
            "; beyond any test at 1 %: the best test, knowing the effect, detects it in {:.1} % \
             (non-centrality {:.3})",
            100.0 * p.best_test,
            p.noncentrality
        ),
        Some(p) => format!(
            "; within reach: the best test at 1 % detects it in {:.1} %, the verdict's own test \
             predicted {:.1} %",
            100.0 * p.best_test,
            100.0 * p.verdict_test
        ),
        None => String::new(),
    }
}

fn print_row(class: &str, effect: &str, size: &str, row: &Row, power: Option<Power>) {
    let power = power.map_or("-".to_string(), |p| {
        format!(
            "{:.3} ({}); {:.1} % / {:.1} %",
            p.noncentrality,
            p.dof,
            100.0 * p.verdict_test,
            100.0 * p.best_test
        )
    });
    println!(
        "| {class} | {effect} | {size} | {} | {} | {} | {} / {} | {power} |",
        row.runs,
        rate(row.exit3, row.runs),
        rate(row.named, row.runs),
        row.silent_10_sigma,
        row.blind_10_sigma
    );
}
