//! `--report DIR` of `calibrate` and `diagnose` end to end on a short simulated run (a
//! six-position program: 20-s rests joined by turns): the report's sections in order, the
//! SHA-256 of an input against its digest, valid PNG plots, no stale plot of an earlier report,
//! a directory that is a file refused before any work, and a recording of rests without a
//! program reported with its rests named.

use crate::common::{self, run, s, text};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-report", name)
}

/// The program file of the run. Its SHA-256 is [`PROGRAM_SHA256`] (taken with `sha256sum`).
const PROGRAM: &str = r#"name = "six faces"
start_deg = [0.0, 0.0, 0.0]

[[segment]]
kind = "dwell"
duration_s = 20.0

[[segment]]
kind = "rotate"
gimbal = 3
rate_deg_s = 10.0
duration_s = 9.0

[[segment]]
kind = "dwell"
duration_s = 20.0

[[segment]]
kind = "rotate"
gimbal = 3
rate_deg_s = 10.0
duration_s = 9.0

[[segment]]
kind = "dwell"
duration_s = 20.0

[[segment]]
kind = "rotate"
gimbal = 3
rate_deg_s = 10.0
duration_s = 9.0

[[segment]]
kind = "dwell"
duration_s = 20.0

[[segment]]
kind = "rotate"
gimbal = 2
rate_deg_s = 10.0
duration_s = 9.0

[[segment]]
kind = "dwell"
duration_s = 20.0

[[segment]]
kind = "rotate"
gimbal = 2
rate_deg_s = 20.0
duration_s = 9.0

[[segment]]
kind = "dwell"
duration_s = 20.0
"#;
const PROGRAM_SHA256: &str = "44f3df484973820834ff530f397fd769e6c461d1991748e49119a8a205616d85";

/// `examples/run.toml` with [`PROGRAM`], and the same without a program (a recording of
/// rests), into `dir`; a run simulated with the program into `dir/run`.
fn simulated(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    std::fs::write(dir.join("six.toml"), PROGRAM).expect("program");
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let example = std::fs::read_to_string(&example).expect("examples/run.toml");
    let line = "program = \"paper\"";
    assert!(example.contains(line), "examples/run.toml has no `{line}`");
    let (with, without) = (dir.join("with-program.toml"), dir.join("rests.toml"));
    std::fs::write(&with, example.replace(line, "program = \"six.toml\"")).expect("config");
    std::fs::write(&without, example.replace(line, "")).expect("config");
    let out = dir.join("run");
    let sim = run(&["simulate", "--config", s(&with), "--out", s(&out)]);
    assert!(sim.status.success(), "{}", text(&sim.stderr));
    (with, without, out)
}

/// A PNG file: the signature, an IHDR chunk first and an IEND chunk last.
fn assert_png(path: &Path) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        bytes.len() > 1000,
        "{}: {} bytes",
        path.display(),
        bytes.len()
    );
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", path.display());
    assert_eq!(&bytes[12..16], b"IHDR", "{}", path.display());
    assert_eq!(
        &bytes[bytes.len() - 8..bytes.len() - 4],
        b"IEND",
        "{}",
        path.display()
    );
}

/// The report's sections, in order, and its plots valid PNG files.
fn assert_report(dir: &Path, sections: &[&str]) -> String {
    let md = std::fs::read_to_string(dir.join("report.md")).expect("report.md");
    let mut at = 0;
    for section in sections {
        let found = md[at..].find(section);
        assert!(
            found.is_some(),
            "`{section}` missing or out of order:\n{md}"
        );
        at += found.unwrap_or(0);
    }
    let mut plots = 0;
    for entry in std::fs::read_dir(dir).expect("report directory") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "png") {
            assert_png(&path);
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            assert!(
                md.contains(&format!("]({name})")),
                "{name} is not in report.md"
            );
            plots += 1;
        }
    }
    // The correlations, and per measurement residuals, NIS, spectrum and autocorrelation.
    assert!(plots >= 5, "{plots} plots");
    assert_html(dir, &md, plots);
    md
}

