//! The command lines: `calibrate`'s and `diagnose`'s (read once, by `crate::session`, which
//! resolves them into the session the commands run over), and the option groups several
//! commands share, each declared once: the records (`RecordsArgs`), the programmed run
//! (`ProgramArgs`), the site (`SiteArgs`), the static detector (`detector::DetectorArgs`), the
//! candidate terms (`terms`), with the help headings they are listed under (`heading`). The
//! unit (`crate::provenance::UnitArgs`) and the flight (`crate::navigation::FlightArgs`) are
//! declared beside what they feed.

pub mod detector;
pub mod terms;

use std::path::PathBuf;

/// The help headings the options are grouped under, by what they are for (`--help` lists the
/// common inputs first, then one heading per kind of run and purpose).
pub mod heading {
    /// The options of a programmed run: the rotation program and the turntable's records.
    pub const PROGRAMMED: &str = "Programmed run (rotation program, turntable)";
    /// The options of a recording of rests joined by any motion (a hand-turned unit).
    pub const FREE_MOTION: &str = "Recording of rests, hand-turned (--free-motion)";
    /// The static detector's options in `calibrate` and `diagnose`.
    pub const REST_DETECTION_NO_PROGRAM: &str = "Rest detection (recordings without a program)";
    /// The static detector's options in `segment` and `noise`.
    pub const REST_DETECTION: &str = "Rest detection";
    /// The model's terms and the noise.
    pub const MODEL: &str = "Model and noise";
    /// What is written and printed, and against what it is checked.
    pub const OUTPUTS: &str = "Outputs";
    /// The unit the data are of.
    pub const UNIT: &str = "Unit";
}

/// Arguments of `calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// IMU records: a CSV with the header `t,dthx,dthy,dthz,dvx,dvy,dvz` (increments, rad and m/s)
    /// or `t,wx,wy,wz,fx,fy,fz` (rad/s and m/s^2), an optional `temp` column; t in s on the IMU
    /// clock (the program may start at any time: see --program-start), records at
    /// filter.imu_rate_hz (docs/formats.md).
    #[arg(long, value_name = "FILE")]
    pub imu: PathBuf,
    /// Run configuration: a TOML file (docs/formats.md), or `paper` / `paper-reconciled` for the
    /// embedded configurations. Its program must be the one the turntable ran; `[priors]`,
    /// `[noise]`, `[filter]` and `[clock]` set up the filter (`[truth]` is not read). A
    /// configuration without a program and no --turntable calibrate a recording of rests
    /// joined by any motion (a hand-turned unit): the same filter, with the specific force
    /// measured in the rests the data show (docs/estimation.md, "Without a program"). Required
    /// unless --free-motion; with it optional: its `[priors]` and `[site]` (for g) replace the
    /// defaults.
    #[arg(long, value_name = "FILE|NAME")]
    pub config: Option<String>,
    /// The rotation program's start and the turntable's records.
    #[command(flatten)]
    pub program: ProgramArgs,
    /// A hand-turned multi-position recording, without a rotation program or turntable: the
    /// filter of a recording of rests (the specific force measured in the rests the detector
    /// finds, the attitude carried by the gyros through every motion) with the paper's model
    /// and the terms --terms and --terms-from name; without --config, the unit's grade, priors,
    /// white noise and motion noise from the recording (docs/real-data.md).
    #[arg(long, help_heading = heading::FREE_MOTION)]
    pub free_motion: bool,
    /// With --free-motion: the section list written by `import` (sections.json); its rotations
    /// with an expected turn (e.g. 360-degree turns) become measurements of the integrated angle.
    #[arg(long, value_name = "FILE", requires = "free_motion", help_heading = heading::FREE_MOTION)]
    pub sections: Option<PathBuf>,
    /// With --free-motion: leave every K-th static interval (K, 2K, ... counted from 1) out of
    /// the fit and report the errors on those (a "validation" block in the JSON).
    #[arg(long, value_name = "K", requires = "free_motion", help_heading = heading::FREE_MOTION)]
    pub holdout: Option<usize>,
    /// With --free-motion: the error every specific-force window of one rest shares (m/s^2,
    /// one sigma per axis), weighed so that a rest counts at most as one measurement of it
    /// (`filter.rest_error_m_s2`). The report measures it ("rests' excess"); absent: the
    /// configuration's, or without one the rests' excess where it is significant (p below 1 %
    /// over at least 10 degrees of freedom); 0: the windows taken as independent.
    #[arg(
        long,
        value_name = "M_S2",
        requires = "free_motion",
        value_parser = rest_error_value,
        allow_negative_numbers = true,
        help_heading = heading::FREE_MOTION
    )]
    pub rest_error: Option<f64>,
    /// With --free-motion: write a PNG of |f| - g per static interval, before and after.
    #[arg(long, value_name = "FILE", requires = "free_motion", help_heading = heading::FREE_MOTION)]
    pub plot: Option<PathBuf>,
    /// The site of a recording without a configuration.
    #[command(flatten, next_help_heading = heading::FREE_MOTION)]
    pub site: SiteArgs,
    /// How rests are found in a recording without a program (and with --free-motion).
    #[command(flatten, next_help_heading = heading::REST_DETECTION_NO_PROGRAM)]
    pub detector: crate::args::detector::DetectorArgs,
    // Candidate terms to add to the paper's model: the help lists every id from the
    // declarations.
    #[arg(
        long,
        value_name = "ID",
        num_args = 1..,
        help = crate::args::terms::calibrate_help(),
        long_help = crate::args::terms::calibrate_long_help(),
        help_heading = heading::MODEL
    )]
    pub terms: Vec<String>,
    /// Add the terms a `diagnose --json` result accepted (`accepted_terms`).
    #[arg(long, value_name = "DIAGNOSE.json", help_heading = heading::MODEL)]
    pub terms_from: Option<PathBuf>,
    /// Write the result to this JSON file: every parameter's name, value, sigma and unit in SI
    /// units, and the fit statistics (docs/formats.md).
    #[arg(long, value_name = "FILE", help_heading = heading::OUTPUTS)]
    pub json: Option<PathBuf>,
    /// True values (the truth.json of `simulate`, or any result file): also print each
    /// parameter's true value, its error in sigmas and the normalised estimation error squared
    /// (NEES) of all parameters.
    #[arg(long, value_name = "FILE", help_heading = heading::OUTPUTS)]
    pub truth: Option<PathBuf>,
    /// Write the PNG plots of the tests of the fit's innovations into DIR (created, or its
    /// plots replaced whole, as --report: a failed run leaves none). The tests themselves (NIS per program segment, whiteness, lines at the
    /// program's frequencies; docs/estimation.md, "Diagnostics") run on every calibration:
    /// their summary is printed, the JSON has their "diagnostics" block, and with a configured
    /// noise a failing verdict (family-wise level 1 %) ends with exit status 3.
    #[arg(long, value_name = "DIR", help_heading = heading::OUTPUTS)]
    pub diagnostics: Option<PathBuf>,
    /// Write the report a laboratory files into DIR (created, or replaced whole: no plot of an
    /// earlier report stays): report.md with the inputs' SHA-256, the configuration, version,
    /// date and command line, the verdict and its failing tests, the parameters with 1 sigma,
    /// and PNG plots of the correlations, the residuals and the NIS per segment
    /// (docs/report.md). The verdict is the one the printout, the JSON and the exit status
    /// say.
    #[arg(long, value_name = "DIR", help_heading = heading::OUTPUTS)]
    pub report: Option<PathBuf>,
    /// The flight of the navigation figure.
    #[command(flatten, next_help_heading = heading::OUTPUTS)]
    pub flight: crate::navigation::FlightArgs,
    /// The unit calibrated.
    #[command(flatten, next_help_heading = heading::UNIT)]
    pub unit: crate::provenance::UnitArgs,
}

