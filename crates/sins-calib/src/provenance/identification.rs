//! What identifies a run in the report a laboratory files (`--report DIR`): every input file
//! with its SHA-256, the configuration with its text, the tool's version and commit, the date
//! and the command line; and the names of the files a report directory holds.

use crate::Error;
use calib::config::RunConfig;
use std::path::{Path, PathBuf};

/// Every file a report directory may hold (the names an earlier report may have left).
pub const NAMES: [&str; 15] = [
    "report.md",
    "report.html",
    "navigation.png",
    "temperature.png",
    "correlation.png",
    "residuals_accel.png",
    "residuals_turntable.png",
    "nis_segments_accel.png",
    "nis_segments_turntable.png",
    "spectrum_accel.png",
    "spectrum_turntable.png",
    "autocorrelation_accel.png",
    "autocorrelation_turntable.png",
    "innovations_accel.png",
    "innovations_turntable.png",
];

/// A file the run read, identified by its content.
pub struct InputFile {
    /// What the file is to the run.
    pub role: String,
    /// The path as given.
    pub path: PathBuf,
    /// SHA-256, lower-case hex.
    pub sha256: String,
    /// Size in bytes.
    pub bytes: u64,
}

/// What identifies a run: inputs, configuration, tool, date and command line.
pub struct Identification {
    /// The input files with their SHA-256.
    pub inputs: Vec<InputFile>,
    /// The configuration as named (a path, an embedded configuration, or made from the
    /// recording), its SHA-256 and its text.
    pub config_shown: String,
    /// See `config_shown`.
    pub config_sha256: String,
    /// See `config_shown`.
    pub config_text: String,
    /// The command line as a shell would take it back.
    pub command_line: String,
    /// The date and time of the run (UTC).
    pub date_utc: String,
    /// The unit the data are of (empty: unknown).
    pub unit: calib::config::UnitIdentity,
    /// What the run assumed for want of an input.
    pub assumptions: Vec<String>,
}

impl Identification {
    /// Add the run's unit, assumptions and the inputs its provenance hashed (the import's
    /// profile and raw files) that are not listed yet.
    pub fn with_provenance(
        mut self,
        p: &crate::provenance::RunProvenance,
        assumptions: &[String],
    ) -> Self {
        self.unit = p.unit.clone();
        self.assumptions = assumptions.to_vec();
        for f in &p.inputs {
            if !self.inputs.iter().any(|i| i.sha256 == f.sha256) {
                self.inputs.push(InputFile {
                    role: f.role.clone(),
                    path: PathBuf::from(&f.path),
                    sha256: f.sha256.clone(),
                    bytes: f.bytes,
                });
            }
        }
        self
    }
}