/// `report.html`: one self-contained page with everything of report.md. No reference to
/// anything outside it (no `src` or `href` to the network, no script), every image one of the
/// report's PNGs as a `data:` URI, the correction matrices and every correlation of 0.9 or
/// more explained.
fn assert_html(dir: &Path, md: &str, plots: usize) {
    let html = std::fs::read_to_string(dir.join("report.html")).expect("report.html");
    assert!(html.starts_with("<!DOCTYPE html>"), "{}", &html[..100]);
    for outside in [
        "src=\"http",
        "href=\"http",
        "src='http",
        "<script",
        "<link",
        "@import",
        "url(",
    ] {
        assert!(!html.contains(outside), "report.html has `{outside}`");
    }
    let images: Vec<&str> = html.split("<img ").skip(1).collect();
    assert_eq!(images.len(), plots, "one <img> per plot");
    for img in &images {
        assert!(
            img.starts_with("src=\"data:image/png;base64,iVBORw0KGgo"),
            "{}",
            &img[..80.min(img.len())]
        );
    }
    // The headings and the correction matrices of report.md, in the page.
    for line in md
        .lines()
        .filter(|l| l.starts_with("## ") || l.starts_with("### "))
    {
        let heading = line.trim_start_matches('#').trim();
        assert!(
            html.contains(&format!(">{heading}</h")),
            "heading `{heading}` not in report.html"
        );
    }
    for needle in [
        ">M_g x</th>",
        ">b_g [rad/s]</th>",
        ">M_a z</th>",
        "<th>test</th>",
    ] {
        assert!(html.contains(needle), "`{needle}` not in report.html");
    }
    // Every correlation of 0.9 or more in the table has its sentence, in both.
    let mut strong = 0;
    for row in md
        .lines()
        .filter(|l| l.starts_with("| ") && l.ends_with(" |"))
    {
        let cells: Vec<&str> = row.trim_matches('|').split('|').map(str::trim).collect();
        if cells.len() != 3 {
            continue;
        }
        let Ok(r) = cells[2].parse::<f64>() else {
            continue;
        };
        if r.abs() >= 0.9 {
            strong += 1;
            let sentence = format!(
                "`{}` and `{}` are correlated at {}",
                cells[0], cells[1], cells[2]
            );
            assert!(
                md.contains(&sentence),
                "no sentence `{sentence}` in report.md"
            );
            let in_html = format!(
                "<code>{}</code> and <code>{}</code> are correlated at {}",
                cells[0], cells[1], cells[2]
            );
            assert!(
                html.contains(&in_html),
                "no sentence `{in_html}` in report.html"
            );
        }
    }
    if strong == 0 {
        assert!(
            md.contains("No two estimates are correlated at 0.9 or more"),
            "{md}"
        );
    }
}

const CALIBRATION_SECTIONS: [&str; 8] = [
    "# Calibration report",
    "## 1. Identification",
    "## 2. Verdict",
    "## 3. Parameters",
    "## 4. Correlation of the estimates",
    "## 5. Residuals",
    "## 6. NIS per segment",
    "## Further diagnostics",
];

