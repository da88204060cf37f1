//! `sins-calib import`: a recording in another layout turned into `imu.csv` (and
//! `turntable.csv`, `sections.json`) by an import profile; the work is the `import` crate's.

mod bag;

use crate::render::table;
use crate::{Error, output, print};
use ::import::profile::Profile;
use ::import::{ImportOptions, ImportReport, ImportedFiles, Written, import_into};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `import`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Import profile (TOML, docs/formats.md "Import profile"): the input files, their layout,
    /// which column is which, the time base, units, axis mapping and sensor ranges. Relative
    /// paths in it resolve against its own directory. Ready profiles: examples/xsens_mti.toml,
    /// examples/ferraris_session.toml.
    #[arg(
        long,
        value_name = "FILE",
        required_unless_present = "bag",
        conflicts_with = "bag"
    )]
    pub profile: Option<PathBuf>,
    /// Instead of a profile: a ROS 1 bag (.bag) or an MCAP file (.mcap, ROS 2 messages in CDR),
    /// told apart by their first bytes; the sensor_msgs/Imu messages on --topic become the
    /// records, at their header stamps, in rad/s and m/s^2 as the messages carry them
    /// (docs/formats.md, "ROS recordings").
    #[arg(long, value_name = "FILE", requires = "topic")]
    pub bag: Option<PathBuf>,
    /// The topic of the bag to import (e.g. /imu/data).
    #[arg(long, value_name = "TOPIC", requires = "bag")]
    pub topic: Option<String>,
    /// Directory to write imu.csv, import.json and, where the source has them, turntable.csv and
    /// sections.json into; created when missing. Nothing is written when the import is refused;
    /// otherwise the files of an earlier import are replaced together (a turntable.csv or
    /// sections.json this import does not write is removed, other files are kept). A directory
    /// holding the import's own input under one of these names is refused.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Import a recording with gaps (intervals longer than the profile's checks.gap_factor,
    /// default 1.5, times the median interval) as it is, each gap printed and recorded in
    /// import.json. Without it such a recording is refused at its first gap; gaps are never
    /// bridged.
    #[arg(long)]
    pub allow_gaps: bool,
}

/// Every file `import` may write into its directory.
pub(crate) const OUTPUTS: [&str; 4] = ["imu.csv", "turntable.csv", "sections.json", "import.json"];

/// Run `import`.
pub fn run(args: &Args) -> Result<(), Error> {
    if let (Some(bag), Some(topic)) = (&args.bag, &args.topic) {
        return bag::run(bag, topic, args);
    }
    let profile_path = args.profile.as_ref().expect("clap: --profile or --bag");
    let profile = Profile::load(profile_path)?;
    let mut inputs: Vec<PathBuf> = profile.input_files().into_iter().map(|(_, p)| p).collect();
    inputs.push(profile_path.clone());
    if let Some(s) = &profile.sections {
        inputs.push(profile.resolve(&s.file));
    }
    let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    let options = ImportOptions {
        allow_gaps: args.allow_gaps,
    };
    let (out, imported) = import_atomically(&args.out, &inputs, |dir| {
        import_into(&profile, &options, dir)
    })?;
    let tmp = &imported.written;
    stamp_outputs(
        profile_path,
        &profile,
        &imported.report,
        imported.sections.as_ref(),
        tmp,
    )?;
    let written = Written {
        imu: out.final_path("imu.csv"),
        turntable: tmp
            .turntable
            .as_ref()
            .map(|_| out.final_path("turntable.csv")),
        sections: tmp
            .sections
            .as_ref()
            .map(|_| out.final_path("sections.json")),
        report: out.final_path("import.json"),
    };
    out.commit()?;
    let r = &imported.report;
    let c = table::compact;

    let mut s = String::new();
    let _ = writeln!(s, "sins-calib import: {}", profile_path.display());
    if let Some(d) = &r.description {
        let _ = writeln!(s, "  {d}");
    }
    if !profile.unit.is_empty() {
        let _ = writeln!(s, "  unit: {}", profile.unit.describe());
    }
    for i in &r.inputs {
        let _ = writeln!(
            s,
            "  read {} ({}): {} data rows, lines {}..{}",
            i.file, i.role, i.rows, i.first_line, i.last_line
        );
    }
    let tm = &r.timing;
    let _ = writeln!(
        s,
        "  time: t = {} .. {} s, {} records, median interval {} s ({} Hz), intervals {} .. {} s \
         (each record keeps its own time stamp)",
        c(r.t_first_s),
        c(r.t_last_s),
        r.records,
        c(tm.median_interval_s),
        c(1.0 / tm.median_interval_s),
        c(tm.min_interval_s),
        c(tm.max_interval_s)
    );
    s += &gap_lines(r);
    s += &saturation_lines(r);
    s += &static_force_line(r);
    s += &written_lines(&imported, &written);
    let _ = writeln!(s, "  wrote {}", written.report.display());
    print(&s)
}

