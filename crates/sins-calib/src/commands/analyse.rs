//! `sins-calib analyse`: covariance analysis of a run configuration.

use crate::commands::diagnose::{DriftReachJson, drift_reach_json};
use crate::render::table::{self, Align, Table};
use crate::{Error, load_config, output};
use calib::estimate::covariance::covariance_analysis_ext;
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
    /// Candidate terms to analyse with the paper's model (ids, as `diagnose` names them; the
    /// thermal ones need a `[temperature]` profile): their posterior sigmas and whether the
    /// program separates them from the paper's parameters (the rule `diagnose` applies).
    #[arg(long, value_name = "ID", num_args = 1..)]
    pub terms: Vec<String>,
    /// The flight of the navigation figure.
    #[command(flatten)]
    pub flight: crate::navigation::FlightArgs,
}

#[derive(Serialize)]
struct AnalysisJson<'a> {
    with_turntable: bool,
    parameters: Vec<AnalysisParameter>,
    #[serde(skip_serializing_if = "Option::is_none")]
    walk_reach: Option<DriftReachJson>,
    /// With --terms: each term's separability from the paper's parameters.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    terms: Vec<TermSeparationJson>,
    /// What the program buys in navigation (`crate::navigation`).
    navigation: crate::navigation::NavigationJson<'a>,
}

#[derive(Serialize)]
struct TermSeparationJson {
    term: String,
    separable: bool,
    confounded_with: Vec<String>,
}

#[derive(Serialize)]
struct AnalysisParameter {
    name: String,
    unit: &'static str,
    prior_sigma: f64,
    sigma: f64,
}

/// The walk `diagnose` is expected to show on this program ([`calib::extend::drift_reach`] at
/// the loop's default grid and level, over the candidates it would test), as JSON and text.
fn walk_reach(
    config: &calib::config::RunConfig,
    with_turntable: bool,
) -> Result<Option<(DriftReachJson, String)>, Error> {
    use sins_model::units::DEG_PER_HOUR;
    let settings = calib::extend::LoopSettings::default();
    // The candidates the loop would test: the thermal ones only where the unit's temperature
    // moves ([`calib::extend::thermal_untestable`]).
    let tested = settings
        .candidates
        .iter()
        .filter(|c| !c.is_thermal() || config.temperature.is_some())
        .count();
    let level = settings.level / tested as f64;
    let ext = calib::model::extension::ModelExtension::default();
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
    let flight = crate::navigation::Flight::load(&args.flight)?;
    if let Some(path) = &args.json {
        let program = crate::provenance::identification::program_file(&config);
        let mut inputs = vec![std::path::Path::new(&args.config)];
        inputs.extend(program.as_deref());
        inputs.extend(args.flight.flight.as_deref());
        output::Outputs::new(&inputs).file(path, "--json")?;
    }
    let program = config.program()?;
    let with_turntable = !args.imu_only;
    let terms = crate::args::terms::terms_asked(&args.terms, None)?;
    if config.temperature.is_none()
        && let Some(c) = terms.iter().find(|c| c.is_thermal())
    {
        return Err(format!(
            "analyse: {origin} has no [temperature] section: the thermal term {} acts on the \
             temperature's departure from its reference, so the analysis needs the profile the \
             unit will see (docs/temperature.md)",
            c.id()
        )
        .into());
    }
    let ext = calib::model::extension::ModelExtension::with_grade(&terms, config.unit_grade());
    let post = covariance_analysis_ext(&config, with_turntable, &ext)?;

    let program = (program.name.as_str(), program.duration());
    let mut s = header(&config, &origin, program, &post, with_turntable);
    let (table, parameters) = parameter_table(&post);
    s += &table;
    let separations = term_separations(&config, program.1, &post, &terms, &mut s);
    let ids: Vec<&str> = terms.iter().map(|c| c.id()).collect();
    let navigation = figure(&config, (&post, program.1), &flight, &ids);
    let _ = writeln!(s, "\n{}", navigation.line());
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
            terms: separations,
            navigation: navigation.json(),
        };
        let text = calib::io::schema::to_json(calib::io::schema::ANALYSIS, &json)?;
        output::write_file(path, text.as_bytes())?;
        if !output::is_stdout(path) {
            let _ = writeln!(s, "\nwrote {}", path.display());
        }
    }
    crate::report(&s, args.json.as_deref())
}

