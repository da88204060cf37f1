//! `sins-calib design`: a program that separates the given candidate terms from the paper's
//! parameters, printed as TOML with its predicted sigmas (`calib::extend::design`), each
//! program with its navigation figure; without `--terms`, programs ranked by the navigation
//! figure they buy (`crate::navigation`), the best proposed.

pub mod navigation;

use crate::args::terms::parse_terms;
use crate::{Error, load_config, output, print};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `design`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Run configuration whose program is the recorded (or planned) one.
    #[arg(long, value_name = "FILE|NAME")]
    pub config: String,
    // Candidate term ids to separate: the help lists every id from the declarations.
    #[arg(
        long,
        value_name = "ID",
        num_args = 1..,
        help = crate::args::terms::design_help(),
        long_help = crate::args::terms::design_long_help()
    )]
    pub terms: Vec<String>,
    /// Analyse with the turntable angles (28-state model and more); default: the IMU alone.
    #[arg(long)]
    pub with_turntable: bool,
    /// Write the proposed program to this TOML file (also printed); checked before the design
    /// runs (not a directory, not the configuration), written whole or not at all.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// The flight of the navigation figure.
    #[command(flatten)]
    pub flight: crate::navigation::FlightArgs,
}

/// Run `design`.
pub fn run(args: &Args) -> Result<(), Error> {
    let (config, origin) = load_config(&args.config)?;
    let flight = crate::navigation::Flight::load(&args.flight)?;
    if let Some(path) = &args.out {
        let program = crate::provenance::identification::program_file(&config);
        let mut inputs = vec![std::path::Path::new(&args.config)];
        inputs.extend(program.as_deref());
        inputs.extend(args.flight.flight.as_deref());
        output::Outputs::new(&inputs).file(path, "--out")?;
    }
    if args.terms.is_empty() {
        return crate::commands::design::navigation::run(args, &config, &flight);
    }
    crate::args::terms::check_distinct(&args.terms)?;
    let terms = parse_terms(&args.terms)?;
    if terms.contains(&sins_model::candidates::Candidate::GyroBiasDrift) {
        // The design leaves it out (it has no parameters to separate): named, it would be
        // dropped without a word.
        return Err(format!(
            "design --terms {}: a random walk of the gyro biases has no parameters for a \
             program to separate (it is process noise, not a state): expected candidate terms \
             with parameters; `analyse --walk-reach` says which walk a program shows",
            sins_model::candidates::Candidate::GyroBiasDrift.id()
        )
        .into());
    }
    crate::args::terms::check_thermal(
        &terms,
        config.temperature.is_some(),
        "design",
        &format!("{origin} has no [temperature] section"),
        "the temperature profile the unit will see in a [temperature] section",
    )?;
    let (recorded, proposals, chosen) =
        calib::extend::design::design(&config, args.with_turntable, &terms)?;
    let judged = crate::commands::design::navigation::judge(
        &config,
        &flight,
        std::iter::once(&recorded).chain(&proposals),
    );
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Separability (posterior sigma / prior sigma, separable at <= 0.5) and navigation \
         ({}):",
        judged.heading
    );
    for (p, rho) in std::iter::once(&recorded)
        .chain(&proposals)
        .zip(&judged.rho_m)
    {
        let _ = writeln!(
            s,
            "#   {:<72} {:>6.0} s  worst ratio {:.3}  navigation {}{}",
            p.description,
            p.duration_s,
            p.worst_ratio(),
            crate::commands::design::navigation::rho_text(rho),
            if p.separates() { "  separates" } else { "" }
        );
    }
    let toml = match chosen {
        None => {
            let _ = writeln!(
                s,
                "# The recorded program already separates every requested term: nothing to add. \
                 Its predicted sigmas and the program follow."
            );
            recorded.to_toml()
        }
        Some(k) => {
            if !proposals[k].separates() {
                let _ = writeln!(
                    s,
                    "# No proposal separates every requested term; the closest one follows."
                );
            }
            proposals[k].to_toml()
        }
    };
    s += &toml;
    // The file first: a report that cannot be printed must not lose it.
    if let Some(path) = &args.out {
        output::write_file(path, toml.as_bytes())?;
    }
    print(&s)
}