/// Write the JSON files the `import` crate wrote again with their schema stamp first (the
/// same contents in the same order), and `import.json` with the profile's `[unit]` and the
/// SHA-256 of the profile, the raw files and the files written
/// (`crate::provenance::ImportProvenance`): a calibration of the imported records names them.
fn stamp_outputs(
    profile_path: &std::path::Path,
    profile: &Profile,
    report: &ImportReport,
    sections: Option<&::import::sections::SectionsFile>,
    written: &Written,
) -> Result<(), Error> {
    use crate::provenance::{ImportProvenance, InputHash};
    #[derive(serde::Serialize)]
    struct ImportJson<'a> {
        #[serde(flatten)]
        report: &'a ImportReport,
        #[serde(flatten)]
        provenance: ImportProvenance,
    }
    let write = |p: &std::path::Path, text: String| -> Result<(), Error> {
        std::fs::write(p, text).map_err(|e| format!("{}: cannot write: {e}", p.display()).into())
    };
    let mut output_sha256 = std::collections::BTreeMap::new();
    output_sha256.insert(
        "imu.csv".to_string(),
        crate::provenance::sha256::of_file(&written.imu)?.0,
    );
    if let Some(p) = &written.turntable {
        output_sha256.insert(
            "turntable.csv".into(),
            crate::provenance::sha256::of_file(p)?.0,
        );
    }
    if let (Some(p), Some(sections)) = (&written.sections, sections) {
        write(
            p,
            calib::io::schema::to_json(calib::io::schema::SECTIONS, sections)?,
        )?;
        output_sha256.insert(
            "sections.json".into(),
            crate::provenance::sha256::of_file(p)?.0,
        );
    }
    let mut input_files = vec![InputHash::of("import profile", profile_path)?];
    for (role, p) in profile.input_files() {
        input_files.push(InputHash::of(&format!("raw {role} file"), &p)?);
    }
    if let Some(s) = &profile.sections {
        input_files.push(InputHash::of(
            "raw section list",
            &profile.resolve(&s.file),
        )?);
    }
    let json = ImportJson {
        report,
        provenance: ImportProvenance {
            unit: profile.unit.clone(),
            input_files,
            output_sha256,
        },
    };
    write(
        &written.report,
        calib::io::schema::to_json(calib::io::schema::IMPORT, &json)?,
    )
}

/// Check `out` (against the `inputs`), then import into a temporary directory beside it
/// (removed on a refusal, with the directories made for it): the output and what was imported.
pub(crate) fn import_atomically(
    out_dir: &std::path::Path,
    inputs: &[&std::path::Path],
    import: impl FnOnce(&std::path::Path) -> Result<ImportedFiles, ::import::ImportError>,
) -> Result<(output::DirOutput, ImportedFiles), Error> {
    output::Outputs::new(inputs).dir(out_dir, "--out", &OUTPUTS)?;
    // Read, converted and written row by row into the temporary directory (removed on a
    // refusal): the memory does not grow with the recording.
    let created = missing_ancestors(out_dir);
    let out = output::DirOutput::begin(out_dir, &OUTPUTS)?;
    match import(out.tmp_dir()) {
        Ok(imported) => Ok((out, imported)),
        Err(e) => {
            // Nothing is left of a refused import: the temporary directory goes with `out`,
            // and the directories made for it (deepest first; only when empty).
            drop(out);
            for d in created {
                let _ = std::fs::remove_dir(d);
            }
            Err(e.into())
        }
    }
}

/// The directories above `out` that do not exist yet, deepest first.
fn missing_ancestors(out: &std::path::Path) -> Vec<PathBuf> {
    let absolute = std::path::absolute(out).unwrap_or_else(|_| out.to_path_buf());
    absolute
        .ancestors()
        .skip(1)
        .take_while(|d| !d.as_os_str().is_empty() && !d.exists())
        .map(std::path::Path::to_path_buf)
        .collect()
}