/// Arguments of `diagnose`.
#[derive(Debug, clap::Args)]
pub struct DiagnoseArgs {
    /// IMU records (as for `calibrate`).
    #[arg(long, value_name = "FILE")]
    pub imu: PathBuf,
    /// Run configuration (a TOML file, or `paper` / `paper-reconciled`). Required unless
    /// --free-motion; with it optional (its `[site]` and `[priors]`).
    #[arg(
        long,
        value_name = "FILE|NAME",
        required_unless_present = "free_motion"
    )]
    pub config: Option<String>,
    /// The rotation program's start and the turntable's records (as for `calibrate`).
    #[command(flatten)]
    pub program: ProgramArgs,
    /// A hand-turned multi-position recording (no program, no turntable): the loop runs on the
    /// filter of a recording of rests as for a configuration without a program; without
    /// --config, with the configuration `calibrate --free-motion` makes from the recording
    /// (consumer-grade priors, the white noise measured in the rests).
    #[arg(
        long,
        conflicts_with_all = ["turntable", "program_start"],
        help_heading = heading::FREE_MOTION
    )]
    pub free_motion: bool,
    /// With --free-motion: the section list written by `import` (its known turns are
    /// measurements of every fit).
    #[arg(long, value_name = "FILE", requires = "free_motion", help_heading = heading::FREE_MOTION)]
    pub sections: Option<PathBuf>,
    /// With --free-motion: the held-out check of an accepted term holds out every K-th rest
    /// (default 4).
    #[arg(long, value_name = "K", requires = "free_motion", help_heading = heading::FREE_MOTION)]
    pub holdout: Option<usize>,
    /// How rests are found in a recording without a program (a configuration without
    /// `program` and no --turntable: the loop then runs on the filter of `calibrate` for such
    /// recordings, each candidate's separability from the fit's own posterior).
    #[command(flatten, next_help_heading = heading::REST_DETECTION_NO_PROGRAM)]
    pub detector: crate::args::detector::DetectorArgs,
    /// The site of a recording without a configuration.
    #[command(flatten, next_help_heading = heading::FREE_MOTION)]
    pub site: SiteArgs,
    // Candidate terms to consider (default all): the help lists every id from the
    // declarations.
    #[arg(
        long,
        value_name = "ID",
        num_args = 1..,
        help = crate::args::terms::diagnose_help(),
        long_help = crate::args::terms::diagnose_long_help(),
        help_heading = heading::MODEL
    )]
    pub terms: Vec<String>,
    /// Family-wise level of each round's decision.
    #[arg(long, default_value_t = 0.01, value_name = "P", help_heading = heading::MODEL)]
    pub level: f64,
    /// The noise identified at rest (the JSON of `sins-calib noise --json`): the gyro bias
    /// random walk candidate is tried at its identified walk, the largest axis's value and the
    /// ends of its 68 % interval, instead of the default grid of 0.003 to 0.3 deg/h/sqrt(h)
    /// (docs/model-extension.md, "The evidence for a term")
    #[arg(long, value_name = "FILE", help_heading = heading::MODEL)]
    pub noise: Option<PathBuf>,
    /// Write the loop's result as JSON: accepted_terms, candidates (last round), gain,
    /// parameters (docs/formats.md).
    #[arg(long, value_name = "FILE", help_heading = heading::OUTPUTS)]
    pub json: Option<PathBuf>,
    /// Write the report a laboratory files into DIR (created, or replaced whole: no plot of an
    /// earlier report stays): as `calibrate --report` (docs/report.md) for the final model,
    /// with the paper's model beside it and the model-extension table.
    #[arg(long, value_name = "DIR", help_heading = heading::OUTPUTS)]
    pub report: Option<PathBuf>,
    /// The flight of the navigation figure of every model the loop moves to.
    #[command(flatten, next_help_heading = heading::OUTPUTS)]
    pub flight: crate::navigation::FlightArgs,
}

