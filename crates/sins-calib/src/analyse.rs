//! `sins-calib analyse`: covariance analysis of a run configuration.

use crate::diagnose::{DriftReachJson, drift_reach_json};
use crate::table::{self, Align, Table};
use crate::{Error, load_config, output};
use calib::covariance::covariance_analysis;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `analyse`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Run configuration: a TOML file (docs/formats.md), or `paper` / `paper-reconciled` for the
    /// embedded configurations of the paper's covariance analysis (the literal reading and the
    /// reconciled one, docs/paper-check.md). Its program, `[priors]`, `[noise]` and `[filter]` are used.
    #[arg(long, value_name = "FILE|NAME")]
    pub config: String,
    /// Analyse the IMU data alone (24 states) instead of IMU and turntable angles (28 states).
    #[arg(long)]
    pub imu_only: bool,
    /// Also write the result to this JSON file: every parameter's name, SI unit, prior sigma
    /// and posterior sigma in SI units (docs/formats.md).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Also say from which gyro bias random walk the program is expected to show one to
    /// `diagnose` (its loop's threshold at the default level), and what a walk of that size,
    /// unseen, does to the gyro-bias sigmas (docs/model-extension.md, "What a program can see
    /// of a walk"; about fifteen more analyses).
    #[arg(long)]
    pub walk_reach: bool,
}

#[derive(Serialize)]
struct AnalysisJson {
    with_turntable: bool,
    parameters: Vec<AnalysisParameter>,
    #[serde(skip_serializing_if = "Option::is_none")]
    walk_reach: Option<DriftReachJson>,
}

#[derive(Serialize)]
struct AnalysisParameter {
    name: String,
    unit: &'static str,
    prior_sigma: f64,
    sigma: f64,
}

/// The walk `diagnose` is expected to show on this program ([`calib::extend::drift_reach`] at
/// the loop's default grid and level, over all its candidates), as JSON and text.
fn walk_reach(
    config: &calib::config::RunConfig,
    with_turntable: bool,
) -> Result<Option<(DriftReachJson, String)>, Error> {
    use sins_model::units::DEG_PER_HOUR;
    let settings = calib::extend::LoopSettings::default();
    let level = settings.level / settings.candidates.len() as f64;
    let ext = calib::extension::ModelExtension::default();
    let Some(reach) = calib::extend::drift_reach(config, with_turntable, &ext, &settings, level)?
    else {
        return Ok(None);
    };
    let walk = |q: f64| q * 60.0 / DEG_PER_HOUR;
    let deg_h = |v: [f64; 3]| {
        v.map(|x| table::significant(x / DEG_PER_HOUR, 3))
            .join(", ")
    };
    let threshold = reach.threshold;
    let text = match &reach.smallest_visible {
        Some(v) => format!(
            "\nGyro bias random walk: diagnose is expected to show one from about {} \
             deg/h/sqrt(h) on this program (expected statistic {:.1}, accepted above {:.1}); a \
             smaller one mostly goes unseen, and one of that size, unseen, makes the gyro-bias \
             sigmas at the end {} deg/h where the table says {}\n",
            table::significant(walk(v.intensity), 3),
            v.expected_statistic,
            threshold,
            deg_h(v.gyro_bias_sigma),
            deg_h(v.gyro_bias_sigma_without)
        ),
        None => format!(
            "\nGyro bias random walk: even {} deg/h/sqrt(h) stays below diagnose's threshold \
             {threshold:.1} on this program: a walk goes unseen here\n",
            table::significant(walk(reach.largest_tried), 3)
        ),
    };
    Ok(Some((drift_reach_json(&reach), text)))
}

/// Run `analyse`.
pub fn run(args: &Args) -> Result<(), Error> {
    let (config, origin) = load_config(&args.config)?;
    if let Some(path) = &args.json {
        let program = crate::lab_report::program_file(&config);
        let mut inputs = vec![std::path::Path::new(&args.config)];
        inputs.extend(program.as_deref());
        output::Outputs::new(&inputs).file(path, "--json")?;
    }
    let program = config.program()?;
    let with_turntable = !args.imu_only;
    let post = covariance_analysis(&config, with_turntable)?;

    let mut s = String::new();
    let _ = writeln!(
        s,
        "sins-calib analyse: covariance analysis of {origin}, program \"{}\" ({} s), {} states \
         ({})",
        program.name,
        table::compact(program.duration()),
        post.names.len(),
        if with_turntable {
            "IMU and turntable angles"
        } else {
            "IMU data alone"
        }
    );
    let n = &config.noise;
    if n.gyro_bias_walk_deg_h_sqrt_h > 0.0 || n.accel_bias_walk_m_s2_sqrt_s > 0.0 {
        let _ = writeln!(
            s,
            "  with the bias random walks of [noise] as process noise (gyro {} deg/h/sqrt(h), \
             accelerometer {} m/s^2/sqrt(s)): the bias sigmas are those of the biases at the \
             end of the program; set the walks to 0 to see what they cost",
            table::compact(n.gyro_bias_walk_deg_h_sqrt_h),
            table::compact(n.accel_bias_walk_m_s2_sqrt_s)
        );
    }
    s.push('\n');
    let mut t = Table::new(&[
        ("parameter", Align::Left),
        ("prior sigma", Align::Right),
        ("posterior sigma", Align::Right),
        ("unit", Align::Left),
        ("prior/posterior", Align::Right),
    ]);
    let mut parameters = Vec::new();
    for (title, members) in table::grouped(&post.names) {
        t.section(title);
        for i in members {
            let unit = post.units[i];
            let f = unit.report_factor();
            let prior = post.prior_sigma[i];
            let sigma = post.cov[(i, i)].max(0.0).sqrt();
            t.row(vec![
                format!("  {}", post.names[i]),
                table::significant(prior * f, 3),
                table::significant(sigma * f, 3),
                unit.report_name().to_string(),
                table::significant(prior / sigma, 3),
            ]);
            parameters.push(AnalysisParameter {
                name: post.names[i].clone(),
                unit: unit.si_name(),
                prior_sigma: prior,
                sigma,
            });
        }
    }
    s += &t.render();
    let reach = if args.walk_reach {
        walk_reach(&config, with_turntable)?.map(|(json, text)| {
            s += &text;
            json
        })
    } else {
        None
    };
    if let Some(path) = &args.json {
        let json = AnalysisJson {
            with_turntable,
            parameters,
            walk_reach: reach,
        };
        let text = calib::schema::to_json(calib::schema::ANALYSIS, &json)?;
        output::write_file(path, text.as_bytes())?;
        if !output::is_stdout(path) {
            let _ = writeln!(s, "\nwrote {}", path.display());
        }
    }
    crate::report(&s, args.json.as_deref())
}