/// The specific force at rest the import found (the quietest second's median |f|), as a line
/// of the printout.
pub(crate) fn static_force_line(r: &ImportReport) -> String {
    let f = &r.static_force;
    format!(
        "  specific force at rest: median |f| = {} m/s^2 ({} g) over t = {} .. {} s (the \
         quietest second)\n",
        table::significant(f.median_norm_m_s2, 5),
        table::significant(f.ratio_to_g, 4),
        table::compact(f.window_s[0]),
        table::compact(f.window_s[1])
    )
}

/// The gaps of the time stamps, or that there are none.
pub(crate) fn gap_lines(r: &ImportReport) -> String {
    let c = table::compact;
    let mut s = String::new();
    let tm = &r.timing;
    if r.gaps.is_empty() {
        let _ = writeln!(
            s,
            "  gaps: none (no interval longer than {} median intervals)",
            c(tm.gap_factor)
        );
    } else {
        let _ = writeln!(
            s,
            "  gaps: {} (kept as they are, --allow-gaps; recorded in import.json):",
            r.gaps.len()
        );
        for g in &r.gaps {
            let _ = writeln!(
                s,
                "    {} s ({:.1} median intervals) between t = {} s and t = {} s, {} line {}",
                c(g.length_s),
                g.median_intervals,
                c(g.t_before_s),
                c(g.t_after_s),
                g.file,
                g.line
            );
        }
    }
    s
}

/// The saturation of each sensor with a range.
fn saturation_lines(r: &ImportReport) -> String {
    let c = table::compact;
    let mut s = String::new();
    for sat in &r.saturation {
        match sat.first_line {
            None => {
                let _ = writeln!(
                    s,
                    "  saturation: {} none (range {} .. {} in the file's values)",
                    sat.sensor,
                    c(sat.range[0]),
                    c(sat.range[1])
                );
            }
            Some(line) => {
                let _ = writeln!(
                    s,
                    "  saturation: {} {} records at or beyond the range {} .. {} in {} \
                     stretches, the first at {} line {} (recorded in import.json)",
                    sat.sensor,
                    sat.count,
                    c(sat.range[0]),
                    c(sat.range[1]),
                    sat.stretches.len(),
                    sat.file,
                    line
                );
            }
        }
    }
    s
}

/// The files written (but `import.json`), with the sections carried over.
fn written_lines(imported: &ImportedFiles, written: &Written) -> String {
    let c = table::compact;
    let mut s = String::new();
    let r = &imported.report;
    let _ = writeln!(
        s,
        "  wrote {}: {} records, {}",
        written.imu.display(),
        r.records,
        if r.form == "rates" {
            "rates (rad/s, m/s^2)"
        } else {
            "increments (rad, m/s)"
        }
    );
    if let Some(p) = &written.turntable {
        let _ = writeln!(s, "  wrote {}: {} records", p.display(), r.records);
    }
    if let (Some(p), Some(sections)) = (&written.sections, &imported.sections) {
        let _ = writeln!(
            s,
            "  wrote {}: {} sections",
            p.display(),
            sections.sections.len()
        );
        for x in &sections.sections {
            let what = match (x.up, x.axis) {
                (Some(up), _) => format!("static, up = {}", axis_name(up)),
                (_, Some(axis)) => format!(
                    "rotation about {}, expected {} deg, gyro integrates to {} deg",
                    axis_name(axis),
                    c(x.expected_turn_deg.unwrap_or(f64::NAN)),
                    table::significant(x.measured_turn_deg.unwrap_or(f64::NAN), 4)
                ),
                _ => String::new(),
            };
            let _ = writeln!(
                s,
                "    {:<6} t = {:>7} .. {:>7} s  {:>4} records  {what}",
                x.name,
                table::significant(x.start_s, 4),
                table::significant(x.end_s, 4),
                x.last_record - x.first_record + 1
            );
        }
    }
    s
}

/// `+x`, `-z`, ... for a signed unit vector along an axis; the components otherwise.
fn axis_name(v: [f64; 3]) -> String {
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        if v[k].abs() == 1.0 && v.iter().filter(|x| **x == 0.0).count() == 2 {
            return format!("{}{name}", if v[k] > 0.0 { '+' } else { '-' });
        }
    }
    format!("[{}, {}, {}]", v[0], v[1], v[2])
}
