//! Project automation: `cargo xtask paper-check` reproduces the paper's tables; `cargo xtask
//! docs-check` runs the documentation's commands and compares their output with the documents;
//! `cargo xtask audit` runs every command on hostile inputs and classifies the outcomes.

#![forbid(unsafe_code)]

use calib::config::{NoiseReading, RunConfig};
use calib::estimate::covariance::{Posterior, covariance_analysis};
use calib::report::{COLUMNS, PaperTable};
use clap::{Parser, Subcommand};
use serde_json::{Map, Value, json};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod audit;
mod bounds;
mod docs_check;
mod hidden;
mod operating;
mod plot;
mod structure;

/// The paper's navigation figures after 1 h of the snake flight (m).
const PAPER_RHO_IMU_ONLY_M: f64 = sins_model::paper::RHO_IMU_ONLY_M;
const PAPER_RHO_WITH_TURNTABLE_M: f64 = sins_model::paper::RHO_WITH_TURNTABLE_M;

#[derive(Parser)]
#[command(
    name = "xtask",
    about = "Project automation for the SINS turntable-calibration toolkit"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Reproduce the paper's two covariance tables (IMU only; with turntable angles) with the
    /// literal and the reconciled configuration, and check every reconciled entry is within 0.5 to
    /// 2 times the paper's value. Exits non-zero otherwise.
    PaperCheck {
        /// Also write the tables as JSON to this path.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Where to write the plot of rho(t) for both calibrations.
        #[arg(long, default_value = "target/paper-check/rho.png")]
        plot: PathBuf,
        /// Configuration checked against the paper: `paper-reconciled` (embedded default),
        /// `paper` (literal reading) or a path to a run TOML.
        #[arg(long, default_value = "paper-reconciled")]
        config: String,
    },
    /// Print the sensitivity sweeps behind docs/paper-check.md: which assumption moves which entry.
    PaperSweep,
    /// Print the navigation error budget of both calibrations and the sweeps behind
    /// docs/navsim.md (correlations kept or dropped, the paper's diagonal tables, sensor noise).
    NavBudget,
    /// The navigation position error after 1 h of the default snake flight (docs/navsim.md)
    /// that a calibration result buys: its sigmas and its posterior correlations (the
    /// `correlation` block of the result file), and its sigmas alone for comparison.
    NavError {
        /// Result file of `sins-calib calibrate --json` (parameters with sigmas; correlation).
        #[arg(long)]
        result: PathBuf,
    },
    /// Run every hidden-effect case of the model-extension loop and the negative control, and
    /// print the table of docs/model-extension.md (effect, accepted term, estimate against
    /// truth, gain). Exits non-zero when a case fails its checks.
    HiddenEffects {
        /// Seeds of the negative control (101, 102, ...).
        #[arg(long, default_value_t = 20)]
        control_seeds: u64,
        /// Run only the case of this name (e.g. "size effect").
        #[arg(long)]
        case: Option<String>,
    },
    /// The verdict's operating characteristic: false-alarm rate on clean simulated runs and
    /// detection rate of every candidate term at sizes that move a base parameter by 1, 3 and
    /// 10 sigma, per class of run, with binomial intervals (docs/verdict.md). Exits non-zero
    /// when a target is missed (false alarms above 5 %, detection at 10 sigma below 95 %, an
    /// exit 0 with a base parameter 10 sigma off and the term named nowhere, not even as a
    /// blind spot).
    OperatingCharacteristic {
        /// Clean runs per class (seeds 1001, 1002, ...).
        #[arg(long, default_value_t = 100)]
        clean: usize,
        /// Runs per effect and size (seeds 2001, 2002, ...).
        #[arg(long, default_value_t = 20)]
        effect_runs: usize,
        /// Only the classes whose name contains this (e.g. "rests").
        #[arg(long)]
        class: Option<String>,
    },
    /// Run every `sh` block (and untagged block that is a command) of README.md and the .md
    /// files under docs/ as written (sins-calib: the release binary; from a temporary copy of
    /// the repository; /tmp/ redirected) and compare the `text` and untagged blocks after each
    /// with its output (excerpt rule: xtask/src/docs_check.rs); an untagged block after no
    /// command fails.
    /// Ends with `docs-check: N passed, M failed, K skipped`; exits non-zero on a failure.
    DocsCheck {
        /// Check only these files (paths relative to the repository, e.g. README.md).
        files: Vec<String>,
        /// Keep the temporary working copies (their path is printed).
        #[arg(long)]
        keep: bool,
        /// Files checked at the same time (each in its own working copy).
        #[arg(long, default_value_t = 2)]
        jobs: usize,
    },
    /// Run every command of sins-calib on the hostile inputs of xtask/audit/cases.toml (absurd
    /// numbers, devices and huge files as inputs, wrong units, bad output paths, closed
    /// standard output), classify each run (panic/abort, silent success, late refusal, damaged
    /// output, unclear error, refused good input, ok) and print the count per class. Exits
    /// non-zero when a run is not ok.
    Audit {
        /// Run only the cases whose name contains this.
        #[arg(long)]
        case: Option<String>,
        /// Keep the temporary directory of the cases (its path is printed).
        #[arg(long)]
        keep: bool,
        /// Print every case, not only those that are not ok.
        #[arg(long)]
        verbose: bool,
        /// Audit this sins-calib binary instead of building the workspace's (e.g. an earlier
        /// build, to compare the counts).
        #[arg(long)]
        bin: Option<PathBuf>,
    },
    /// The shape of the code, from the sources: functions over 100 lines in crates/*/src, the
    /// entries at the top of crates/calib/src (at most 12), module cycles in calib (between its
    /// rooms, and between sibling files of a room). Exits non-zero when a bound is broken.
    Structure,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::PaperCheck { json, config, plot } => paper_check(json, &config, &plot),
        Command::PaperSweep => {
            paper_sweep();
            ExitCode::SUCCESS
        }
        Command::HiddenEffects {
            control_seeds,
            case,
        } => hidden::hidden_effects(control_seeds, case.as_deref()),
        Command::OperatingCharacteristic {
            clean,
            effect_runs,
            class,
        } => operating::operating_characteristic(clean, effect_runs, class.as_deref()),
        Command::DocsCheck { files, keep, jobs } => docs_check::docs_check(&files, keep, jobs),
        Command::Audit {
            case,
            keep,
            verbose,
            bin,
        } => audit::audit(case.as_deref(), keep, verbose, bin.as_deref()),
        Command::Structure => {
            let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
            match structure::run(&root) {
                Ok(true) => ExitCode::SUCCESS,
                Ok(false) => ExitCode::FAILURE,
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Command::NavError { result } => match nav_error(&result) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
        Command::NavBudget => match nav_budget() {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
    }
}

/// Both tables (IMU only, with turntable) for a configuration, run in parallel.
fn both_tables(config: &RunConfig) -> Result<(Posterior, Posterior), String> {
    std::thread::scope(|s| {
        let a = s.spawn(|| covariance_analysis(config, false));
        let b = s.spawn(|| covariance_analysis(config, true));
        let a = a
            .join()
            .map_err(|_| "analysis thread panicked".to_string())?;
        let b = b
            .join()
            .map_err(|_| "analysis thread panicked".to_string())?;
        Ok((a.map_err(|e| e.to_string())?, b.map_err(|e| e.to_string())?))
    })
}

fn table_json(t: &PaperTable, p: &Posterior, literal: &PaperTable) -> Value {
    let mut m = Map::new();
    for ((name, _), v) in COLUMNS.iter().zip(t.values()) {
        m.insert(name.to_string(), json!(v));
    }
    let mut lit = Map::new();
    for ((name, _), v) in COLUMNS.iter().zip(literal.values()) {
        lit.insert(name.to_string(), json!(v));
    }
    m.insert("literal".into(), Value::Object(lit));
    let mut per = Map::new();
    for (i, name) in p.names.iter().enumerate() {
        per.insert(
            name.clone(),
            json!({"sigma_si": p.cov[(i, i)].max(0.0).sqrt(), "unit_si": p.units[i].si_name()}),
        );
    }
    m.insert("per_parameter".into(), Value::Object(per));
    Value::Object(m)
}

/// The instrument block (gyro.*, accel.*) of a calibration posterior, for navigation.
fn instrument_covariance(p: &Posterior) -> Result<navsim::InstrumentCovariance, String> {
    let idx: Vec<usize> = (0..p.names.len())
        .filter(|&i| p.names[i].starts_with("gyro.") || p.names[i].starts_with("accel."))
        .collect();
    let names = idx.iter().map(|&i| p.names[i].clone()).collect();
    let cov = nalgebra::DMatrix::from_fn(idx.len(), idx.len(), |a, b| p.cov[(idx[a], idx[b])]);
    navsim::InstrumentCovariance::new(names, cov).map_err(|e| e.to_string())
}

/// rho(t) over the default snake flight for an instrument covariance.
fn navigation(cov: &navsim::InstrumentCovariance) -> Result<navsim::RhoSeries, String> {
    let traj = navsim::SnakeTrajectory::new(&navsim::SnakeConfig::default_config())
        .map_err(|e| e.to_string())?;
    navsim::rho_series(&traj, cov, &navsim::NavOptions::default()).map_err(|e| e.to_string())
}

/// The navigation check: rho after 1 h for both calibrations; returns (pass, json).
fn navigation_check(rec: &(Posterior, Posterior), plot_path: &Path) -> (bool, Value) {
    let runs = [&rec.0, &rec.1].map(|p| instrument_covariance(p).and_then(|c| navigation(&c)));
    let paper_rows = [
        navsim::InstrumentCovariance::paper_without_turntable(),
        navsim::InstrumentCovariance::paper_with_turntable(),
    ]
    .map(|c| navigation(&c));
    let (a, b) = match runs {
        [Ok(a), Ok(b)] => (a, b),
        [a, b] => {
            let e = a.err().or(b.err()).unwrap_or_default();
            println!("navigation: error: {e}");
            return (false, Value::Null);
        }
    };
    let (ra, rb) = (a.final_rho_m(), b.final_rho_m());
    println!(
        "\nNavigation after 1 h of the snake flight (docs/navsim.md): rho = a sqrt(s2(dLambda cos phi) + s2(dPhi))"
    );
    println!(
        "{:<32} {:>8} {:>10} {:>7} {:>22}",
        "calibration", "paper m", "ours m", "ratio", "paper's table rows, m"
    );
    let pr: Vec<f64> = paper_rows
        .iter()
        .map(|r| r.as_ref().map_or(f64::NAN, |r| r.final_rho_m()))
        .collect();
    println!(
        "{:<32} {:>8.0} {:>10.0} {:>7.2} {:>22.0}",
        "without turntable angles",
        PAPER_RHO_IMU_ONLY_M,
        ra,
        ra / PAPER_RHO_IMU_ONLY_M,
        pr[0]
    );
    println!(
        "{:<32} {:>8.0} {:>10.0} {:>7.2} {:>22.0}",
        "with turntable angles",
        PAPER_RHO_WITH_TURNTABLE_M,
        rb,
        rb / PAPER_RHO_WITH_TURNTABLE_M,
        pr[1]
    );
    let improvement = ra / rb;
    println!(
        "improvement: ours {improvement:.2} times, paper {:.2} times",
        PAPER_RHO_IMU_ONLY_M / PAPER_RHO_WITH_TURNTABLE_M
    );
    let within = (ra / PAPER_RHO_IMU_ONLY_M - 1.0).abs() <= 0.35;
    let improves = improvement >= 1.3;
    println!(
        "  {} IMU-only figure within 35% of 1900 m",
        if within { "yes:" } else { "NO: " }
    );
    println!(
        "  {} turntable angles improve it at least 1.3 times",
        if improves { "yes:" } else { "NO: " }
    );
    if let Some(dir) = plot_path.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    match plot::plot_rho_png(
        plot_path,
        "Navigation error after calibration (snake flight)",
        &[
            ("without turntable angles", &a.t, &a.rho_m),
            ("with turntable angles", &b.t, &b.rho_m),
        ],
    ) {
        Ok(()) => println!("plot of rho(t): {}", plot_path.display()),
        Err(e) => println!("plot of rho(t) not written: {e}"),
    }
    (
        within && improves,
        json!({"imu_only_m": ra, "with_turntable_m": rb}),
    )
}

fn paper_check(json_path: Option<PathBuf>, config_name: &str, plot_path: &Path) -> ExitCode {
    if json_path.as_deref() == Some(Path::new("-")) {
        // The tables go to standard output: the JSON would be mixed into them (and a file named
        // `-` is no one's wish).
        eprintln!(
            "error: --json -: paper-check prints its tables to standard output; give a file \
             for the JSON (e.g. --json target/paper-check.json)"
        );
        return ExitCode::FAILURE;
    }
    let checked = match calib::paper::named_or_file(config_name) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let literal = calib::paper::literal();
    let t0 = std::time::Instant::now();
    let (Ok(lit), Ok(rec)) = (both_tables(&literal), both_tables(&checked)) else {
        eprintln!("error: covariance analysis failed");
        return ExitCode::FAILURE;
    };
    let elapsed = t0.elapsed().as_secs_f64();
    let (mut ok, out) = print_tables(&lit, &rec, config_name);
    ok &= conclusions_hold(&rec, config_name);
    let (nav_ok, nav_json) = navigation_check(&rec, plot_path);
    ok &= nav_ok;
    println!(
        "\nliteral = configs/paper.toml, {config_name} = {}; see docs/paper-check.md ({elapsed:.1} s)",
        if config_name == "paper-reconciled" {
            "configs/paper-reconciled.toml (crates/calib)"
        } else {
            config_name
        }
    );
    if let Some(path) = json_path {
        let doc = json!({
            "schema": calib::io::schema::Schema::current(calib::io::schema::PAPER_CHECK),
            "tables": Value::Object(out),
            "navigation": nav_json,
        });
        if let Err(e) = std::fs::write(&path, serde_json::to_string_pretty(&doc).unwrap() + "\n") {
            eprintln!("error: {}: cannot write: {e}", path.display());
            return ExitCode::FAILURE;
        }
        println!("wrote {}", path.display());
    }
    if ok {
        println!("paper-check: PASS");
        ExitCode::SUCCESS
    } else {
        println!("paper-check: FAIL");
        ExitCode::FAILURE
    }
}

/// Both of the paper's tables beside the literal reading's and the checked configuration's,
/// printed; whether every checked entry is within 0.5 to 2 times the paper's, and the tables as
/// JSON.
fn print_tables(
    lit: &(Posterior, Posterior),
    rec: &(Posterior, Posterior),
    config_name: &str,
) -> (bool, Map<String, Value>) {
    let mut ok = true;
    let mut out = Map::new();
    for (key, title, paper, lit_p, rec_p) in [
        (
            "imu_only",
            "Without the turntable angles (24 states)",
            sins_model::paper::TABLE_IMU_ONLY,
            &lit.0,
            &rec.0,
        ),
        (
            "with_turntable",
            "With the turntable angles (28 states)",
            sins_model::paper::TABLE_WITH_TURNTABLE,
            &lit.1,
            &rec.1,
        ),
    ] {
        let tl = calib::report::paper_table(lit_p);
        let tr = calib::report::paper_table(rec_p);
        println!("\n{title}: largest posterior sigma of each group");
        println!(
            "{:<17} {:>7} {:>10} | {:>10} {:>6} | {:>10} {:>6}",
            "entry", "unit", "paper", "literal", "ratio", config_name, "ratio"
        );
        for (((name, unit), p), (l, r)) in COLUMNS
            .iter()
            .zip(paper.values())
            .zip(tl.values().into_iter().zip(tr.values()))
        {
            let ratio = r / p;
            let pass = (0.5..=2.0).contains(&ratio);
            ok &= pass;
            println!(
                "{name:<17} {unit:>7} {p:>10.3e} | {l:>10.3e} {:>6.2} | {r:>10.3e} {ratio:>6.2} {}",
                l / p,
                if pass { "ok" } else { "OUT OF [0.5, 2]" }
            );
        }
        if let (Some(d), Some(tau)) = (rec_p.sigma("install.delta.x"), rec_p.sigma("turntable.tau"))
        {
            let dmax = ["x", "y", "z"]
                .iter()
                .filter_map(|a| rec_p.sigma(&format!("install.delta.{a}")))
                .fold(d, f64::max);
            println!(
                "  also estimated: installation misalignment delta_z {:.3} arcsec, delay tau {:.2e} s",
                dmax / sins_model::units::ARCSEC,
                tau
            );
        }
        out.insert(key.into(), table_json(&tr, rec_p, &tl));
    }
    (ok, out)
}

/// The paper's qualitative conclusions, checked on the tables of `rec` (printed).
fn conclusions_hold(rec: &(Posterior, Posterior), config_name: &str) -> bool {
    let mut ok = true;
    let (a, b) = (
        calib::report::paper_table(&rec.0),
        calib::report::paper_table(&rec.1),
    );
    let conclusions = [
        (
            "turntable angles improve the gyro bias",
            b.nu0_deg_h < 0.9 * a.nu0_deg_h,
        ),
        (
            "turntable angles improve the gyro scale factors",
            b.theta_ii < 0.9 * a.theta_ii,
        ),
        (
            "turntable angles improve the gyro cross-axis terms",
            b.theta_ij_arcmin < 0.9 * a.theta_ij_arcmin,
        ),
        (
            "accelerometer scale factors stay where they are",
            (b.gamma_ii / a.gamma_ii - 1.0).abs() < 0.05,
        ),
    ];
    println!("\nThe paper's conclusions, with {config_name}:");
    for (what, holds) in conclusions {
        ok &= holds;
        println!("  {} {what}", if holds { "yes:" } else { "NO: " });
    }
    ok
}

/// One sweep row: ratios ours/paper of both tables.
fn sweep_row(label: &str, config: &RunConfig) {
    match both_tables(config) {
        Ok((a, b)) => {
            let ra = calib::report::paper_table(&a).values();
            let rb = calib::report::paper_table(&b).values();
            let pa = sins_model::paper::TABLE_IMU_ONLY.values();
            let pb = sins_model::paper::TABLE_WITH_TURNTABLE.values();
            print!("| {label:<34} |");
            for i in 0..6 {
                print!(" {:.2}", ra[i] / pa[i]);
            }
            print!(" |");
            for i in 0..6 {
                print!(" {:.2}", rb[i] / pb[i]);
            }
            println!(" |");
        }
        Err(e) => println!("| {label} | error: {e} |"),
    }
}

fn paper_sweep() {
    let header = || {
        println!(
            "| assumption | IMU only: nu0 Tii Tij df0 Gii Gij | with turntable: nu0 Tii Tij df0 Gii Gij |"
        );
        println!("|---|---|---|");
    };
    let lit = calib::paper::literal();
    let rec = calib::paper::reconciled();
    println!(
        "Ratios ours/paper. literal = configs/paper.toml, reconciled = configs/paper-reconciled.toml.\n"
    );
    println!("### 1. Initial heading prior (literal otherwise)\n");
    header();
    for h_arcmin in [60.0, 30.0, 12.0, 6.0, 3.0, 1.0] {
        let mut c = lit.clone();
        c.priors.initial_heading_deg = h_arcmin / 60.0;
        sweep_row(&format!("heading sigma {h_arcmin} arcmin"), &c);
    }
    println!(
        "\n### 2. Specific-force measurement: one 1-Hz sample every T s (reconciled otherwise)\n"
    );
    header();
    for t in [1.0, 4.0, 8.0, 16.0, 20.0, 32.0] {
        let mut c = rec.clone();
        c.noise.reading = NoiseReading::Sample;
        c.filter.accel_rate_hz = 1.0 / t;
        sweep_row(&format!("sample every {t} s"), &c);
    }
    println!(
        "\n### 3. The same information as a noise level: averaged reading at 1 Hz (reconciled heading)\n"
    );
    header();
    for k in [1.0, 2.0, 4.0, 8.0] {
        let mut c = rec.clone();
        c.noise.reading = NoiseReading::Average;
        c.filter.accel_rate_hz = 1.0;
        c.noise.accel_m_s2 = 0.001 * k;
        sweep_row(&format!("accel noise {} m/s^2 at 1 Hz", 0.001 * k), &c);
    }
    println!(
        "\n### 4. Averaged reading: the measurement rate does not matter (literal otherwise)\n"
    );
    header();
    for r in [0.1, 1.0, 10.0] {
        let mut c = lit.clone();
        c.filter.accel_rate_hz = r;
        c.filter.turntable_rate_hz = r;
        sweep_row(&format!("accel and turntable at {r} Hz"), &c);
    }
    println!("\n### 5. Other assumptions, each alone on the reconciled configuration\n");
    header();
    sweep_row("reconciled", &rec);
    let mut c = rec.clone();
    c.priors.initial_tilt_deg = 0.05;
    sweep_row("tilt sigma 3 arcmin (1 deg)", &c);
    let mut c = rec.clone();
    c.site.latitude_deg = 0.0;
    sweep_row("latitude 0 deg (55.7)", &c);
    let mut c = rec.clone();
    c.site.latitude_deg = 70.0;
    sweep_row("latitude 70 deg (55.7)", &c);
    let mut c = rec.clone();
    c.noise.angle_arcsec = 30.0;
    sweep_row("angle noise 30 arcsec (15)", &c);
    let mut c = rec.clone();
    c.filter.turntable_rate_hz = 0.0625;
    sweep_row("turntable sample every 16 s (1 s)", &c);
    let mut c = rec.clone();
    c.filter.imu_rate_hz = 20.0;
    sweep_row("IMU sub-steps at 20 Hz (100)", &c);
    let mut c = rec.clone();
    c.priors.install_misalignment_deg = 0.1;
    sweep_row("delta_z prior 0.1 deg (1)", &c);
    let mut c = rec.clone();
    c.priors.tau_s = 0.005;
    sweep_row("tau prior 5 ms (50)", &c);
    let mut c = rec.clone();
    c.filter.estimate_base_misalignment = true;
    sweep_row("estimate gamma_p, 10 arcsec prior", &c);
}

/// The instrument covariance of a result file: the parameters navigation models (the paper's
/// 21 and those of the candidate terms the result estimated, `navsim::InstrumentModel`), their
/// sigmas and, when `correlations` and the file has them, their correlations (else diagonal).
/// Also the names left out (names navigation does not know; the turntable's and mounting
/// terms, which do not act on navigation, are not listed).
fn result_covariance(
    result: &calib::io::ResultFile,
    file: &str,
    correlations: bool,
) -> Result<(navsim::InstrumentCovariance, Vec<String>), String> {
    let model =
        navsim::InstrumentModel::for_names(result.parameters.iter().map(|p| p.name.as_str()));
    let mut idx = Vec::new();
    let mut left_out = Vec::new();
    for (i, p) in result.parameters.iter().enumerate() {
        if model.names().contains(&p.name) {
            idx.push(i);
        } else if !navsim::instruments::IGNORED_PREFIXES
            .iter()
            .any(|x| p.name.starts_with(x))
        {
            left_out.push(p.name.clone());
        }
    }
    let mut sigmas = Vec::with_capacity(idx.len());
    for &i in &idx {
        let p = &result.parameters[i];
        sigmas.push(p.sigma.ok_or_else(|| {
            format!(
                "{file}: parameter `{}` has no sigma: expected a calibration result (a truth \
                 file has none)",
                p.name
            )
        })?);
    }
    let names: Vec<String> = idx
        .iter()
        .map(|&i| result.parameters[i].name.clone())
        .collect();
    let correlation: Vec<Vec<f64>> = match (&result.correlation, correlations) {
        (Some(r), true) => idx
            .iter()
            .map(|&i| idx.iter().map(|&j| r[i][j]).collect())
            .collect(),
        _ => (0..idx.len())
            .map(|i| {
                (0..idx.len())
                    .map(|j| if i == j { 1.0 } else { 0.0 })
                    .collect()
            })
            .collect(),
    };
    let cov =
        navsim::InstrumentCovariance::from_sigmas_and_correlation(names, &sigmas, &correlation)
            .map_err(|e| format!("{file}: {e}"))?;
    Ok((cov, left_out))
}

/// rho after 1 h of the default snake flight (m) from a result file, with or without its
/// correlations.
fn nav_error_m(
    result: &calib::io::ResultFile,
    file: &str,
    correlations: bool,
) -> Result<f64, String> {
    let (cov, _) = result_covariance(result, file, correlations)?;
    navigation(&cov)
        .map(|r| r.final_rho_m())
        .map_err(|e| format!("{file}: {e}"))
}

fn nav_error(path: &Path) -> Result<(), String> {
    let file = path.display().to_string();
    let result = calib::io::read_result_json(path).map_err(|e| e.to_string())?;
    let (_, left_out) = result_covariance(&result, &file, false)?;
    println!(
        "navigation error rho after 1 h of the default snake flight (docs/navsim.md), from {file}"
    );
    match result.correlation {
        Some(_) => println!(
            "  sigmas and posterior correlations  {:8.0} m",
            nav_error_m(&result, &file, true)?
        ),
        None => println!("  (the file has no `correlation` block: sigmas only)"),
    }
    println!(
        "  sigmas alone, correlations dropped {:8.0} m",
        nav_error_m(&result, &file, false)?
    );
    if !left_out.is_empty() {
        println!(
            "  left out (names navigation does not know): {}",
            left_out.join(", ")
        );
    }
    Ok(())
}

/// The covariance with its off-diagonal elements dropped.
fn diagonal_only(c: &navsim::InstrumentCovariance) -> navsim::InstrumentCovariance {
    let d = nalgebra::DMatrix::from_diagonal(&c.cov.diagonal());
    navsim::InstrumentCovariance::new(c.names.clone(), d).expect("a diagonal covariance is valid")
}

/// Every parameter of a group at the group's largest sigma (how the paper's tables read).
fn group_max_diagonal(c: &navsim::InstrumentCovariance) -> navsim::InstrumentCovariance {
    let g = calib::report::Groups::new();
    let mut d = nalgebra::DMatrix::zeros(c.names.len(), c.names.len());
    for group in [
        &g.nu0,
        &g.theta_ii,
        &g.theta_ij,
        &g.df0,
        &g.gamma_ii,
        &g.gamma_ij,
    ] {
        let idx: Vec<usize> = group
            .iter()
            .filter_map(|n| c.names.iter().position(|m| m == n))
            .collect();
        let v = idx.iter().map(|&i| c.cov[(i, i)]).fold(0.0, f64::max);
        for i in idx {
            d[(i, i)] = v;
        }
    }
    navsim::InstrumentCovariance::new(c.names.clone(), d).expect("a diagonal covariance is valid")
}

fn nav_budget() -> Result<(), String> {
    let rec = both_tables(&calib::paper::reconciled())?;
    let lit = both_tables(&calib::paper::literal())?;
    let traj = navsim::SnakeTrajectory::new(&navsim::SnakeConfig::default_config())
        .map_err(|e| e.to_string())?;
    let quiet = navsim::NavOptions {
        gyro_noise_density: 0.0,
        accel_noise_density: 0.0,
        ..navsim::NavOptions::default()
    };
    let rho = |c: &navsim::InstrumentCovariance, o: &navsim::NavOptions| {
        navsim::rho_series(&traj, c, o)
            .map(|r| r.final_rho_m())
            .map_err(|e| e.to_string())
    };
    println!(
        "rho after 1 h of the default snake flight [m]; ratio = without / with turntable angles\n"
    );
    println!("| instrument covariance | flight noise | without | with | ratio |");
    println!("|---|---|---|---|---|");
    let rows: Vec<(
        &str,
        navsim::InstrumentCovariance,
        navsim::InstrumentCovariance,
    )> = vec![
        (
            "reconciled posterior, full (paper-check)",
            instrument_covariance(&rec.0)?,
            instrument_covariance(&rec.1)?,
        ),
        (
            "reconciled posterior, correlations dropped",
            diagonal_only(&instrument_covariance(&rec.0)?),
            diagonal_only(&instrument_covariance(&rec.1)?),
        ),
        (
            "reconciled posterior, group maxima, diagonal",
            group_max_diagonal(&instrument_covariance(&rec.0)?),
            group_max_diagonal(&instrument_covariance(&rec.1)?),
        ),
        (
            "paper's tables, diagonal",
            navsim::InstrumentCovariance::paper_without_turntable(),
            navsim::InstrumentCovariance::paper_with_turntable(),
        ),
        (
            "literal posterior, full",
            instrument_covariance(&lit.0)?,
            instrument_covariance(&lit.1)?,
        ),
    ];
    for (label, a, b) in &rows {
        for (nl, o) in [
            ("on", navsim::NavOptions::default()),
            ("off", quiet.clone()),
        ] {
            let (ra, rb) = (rho(a, &o)?, rho(b, &o)?);
            println!("| {label} | {nl} | {ra:.0} | {rb:.0} | {:.2} |", ra / rb);
        }
    }
    println!(
        "\nIMU-only calibration with other initial-heading priors (reconciled otherwise), correlations dropped\n"
    );
    println!(
        "| heading prior | nu0 entry deg/h | rho without [m] | ratio to with-turntable (correlations dropped) |"
    );
    println!("|---|---|---|---|");
    let with_diag = rho(&rows[1].2, &navsim::NavOptions::default())?;
    for h_arcmin in [6.0, 3.0, 1.5, 0.75] {
        let mut c = calib::paper::reconciled();
        c.priors.initial_heading_deg = h_arcmin / 60.0;
        let p = covariance_analysis(&c, false).map_err(|e| e.to_string())?;
        let nu0 = calib::report::paper_table(&p).nu0_deg_h;
        let r = rho(
            &diagonal_only(&instrument_covariance(&p)?),
            &navsim::NavOptions::default(),
        )?;
        println!(
            "| {h_arcmin} arcmin | {nu0:.4} | {r:.0} | {:.2} |",
            r / with_diag
        );
    }
    println!(
        "\nError budget of the reconciled posterior (each group alone, correlations within it kept) [m]\n"
    );
    println!("| group | without | with |");
    println!("|---|---|---|");
    let ba = navsim::error_budget(&traj, &rows[0].1, &navsim::NavOptions::default())
        .map_err(|e| e.to_string())?;
    let bb = navsim::error_budget(&traj, &rows[0].2, &navsim::NavOptions::default())
        .map_err(|e| e.to_string())?;
    for (ea, eb) in ba.entries.iter().zip(&bb.entries) {
        println!("| {:?} | {:.0} | {:.0} |", ea.group, ea.rho_m, eb.rho_m);
    }
    println!("| total | {:.0} | {:.0} |", ba.total_m, bb.total_m);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reconciled calibration with the turntable angles as a result file (parameters with
    /// sigmas, the correlation block rounded as written), read back: its navigation figure is
    /// 713 m with the correlations and 1082 m without (docs/navsim.md).
    #[test]
    fn correlations_in_the_result_file_change_the_navigation_figure() {
        let p = covariance_analysis(&calib::paper::reconciled(), true).expect("analysis");
        let keep: Vec<usize> = (0..p.names.len())
            .filter(|&i| !p.names[i].starts_with("attitude."))
            .collect();
        let parameters = keep
            .iter()
            .map(|&i| calib::io::ResultParameter {
                name: p.names[i].clone(),
                value: 0.0,
                sigma: Some(p.cov[(i, i)].sqrt()),
                unit: p.units[i].si_name().into(),
            })
            .collect();
        let k = keep.clone();
        let correlation = calib::io::posterior::correlation(keep.len(), 0..keep.len(), |a, b| {
            p.cov[(k[a], k[b])]
        });
        let result = calib::io::ResultFile {
            parameters,
            correlation: Some(correlation),
            correction: None,
            ..Default::default()
        };
        let dir = std::env::temp_dir().join(format!("xtask-nav-error-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("result.json");
        calib::io::write_result_json(&path, &result).unwrap();
        let back = calib::io::read_result_json(&path).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let with = nav_error_m(&back, "result.json", true).unwrap();
        let without = nav_error_m(&back, "result.json", false).unwrap();
        println!("with correlations {with:.1} m, without {without:.1} m");
        // The full posterior's own figure (paper-check), from the unrounded covariance.
        let full = navigation(&instrument_covariance(&p).unwrap())
            .unwrap()
            .final_rho_m();
        assert!((with / full - 1.0).abs() < 1e-3, "{with} vs {full}");
        assert!((with / 713.0 - 1.0).abs() < 0.01, "{with}");
        assert!((without / 1082.0 - 1.0).abs() < 0.01, "{without}");
    }
}