/// The navigation figure of the analysis's posterior for a program of `duration` s (the
/// thermal terms about the reference of the configuration's `[temperature]`).
pub fn figure(
    config: &calib::config::RunConfig,
    (post, duration): (&calib::estimate::covariance::Posterior, f64),
    flight: &crate::navigation::Flight,
    terms: &[&str],
) -> crate::navigation::Navigation {
    let reference = config.temperature.as_ref().and_then(|_| {
        let rate = config.filter.imu_rate_hz;
        config
            .temperature_profile(rate, (duration * rate) as usize)
            .map(|(_, r)| r)
    });
    let cal = navsim::CalibrationCovariance {
        names: post.names.clone(),
        posterior: post.cov.clone(),
        prior_sigma: post.prior_sigma.clone(),
        reference_temperature_c: reference,
    };
    crate::navigation::Navigation::of(cal, config, flight, terms, None)
}

/// The printout's head: the configuration, its program, the model, the walks of `[noise]`.
fn header(
    config: &calib::config::RunConfig,
    origin: &str,
    (name, duration): (&str, f64),
    post: &calib::estimate::covariance::Posterior,
    with_turntable: bool,
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "sins-calib analyse: covariance analysis of {origin}, program \"{}\" ({} s), {} states \
         ({})",
        name,
        table::compact(duration),
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
    s
}

/// Every parameter's prior and posterior sigma, as the printed table and for the JSON.
fn parameter_table(
    post: &calib::estimate::covariance::Posterior,
) -> (String, Vec<AnalysisParameter>) {
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
    (t.render(), parameters)
}

/// Each asked term's separability from the paper's parameters in the posterior, written into
/// `s` (with the temperature the thermal terms see), for the JSON.
fn term_separations(
    config: &calib::config::RunConfig,
    duration: f64,
    post: &calib::estimate::covariance::Posterior,
    terms: &[sins_model::candidates::Candidate],
    s: &mut String,
) -> Vec<TermSeparationJson> {
    if terms.is_empty() {
        return Vec::new();
    }
    let base: Vec<String> = post
        .names
        .iter()
        .filter(|n| {
            !n.starts_with("attitude.") && !terms.iter().any(|c| c.param_names().contains(n))
        })
        .cloned()
        .collect();
    s.push('\n');
    if terms.iter().any(|c| c.is_thermal()) {
        let dt = 1.0 / config.filter.imu_rate_hz;
        let n = (duration / dt) as usize;
        if let Some((profile, reference)) = config.temperature_profile(config.filter.imu_rate_hz, n)
        {
            let temps: Vec<f64> = (0..=100)
                .map(|k| profile.at(duration * k as f64 / 100.0))
                .collect();
            let lo = temps.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = temps.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let _ = writeln!(
                s,
                "temperature over the program: {lo:.2} .. {hi:.2} deg C ({}), thermal terms \
                 about {reference:.2} deg C",
                config
                    .temperature
                    .as_ref()
                    .map_or("the recording's", |t| t.profile.as_str())
            );
        }
    }
    let mut out = Vec::new();
    for c in terms {
        let sep = calib::extend::evidence::separability(
            &post.names,
            &post.prior_sigma,
            &post.cov,
            &c.param_names(),
            &base,
        );
        let confounded = sep.confounded();
        let _ = writeln!(
            s,
            "{}: {}",
            c.id(),
            if sep.separable {
                "separable from the paper's parameters on this program".to_string()
            } else if confounded.is_empty() {
                "not separable: the program leaves it near its prior".to_string()
            } else {
                format!("not separable: confounded with {}", confounded.join(", "))
            }
        );
        out.push(TermSeparationJson {
            term: c.id().to_string(),
            separable: sep.separable,
            confounded_with: confounded,
        });
    }
    out
}