/// The records of the commands that read a recording as it is (`segment`, `noise`).
#[derive(Debug, clap::Args)]
pub struct RecordsArgs {
    /// IMU records (imu.csv, rates or increments; as written by `import` or `simulate`).
    #[arg(long, value_name = "FILE")]
    pub imu: PathBuf,
}

/// The options of a programmed run (`calibrate` and `diagnose`): the turntable's records and
/// where the rotation program starts.
#[derive(Debug, clap::Args)]
pub struct ProgramArgs {
    /// Turntable angle records: a CSV with the header `t,k1,k2,k3` (t in s on the turntable
    /// clock, related to the IMU clock by the configuration's `[clock]`; heading, bank and pitch in
    /// degrees). Adds the installation misalignment and the delay to the estimated parameters
    /// (28 states); without it the IMU data alone are used (24 states).
    #[arg(long, value_name = "FILE", help_heading = heading::PROGRAMMED)]
    pub turntable: Option<PathBuf>,
    /// IMU time (s) at which the rotation program starts. Without it the start is found from the
    /// data, by matching the measured rate magnitude against the program's; with it, the data are
    /// checked against the program from there. Either way a recording that does not follow the
    /// program is refused.
    #[arg(
        long,
        value_name = "SECONDS",
        allow_negative_numbers = true,
        help_heading = heading::PROGRAMMED
    )]
    pub program_start: Option<f64>,
}

impl ProgramArgs {
    /// The turntable's records (`--turntable`), opened (`None` without the option).
    pub fn open_turntable(
        &self,
    ) -> Result<Option<calib::io::angle_records::AngleFile>, crate::Error> {
        Ok(self
            .turntable
            .as_deref()
            .map(calib::io::angle_records::AngleFile::open)
            .transpose()?)
    }
}

/// The site of a hand-turned recording without a configuration (`calibrate` and `diagnose`
/// with `--free-motion`): its normal gravity comes from them, and each one not given is an
/// assumption the run states.
#[derive(Debug, clap::Args)]
pub struct SiteArgs {
    /// With --free-motion and no --config: latitude of the site (deg) for normal gravity.
    #[arg(
        long,
        value_name = "DEG",
        requires = "free_motion",
        conflicts_with = "config",
        allow_negative_numbers = true
    )]
    pub latitude: Option<f64>,
    /// With --free-motion and no --config: height of the site above the ellipsoid (m) for
    /// normal gravity (absent: 0, said as an assumption; gravity falls 3.1e-6 m/s^2 a metre, a
    /// scale error of 0.3 ppm a metre in the accelerometers).
    #[arg(
        long,
        value_name = "M",
        requires = "free_motion",
        conflicts_with = "config",
        allow_negative_numbers = true
    )]
    pub height: Option<f64>,
}

/// `--rest-error`: a specific-force error in 0 .. 1 m/s^2.
fn rest_error_value(text: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .ok()
        .filter(|v| (0.0..=1.0).contains(v))
        .ok_or_else(|| format!("`{text}`: expected a specific-force error in 0 .. 1 m/s^2"))
}