#[test]
fn calibrate_and_diagnose_write_the_report_a_lab_files() {
    let dir = scratch("six");
    let (with, _, out) = simulated(&dir);
    let (imu, tt) = (out.join("imu.csv"), out.join("turntable.csv"));
    let report = dir.join("report");
    // An earlier report with the turntable angles left a plot an IMU-only report has not.
    std::fs::create_dir_all(&report).expect("report directory");
    std::fs::write(report.join("residuals_turntable.png"), "stale").expect("stale plot");
    let cal = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--config",
        s(&with),
        "--truth",
        s(&out.join("truth.json")),
        "--report",
        s(&report),
    ]);
    let stdout = text(&cal.stdout);
    assert!(cal.status.success(), "{stdout}\n{}", text(&cal.stderr));
    assert!(stdout.contains("wrote the report"), "{stdout}");
    assert!(
        !report.join("residuals_turntable.png").exists(),
        "a stale plot survived"
    );
    let md = assert_report(&report, &CALIBRATION_SECTIONS);
    // The program file named by the configuration, identified by its digest; the
    // configuration's text embedded; scale factors in ppm; the truth's errors in sigmas.
    assert!(
        md.contains(&format!(
            "| rotation program | `../six.toml` | {} | `{PROGRAM_SHA256}` |",
            PROGRAM.len()
        )),
        "{md}"
    );
    assert!(md.contains("program = \"six.toml\""), "{md}");
    assert!(
        md.contains("| gyro.theta.xx |") && md.contains("| ppm |"),
        "{md}"
    );
    assert!(md.contains("error/sigma") && md.contains("NEES"), "{md}");
    assert!(md.contains("| specific force | "), "{md}");
    assert!(report.join("residuals_accel.png").is_file());
    // No temporary directory is left beside the report.
    let beside: Vec<String> = std::fs::read_dir(&dir)
        .expect("dir")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(beside.is_empty(), "{beside:?}");

    // diagnose into the same directory: replaced whole, with the model-extension table.
    let diag = run(&[
        "diagnose",
        "--imu",
        s(&imu),
        "--turntable",
        s(&tt),
        "--config",
        s(&with),
        "--report",
        s(&report),
    ]);
    let stdout = text(&diag.stdout);
    assert!(diag.status.success(), "{stdout}\n{}", text(&diag.stderr));
    let mut sections = CALIBRATION_SECTIONS;
    sections[0] = "# Model diagnosis report";
    sections[7] = "## 7. Model extension";
    let md = assert_report(&report, &sections);
    assert!(md.contains("| turntable angles |"), "{md}");
    assert!(report.join("residuals_turntable.png").is_file());
    assert!(
        md.contains("cycle") || md.contains("dwell"),
        "segments not named:\n{md}"
    );
}

#[test]
fn a_recording_of_rests_is_reported_with_its_rests_named() {
    let dir = scratch("rests");
    let (_, without, out) = simulated(&dir);
    let report = dir.join("report");
    let cal = run(&[
        "calibrate",
        "--imu",
        s(&out.join("imu.csv")),
        "--config",
        s(&without),
        "--report",
        s(&report),
    ]);
    let stdout = text(&cal.stdout);
    assert!(cal.status.success(), "{stdout}\n{}", text(&cal.stderr));
    let md = assert_report(&report, &CALIBRATION_SECTIONS);
    assert!(
        md.contains("| rest 1 |") && md.contains("| rest 6 |"),
        "{md}"
    );
}

#[test]
fn a_report_directory_that_is_a_file_is_refused_before_any_work() {
    let dir = scratch("refused");
    let imu = dir.join("imu.csv");
    // Not even a valid recording: the refusal comes before anything is read.
    std::fs::write(&imu, "t,wx,wy,wz,fx,fy,fz\n").expect("imu");
    let file = dir.join("report.md");
    std::fs::write(&file, "mine").expect("file");
    let json = dir.join("result.json");
    for command in ["calibrate", "diagnose"] {
        let out = run(&[
            command,
            "--imu",
            s(&imu),
            "--config",
            "paper",
            "--json",
            s(&json),
            "--report",
            s(&file),
        ]);
        assert_eq!(out.status.code(), Some(1), "{command}");
        let err = text(&out.stderr);
        assert!(
            err.contains("--report") && err.contains("is a file"),
            "{command}: {err}"
        );
        assert!(!json.exists(), "{command} wrote its JSON before refusing");
        assert_eq!(std::fs::read_to_string(&file).expect("file"), "mine");
    }
    // --report names the input itself: refused too.
    let out = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--config",
        "paper",
        "--report",
        s(&imu),
    ]);
    assert_eq!(out.status.code(), Some(1));
}