/// Identify a run of `sins-calib`: hash the `inputs` (role, path) and the configuration given
/// as `config_arg` (a file or an embedded name), with the program file it names.
pub fn identify(
    inputs: &[(&'static str, &Path)],
    config_arg: Option<&str>,
    config: &RunConfig,
) -> Result<Identification, Error> {
    let mut files = Vec::new();
    let mut add = |role: &'static str, path: &Path| -> Result<(), Error> {
        let (sha256, bytes) = crate::provenance::sha256::of_file(path)?;
        files.push(InputFile {
            role: role.to_string(),
            path: path.to_path_buf(),
            sha256,
            bytes,
        });
        Ok(())
    };
    for (role, path) in inputs {
        add(role, path)?;
    }
    let (config_shown, config_text) = match config_arg {
        // Made from the recording (`--free-motion` without --config): shown as used.
        None => (
            "<made from the recording (--free-motion)>".to_string(),
            fields_used(&config.to_toml()?),
        ),
        Some("paper") => (
            "<embedded paper config>".to_string(),
            calib::config::PAPER_CONFIG_TOML.to_string(),
        ),
        Some("paper-reconciled") => (
            "<embedded paper-reconciled config>".to_string(),
            calib::paper::PAPER_RECONCILED_TOML.to_string(),
        ),
        Some(path) => {
            let text = sins_model::text::read_text_bounded(
                std::path::Path::new(path),
                sins_model::text::CONFIGURATION_MAX_BYTES,
                "configuration",
            )
            .map_err(|e| format!("{path}: cannot read the configuration again: {e}"))?;
            (path.to_string(), text)
        }
    };
    if let Some(program) = program_file(config) {
        add("rotation program", &program)?;
    }
    Ok(Identification {
        inputs: files,
        config_sha256: crate::provenance::sha256::of_bytes(config_text.as_bytes()),
        config_shown,
        config_text,
        command_line: command_line(),
        date_utc: utc_now(),
        unit: Default::default(),
        assumptions: Vec::new(),
    })
}

/// The fields of a configuration made from a hand-turned recording that its run uses: without
/// a program, turntable angles or a simulation, the `program = "from-angles"` line, `[clock]`,
/// `[truth]` and the turntable's priors, noise and rates are left out (the report shows the
/// configuration as the run used it; docs/report.md).
fn fields_used(toml: &str) -> String {
    const UNUSED: [(&str, &str); 6] = [
        ("noise", "angle_arcsec"),
        ("priors", "install_misalignment_deg"),
        ("priors", "tau_s"),
        ("priors", "base_misalignment_arcsec"),
        ("filter", "turntable_rate_hz"),
        ("filter", "estimate_base_misalignment"),
    ];
    let unused_section = |s: &str| s == "clock" || s == "truth" || s.starts_with("truth.");
    let mut section = String::new();
    let mut out = String::new();
    for line in toml.lines() {
        let t = line.trim();
        if let Some(name) = t.strip_prefix('[').and_then(|x| x.strip_suffix(']')) {
            section = name.trim().to_string();
        }
        let key = t.split('=').next().unwrap_or("").trim();
        let drop = unused_section(&section)
            || (section.is_empty() && key == "program")
            || UNUSED.iter().any(|(s, k)| *s == section && *k == key);
        if !drop {
            out.push_str(line);
            out.push('\n');
        }
    }
    // No blank line where a dropped section or the program line was.
    let mut tidy = String::new();
    for line in out.lines() {
        if line.trim().is_empty() && (tidy.is_empty() || tidy.ends_with("\n\n")) {
            continue;
        }
        tidy.push_str(line);
        tidy.push('\n');
    }
    while tidy.ends_with("\n\n") {
        tidy.pop();
    }
    tidy
}

/// The program file a configuration names (none for the embedded program, an inline one, or
/// one read from the angles).
pub(crate) fn program_file(config: &RunConfig) -> Option<PathBuf> {
    if config.inline_program.is_some() || config.program == "paper" || config.program_from_angles()
    {
        return None;
    }
    Some(match &config.base_dir {
        Some(d) => d.join(&config.program),
        None => PathBuf::from(&config.program),
    })
}

/// The command line as a shell would take it back (arguments quoted where needed).
fn command_line() -> String {
    std::env::args()
        .enumerate()
        .map(|(i, a)| {
            let a = if i == 0 { "sins-calib".to_string() } else { a };
            let plain = !a.is_empty()
                && a.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
            if plain {
                a
            } else {
                format!("'{}'", a.replace('\'', r"'\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Days since 1970-01-01 as (year, month, day) in the proleptic Gregorian calendar
/// (H. Hinnant's `civil_from_days`).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

/// Seconds since the Unix epoch as `YYYY-MM-DD HH:MM:SS UTC`.
fn utc_text(seconds: i64) -> String {
    let (days, secs) = (seconds.div_euclid(86_400), seconds.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC",
        secs / 3600,
        secs / 60 % 60,
        secs % 60
    )
}

/// The system clock's date and time (UTC).
fn utc_now() -> String {
    match std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH) {
        Ok(d) => utc_text(d.as_secs() as i64),
        Err(_) => "unknown (the system clock is before 1970)".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_configuration_made_from_a_recording_shows_the_fields_used() {
        let mut c = RunConfig::paper();
        c.program = calib::config::PROGRAM_FROM_ANGLES.to_string();
        let text = fields_used(&c.to_toml().unwrap());
        for gone in [
            "program",
            "[clock]",
            "[truth",
            "angle_arcsec",
            "tau_s",
            "turntable_rate",
        ] {
            assert!(!text.contains(gone), "{gone} in\n{text}");
        }
        for kept in [
            "[site]",
            "[priors]",
            "gyro_bias_deg_h",
            "[noise]",
            "accel_m_s2",
            "[filter]",
        ] {
            assert!(text.contains(kept), "{kept} not in\n{text}");
        }
        assert!(
            text.starts_with("[site]") && !text.contains("\n\n\n"),
            "{text}"
        );
        assert!(text.ends_with('\n') && !text.ends_with("\n\n"), "{text}");
    }

    #[test]
    fn dates_are_formatted_from_the_epoch() {
        assert_eq!(utc_text(0), "1970-01-01 00:00:00 UTC");
        // 2000-02-29 (a leap day of a century leap year) 12:34:56.
        assert_eq!(utc_text(951_827_696), "2000-02-29 12:34:56 UTC");
        assert_eq!(utc_text(1_709_251_199), "2024-02-29 23:59:59 UTC");
        assert_eq!(utc_text(4_107_542_400), "2100-03-01 00:00:00 UTC");
        assert_eq!(utc_text(-1), "1969-12-31 23:59:59 UTC");
    }
}
