//! Import profiles on small made-up recordings: parsing and refusals, counts conversion, axis
//! mapping and sign flips, two files joined, jitter kept, gaps, saturation, a specific force that
//! is not g.

mod common;

use common::{Imported, import_to};
use import::profile::Profile;
use import::{ImportError, ImportOptions};
use sha2::Digest;
use std::path::{Path, PathBuf};

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("import-profiles")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// Write `files` (name, text) and the profile `toml` into `dir`; parse the profile.
fn setup(dir: &Path, toml: &str, files: &[(&str, String)]) -> Result<Profile, ImportError> {
    for (name, text) in files {
        std::fs::write(dir.join(name), text).expect("data file");
    }
    let path = dir.join("profile.toml");
    std::fs::write(&path, toml).expect("profile");
    Profile::load(&path)
}

fn import(dir: &Path, toml: &str, files: &[(&str, String)]) -> Result<Imported, ImportError> {
    import_with(&setup(dir, toml, files)?, &ImportOptions::default())
}

/// The import of the recording `profile` (in a test's scratch directory) into a fresh
/// directory there, read back, and checked against what the code gave before the import had one
/// implementation: the same refusal, or the same files (their SHA-256 in
/// `fixtures/profiles_outputs.txt`; `fixtures/README.md` says how they were made).
fn import_with(profile: &Profile, options: &ImportOptions) -> Result<Imported, ImportError> {
    let base = Path::new(&profile.origin).parent().unwrap().to_path_buf();
    let name = base.file_name().unwrap().to_str().unwrap().to_string();
    // The imports of one test run one after the other: the n-th of its directory is its key.
    static IMPORTS: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let n = {
        let mut imports = IMPORTS.lock().unwrap();
        imports.push(name.clone());
        imports.iter().filter(|x| **x == name).count()
    };
    let key = format!("{name}-{n}");
    let imported = import_to(profile, options, &base.join(format!("out-{n}")));
    // Paths in messages and reports are the scratch directory's: masked.
    let tmp = Path::new(env!("CARGO_TARGET_TMPDIR")).join("import-profiles");
    let mask = |text: &str| text.replace(tmp.to_str().unwrap(), "<tmp>");
    let mut found = Vec::new();
    match &imported {
        Err(e) => found.push(format!("{key} refused {:?}", mask(&e.to_string()))),
        Ok(i) => {
            let w = &i.written;
            for p in [
                Some(&w.imu),
                w.turntable.as_ref(),
                w.sections.as_ref(),
                Some(&w.report),
            ]
            .into_iter()
            .flatten()
            {
                let text = mask(&std::fs::read_to_string(p).unwrap());
                let digest = sha2::Sha256::digest(text.as_bytes());
                let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
                let file = p.file_name().unwrap().to_str().unwrap();
                found.push(format!("{key} {file} {hex}"));
            }
        }
    }
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/profiles_outputs.txt");
    let fixture = std::fs::read_to_string(fixture).expect("fixtures/profiles_outputs.txt");
    let prefix = format!("{key} ");
    let expected: Vec<&str> = fixture.lines().filter(|l| l.starts_with(&prefix)).collect();
    assert_eq!(found, expected, "{key}: the outputs before");
    imported
}

/// `n` rows at 100 Hz of `t,gx,gy,gz,ax,ay,az` (rates in deg/s, force in m/s^2) at rest with z
/// up; `t_of(i)` gives the time of row i.
fn rest_csv(n: usize, t_of: impl Fn(usize) -> f64) -> String {
    let mut s = String::from("time,gx,gy,gz,ax,ay,az\n");
    for i in 0..n {
        s += &format!("{},0.5,-0.25,1.0,0.1,-0.2,9.8\n", t_of(i));
    }
    s
}

const REST_PROFILE: &str = r#"
form = "rates"
[input]
file = "data.csv"
skip_lines = 1
header_line = 1
[time]
column = "time"
[gyro]
columns = ["gx", "gy", "gz"]
unit = "deg/s"
[accel]
columns = ["ax", "ay", "az"]
unit = "m/s^2"
"#;

fn message(e: ImportError) -> String {
    e.to_string()
}

#[test]
fn a_plain_profile_imports_and_converts_units() {
    let dir = scratch("plain");
    let imported = import(
        &dir,
        REST_PROFILE,
        &[("data.csv", rest_csv(300, |i| i as f64 * 0.01))],
    )
    .unwrap();
    let r = &imported.imu.records[5];
    let d = std::f64::consts::PI / 180.0;
    assert_eq!(r.gyro, [0.5 * d, -0.25 * d, 1.0 * d]);
    assert_eq!(r.accel, [0.1, -0.2, 9.8]);
    assert_eq!(imported.report.records, 300);
    assert_eq!(imported.report.inputs[0].first_line, 2);
    assert!(imported.report.gaps.is_empty());
    let written = &imported.written;
    assert!(written.turntable.is_none() && written.sections.is_none());
}

#[test]
fn unknown_keys_are_refused_with_their_line() {
    let dir = scratch("unknown-key");
    let toml = REST_PROFILE.replace("unit = \"deg/s\"", "unit = \"deg/s\"\nscale = 2.0");
    let e = message(setup(&dir, &toml, &[]).unwrap_err());
    assert!(e.contains("profile.toml"), "{e}");
    assert!(e.contains("unknown field `scale`"), "{e}");
    assert!(e.contains("line 12"), "{e}");
}

#[test]
fn bad_units_are_refused_naming_the_valid_ones() {
    let dir = scratch("bad-unit");
    let toml = REST_PROFILE.replace("unit = \"deg/s\"", "unit = \"deg/sec\"");
    let e = message(setup(&dir, &toml, &[]).unwrap_err());
    assert!(e.contains("unknown variant `deg/sec`"), "{e}");
    assert!(e.contains("`deg/s`"), "{e}");
    // A unit of the wrong kind for the sensor.
    let toml = REST_PROFILE.replace("unit = \"m/s^2\"", "unit = \"deg/s\"");
    let e = message(setup(&dir, &toml, &[]).unwrap_err());
    assert!(e.contains("[accel] unit = \"deg/s\""), "{e}");
    assert!(e.contains("\"m/s^2\", \"g\""), "{e}");
    // Counts without their conversion.
    let toml = REST_PROFILE.replace("unit = \"m/s^2\"", "unit = \"counts\"");
    let e = message(setup(&dir, &toml, &[]).unwrap_err());
    assert!(e.contains("needs offset"), "{e}");
}

#[test]
fn other_profile_mistakes_are_refused() {
    let dir = scratch("mistakes");
    let cases = [
        (
            REST_PROFILE.replace("header_line = 1\n", ""),
            "expected [input] header_line",
        ),
        (
            REST_PROFILE.replace("column = \"time\"", "column = \"time\"\nrate_hz = 100.0"),
            "expected one time base",
        ),
        (
            REST_PROFILE.replace(
                "unit = \"deg/s\"",
                "unit = \"deg/s\"\naxes = [\"+x\", \"-x\", \"z\"]",
            ),
            "source axis x is used twice",
        ),
        (
            REST_PROFILE.replace(
                "unit = \"deg/s\"",
                "unit = \"deg/s\"\naxes = [\"+x\", \"+w\", \"z\"]",
            ),
            "axis `+w`",
        ),
        (
            // Two axes swapped: a reflection, under which every turn is read backwards.
            REST_PROFILE.replace(
                "unit = \"deg/s\"",
                "unit = \"deg/s\"\naxes = [\"+y\", \"+x\", \"+z\"]",
            ),
            "not a rotation",
        ),
        (
            REST_PROFILE.replace("skip_lines = 1", "skip_lines = 1\ndelimiter = \"1\""),
            "delimiter `1`",
        ),
        (
            REST_PROFILE.replace("columns = [\"gx\", \"gy\", \"gz\"]", "columns = [0, 2, 3]"),
            "column 0",
        ),
        (
            REST_PROFILE.replace("file = \"data.csv\"", "gyro_file = \"data.csv\""),
            "both gyro_file and accel_file",
        ),
        (
            REST_PROFILE.replace(
                "column = \"time\"",
                "counter_column = \"time\"\nrate_hz = 10.0\nunit = \"ms\"",
            ),
            "unit applies to a time column",
        ),
        (
            REST_PROFILE.replace("form = \"rates\"", "form = \"increments\""),
            "[gyro] unit = \"deg/s\": expected one of \"rad\", \"deg\" or \"counts\" for gyro increments",
        ),
    ];
    for (toml, needle) in cases {
        let e = message(setup(&dir, &toml, &[]).unwrap_err());
        assert!(e.contains(needle), "expected `{needle}` in: {e}");
        assert!(e.contains("profile.toml"), "{e}");
    }
}

#[test]
fn a_missing_column_is_refused_with_file_and_line() {
    let dir = scratch("missing-column");
    // By name: not on the header line.
    let toml = REST_PROFILE.replace("\"az\"", "\"acc_z\"");
    let e = message(import(&dir, &toml, &[("data.csv", rest_csv(10, |i| i as f64))]).unwrap_err());
    assert!(
        e.contains("data.csv: line 1: no column named `acc_z`"),
        "{e}"
    );
    assert!(e.contains("time, gx, gy, gz, ax, ay, az"), "{e}");
    // By number: a row with too few fields.
    let toml = r#"
form = "rates"
[input]
file = "data.txt"
delimiter = "whitespace"
[time]
column = 1
[gyro]
columns = [2, 3, 4]
unit = "rad/s"
[accel]
columns = [5, 6, 7]
unit = "m/s^2"
"#;
    let text = "0.00 0 0 0 0 0 9.8\n0.01 0 0 0 0 0 9.8\n0.02 0 0 0 0 9.8\n";
    let e = message(import(&dir, toml, &[("data.txt", text.into())]).unwrap_err());
    assert!(
        e.contains("data.txt: line 3: expected at least 7 fields"),
        "{e}"
    );
    assert!(e.contains("accel z (column 7)"), "{e}");
    // A field that is not a number.
    let text = "0.00 0 0 0 0 0 9.8\n0.01 0 0 zero 0 0 9.8\n";
    let e = message(import(&dir, toml, &[("data.txt", text.into())]).unwrap_err());
    assert!(
        e.contains("data.txt: line 2: gyro z (column 4): expected a number, found `zero`"),
        "{e}"
    );
}

#[test]
fn counts_axis_mapping_and_sign_flips() {
    let dir = scratch("counts");
    let toml = r##"
form = "rates"
[input]
file = "raw.txt"
delimiter = ";"
comment = "#"
[time]
column = 1
unit = "ms"
[gyro]
columns = [2, 3, 4]
unit = "counts"
offset = [100.0, 200.0, 300.0]
sensitivity = [10.0, 20.0, 40.0]
sensitivity_unit = "deg/s"
axes = ["-y", "+z", "-x"]
[accel]
columns = [5, 6, 7]
unit = "counts"
offset = [1000.0, 1000.0, 1000.0]
sensitivity = [1000.0, 500.0, 250.0]
sensitivity_unit = "g"
axes = ["+z", "-x", "-y"]
"##;
    // Source gyro (counts): x = 110 -> 1 deg/s, y = 240 -> 2 deg/s, z = 420 -> 3 deg/s.
    // Source accel: x = 1000 -> 0 g, y = 1000 -> 0 g, z = 1250 -> 1 g.
    let mut text = String::from("# made up\n");
    for i in 0..200 {
        text += &format!("{}; 110; 240; 420; 1000; 1000; 1250\n", 10 * i);
    }
    let imported = import(&dir, toml, &[("raw.txt", text)]).unwrap();
    let d = std::f64::consts::PI / 180.0;
    let r = &imported.imu.records[1];
    assert_eq!(r.t, 0.01);
    // Output gyro = (-y, +z, -x) of the source.
    let expect = [-2.0 * d, 3.0 * d, -d];
    for (got, want) in r.gyro.iter().zip(expect) {
        assert!((got - want).abs() < 1e-15, "{:?}", r.gyro);
    }
    // Output accel = (+z, -x, -y) of the source (a rotation): 1 g along x.
    assert_eq!(r.accel, [9.80665, -0.0, 0.0]);
}

fn two_files(dir: &Path, gyro: &str, accel: &str, join: &str) -> Result<Imported, ImportError> {
    let toml = format!(
        r#"
form = "rates"
[input]
gyro_file = "gyro.txt"
accel_file = "acc.txt"
delimiter = "whitespace"
join = "{join}"
[time]
column = 1
[gyro]
columns = [2, 3, 4]
unit = "rad/s"
[accel]
columns = [2, 3, 4]
unit = "m/s^2"
"#
    );
    import(
        dir,
        &toml,
        &[("gyro.txt", gyro.into()), ("acc.txt", accel.into())],
    )
}

fn rows(n: usize, t_of: impl Fn(usize) -> f64, xyz: &str) -> String {
    (0..n)
        .map(|i| format!("  {:.6e}  {xyz}\n", t_of(i)))
        .collect()
}

#[test]
fn two_files_are_joined_on_time_and_jitter_is_kept() {
    let dir = scratch("join");
    // Jittered time stamps as the Xsens recording has them: 9.0 to 10.4 ms.
    let jitter = |i: usize| {
        let base = 0.02984 + i as f64 * 0.01;
        base + [0.0, -0.001, -0.0006, -0.0002][i % 4]
    };
    let g = rows(500, jitter, "0.01 0.02 0.03");
    let a = rows(500, jitter, "0.1 0.2 9.8");
    let imported = two_files(&dir, &g, &a, "time").unwrap();
    assert_eq!(imported.imu.records.len(), 500);
    let r = &imported.imu.records[7];
    assert_eq!((r.gyro, r.accel), ([0.01, 0.02, 0.03], [0.1, 0.2, 9.8]));
    // Every record keeps its own time stamp, through imu.csv and back.
    for (i, r) in imported.imu.records.iter().enumerate() {
        let t: f64 = format!("{:.6e}", jitter(i)).parse().unwrap();
        assert_eq!(r.t, t, "record {i}");
    }
    let timing = imported.report.timing;
    assert!((timing.min_interval_s - 0.009).abs() < 1e-9, "{timing:?}");
    assert!((timing.max_interval_s - 0.0104).abs() < 1e-9, "{timing:?}");
    assert!(imported.report.gaps.is_empty());
    // By row as well.
    assert!(two_files(&dir, &g, &a, "row").is_ok());
}

#[test]
fn rows_without_a_partner_are_refused() {
    let dir = scratch("join-refused");
    let t = |i: usize| i as f64 * 0.01;
    let g = rows(300, t, "0 0 0");
    // The accelerometer file lacks the row at t = 0.05 (its 6th row, line 6).
    let a: String = (0..300)
        .filter(|&i| i != 5)
        .map(|i| format!("{} 0 0 9.8\n", t(i)))
        .collect();
    let e = message(two_files(&dir, &g, &a, "time").unwrap_err());
    assert!(
        e.contains("gyro.txt: line 6: t = 0.05 s has no row with the same time"),
        "{e}"
    );
    assert!(e.contains("acc.txt"), "{e}");
    // Joined by row, the counts differ.
    let a: String = (0..299).map(|i| format!("{} 0 0 9.8\n", t(i))).collect();
    let e = message(two_files(&dir, &g, &a, "row").unwrap_err());
    assert!(e.contains("gyro.txt: line 300: row 300"), "{e}");
}

#[test]
fn time_must_increase() {
    let dir = scratch("time-order");
    let text = rest_csv(50, |i| if i == 20 { 0.19 } else { i as f64 * 0.01 });
    let e = message(import(&dir, REST_PROFILE, &[("data.csv", text)]).unwrap_err());
    assert!(
        e.contains(
            "data.csv: line 22: t = 0.19 s is not after the previous row's t = 0.19 s (line 21)"
        ),
        "{e}"
    );
}

#[test]
fn a_gap_is_refused_with_line_and_length_unless_allowed() {
    let dir = scratch("gap");
    // 0.05 s missing after t = 1.00 (row 100, line 102): 0.06 s to the next row (line 103).
    let t = |i: usize| i as f64 * 0.01 + if i >= 101 { 0.05 } else { 0.0 };
    let text = rest_csv(300, t);
    let e = message(import(&dir, REST_PROFILE, &[("data.csv", text.clone())]).unwrap_err());
    assert!(e.contains("data.csv: line 103: a gap of 0.06 s"), "{e}");
    assert!(e.contains("(6.0 median intervals of 0.01 s)"), "{e}");
    assert!(
        e.contains("between t = 1 s (line 102) and t = 1.06 s"),
        "{e}"
    );
    assert!(e.contains("--allow-gaps"), "{e}");
    let profile = setup(&dir, REST_PROFILE, &[("data.csv", text)]).unwrap();
    let imported = import_with(&profile, &ImportOptions { allow_gaps: true }).unwrap();
    let gaps = &imported.report.gaps;
    assert_eq!(gaps.len(), 1);
    assert_eq!((gaps[0].record, gaps[0].line), (101, 103));
    assert!((gaps[0].length_s - 0.06).abs() < 1e-12);
    assert_eq!(
        imported.imu.records.len(),
        300,
        "nothing bridged or dropped"
    );
}

#[test]
fn a_time_base_from_a_counter_or_a_rate() {
    let dir = scratch("counter");
    let toml = REST_PROFILE.replace(
        "column = \"time\"",
        "counter_column = \"time\"\nrate_hz = 200.0",
    );
    let text = rest_csv(300, |i| (i + 10) as f64);
    let imported = import(&dir, &toml, &[("data.csv", text.clone())]).unwrap();
    assert_eq!(imported.imu.records[0].t, 0.05);
    assert_eq!(imported.imu.records[2].t, 0.06);
    // A jump of the counter is a gap like any other.
    let text = rest_csv(300, |i| (i + if i > 200 { 5 } else { 0 }) as f64);
    let e = message(import(&dir, &toml, &[("data.csv", text)]).unwrap_err());
    assert!(e.contains("line 203: a gap of 0.03 s"), "{e}");
    // A rate alone: t = k / rate.
    let toml = REST_PROFILE.replace("column = \"time\"", "rate_hz = 50.0");
    let imported = import(&dir, &toml, &[("data.csv", rest_csv(300, |i| i as f64))]).unwrap();
    assert_eq!(imported.imu.records[3].t, 0.06);
}

#[test]
fn saturated_samples_are_counted_with_the_first_line() {
    let dir = scratch("saturation");
    let toml = REST_PROFILE.replace(
        "unit = \"deg/s\"",
        "unit = \"deg/s\"\nrange = [-2000.0, 2000.0]",
    );
    let mut text = rest_csv(300, |i| i as f64 * 0.01);
    // Rows 150..153 (lines 152..155) and 200 (line 202) at the limit.
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(n, l)| {
            if (152..=155).contains(&(n + 1)) || n + 1 == 202 {
                l.replace(",0.5,", ",2000,")
            } else {
                l.to_string()
            }
        })
        .collect();
    text = lines.join("\n") + "\n";
    let imported = import(&dir, &toml, &[("data.csv", text)]).unwrap();
    let sat = &imported.report.saturation;
    assert_eq!(sat.len(), 1, "only the gyro has a range");
    assert_eq!(sat[0].sensor, "gyro");
    assert_eq!(sat[0].count, 5);
    assert_eq!(sat[0].first_line, Some(152));
    let st = &sat[0].stretches;
    assert_eq!(st.len(), 2, "{st:?}");
    assert!(
        (st[0][0] - 1.5).abs() < 1e-12 && (st[0][1] - 1.53).abs() < 1e-12,
        "{st:?}"
    );
    assert!(
        (st[1][0] - 2.0).abs() < 1e-12 && st[1][0] == st[1][1],
        "{st:?}"
    );
}

#[test]
fn a_specific_force_that_is_not_g_is_refused_with_the_likely_cause() {
    let dir = scratch("not-g");
    // Accelerometers in g under an m/s^2 label.
    let text = rest_csv(300, |i| i as f64 * 0.01).replace(",9.8\n", ",1.0\n");
    let e = message(import(&dir, REST_PROFILE, &[("data.csv", text)]).unwrap_err());
    assert!(e.contains("data.csv: line "), "{e}");
    assert!(e.contains("median magnitude of 1.025 m/s^2"), "{e}");
    assert!(e.contains("look given in g, not m/s^2"), "{e}");
    // Raw counts under a physical unit.
    let text = rest_csv(300, |i| i as f64 * 0.01).replace(",9.8\n", ",36429\n");
    let e = message(import(&dir, REST_PROFILE, &[("data.csv", text)]).unwrap_err());
    assert!(e.contains("look like raw counts"), "{e}");
    // Counts with a sensitivity per g given as per m/s^2.
    let toml = REST_PROFILE.replace(
        "unit = \"m/s^2\"",
        "unit = \"counts\"\noffset = [0.0, 0.0, 0.0]\nsensitivity = [1000.0, 1000.0, 1000.0]\nsensitivity_unit = \"m/s^2\"",
    );
    let text = rest_csv(300, |i| i as f64 * 0.01).replace(",0.1,-0.2,9.8\n", ",0,0,1000\n");
    let e = message(import(&dir, &toml, &[("data.csv", text)]).unwrap_err());
    assert!(e.contains("counts per g, not per m/s^2"), "{e}");
}

#[test]
fn files_cut_off_or_not_text_are_refused() {
    let dir = scratch("cut");
    let mut text = rest_csv(50, |i| i as f64 * 0.01);
    text.pop();
    let e = message(import(&dir, REST_PROFILE, &[("data.csv", text)]).unwrap_err());
    assert!(
        e.contains("data.csv: line 51: the last line has no line end"),
        "{e}"
    );
    std::fs::write(
        dir.join("data.csv"),
        b"time,gx,gy,gz,ax,ay,az\n0,\xff,0,0,0,0,9.8\n",
    )
    .unwrap();
    let profile = Profile::load(&dir.join("profile.toml")).unwrap();
    let e = message(import_with(&profile, &ImportOptions::default()).unwrap_err());
    assert!(e.contains("data.csv: line 2: not UTF-8"), "{e}");
    let e = message(Profile::load(&dir.join("none.toml")).unwrap_err());
    assert!(e.contains("none.toml: cannot read"), "{e}");
}

#[test]
fn angles_go_to_the_turntable_file() {
    let dir = scratch("angles");
    let toml =
        REST_PROFILE.to_string() + "[angles]\ncolumns = [\"k1\", \"k2\", \"k3\"]\nunit = \"rad\"\n";
    let mut text = String::from("time,gx,gy,gz,ax,ay,az,k1,k2,k3\n");
    for i in 0..200 {
        text += &format!(
            "{},0,0,0,0,0,9.8,{},0,0\n",
            i as f64 * 0.01,
            std::f64::consts::PI
        );
    }
    let imported = import(&dir, &toml, &[("data.csv", text)]).unwrap();
    let tt = imported.turntable.as_ref().unwrap();
    assert_eq!(tt.records.len(), 200);
    assert_eq!(tt.records[3].t, 0.03);
    assert!((tt.records[3].k_deg[0] - 180.0).abs() < 1e-12);
    assert_eq!(tt.records.len(), 200);
}

#[test]
fn increments_are_written_as_increments_and_checked_per_interval() {
    let dir = scratch("increments");
    let toml = r#"
form = "increments"
[input]
file = "inc.csv"
[time]
rate_hz = 200.0
[gyro]
columns = [1, 2, 3]
unit = "deg"
[accel]
columns = [4, 5, 6]
unit = "m/s"
"#;
    // At rest, z up: dv = g dt = 9.81 / 200 per record, each axis moving by 1e-9 (as a
    // sensor's noise moves it: a column that never changes is refused as a stuck sensor), the
    // z axis symmetrically about its value so that its median is 0.04905.
    let text: String = (0..1000)
        .map(|i| {
            let e = [-1e-9, 0.0, 1e-9][i % 3];
            format!("{},{e},{e},{e},{e},{}\n", 0.001 + e, 0.04905 + e)
        })
        .collect();
    let imported = import(&dir, toml, &[("inc.csv", text)]).unwrap();
    assert_eq!(imported.imu.kind, calib::io::ImuKind::Increments);
    assert!((imported.report.static_force.median_norm_m_s2 - 9.81).abs() < 1e-9);
    let header = std::fs::read_to_string(&imported.written.imu).unwrap();
    assert!(
        header.starts_with("t,dthx,dthy,dthz,dvx,dvy,dvz\n"),
        "{header:.40}"
    );
    let seg = calib::motion::detect::segment(&imported.imu, &Default::default()).unwrap();
    assert_eq!(seg.static_intervals.len(), 1);
    assert!((seg.static_intervals[0].norm_f_m_s2 - 9.81).abs() < 1e-9);
}

#[test]
fn a_stuck_sensor_is_refused_naming_its_columns() {
    let dir = scratch("stuck");
    // 1000 records (5 s at 200 Hz) whose gyros never change, the accelerometers moving.
    let text: String = (0..1000)
        .map(|i| {
            let e = [-1e-9, 0.0, 1e-9][i % 3];
            format!("0.001,0.0,0.0,{e},{e},{}\n", 0.04905 + e)
        })
        .collect();
    let toml = r#"
form = "increments"
[input]
file = "inc.csv"
[time]
rate_hz = 200.0
[gyro]
columns = [1, 2, 3]
unit = "deg"
[accel]
columns = [4, 5, 6]
unit = "m/s"
"#;
    let e = message(import(&dir, toml, &[("inc.csv", text)]).unwrap_err());
    assert!(e.contains("inc.csv") && e.contains("stuck"), "{e}");
    assert!(e.contains("gyro y = 0") && !e.contains("accel x"), "{e}");
}

/// `rest_csv` with a temperature column of `temp(i)`.
fn rest_temp_csv(n: usize, temp: impl Fn(usize) -> String) -> String {
    let mut s = String::from("time,gx,gy,gz,ax,ay,az,temp\n");
    for i in 0..n {
        s += &format!(
            "{},0.5,-0.25,1.0,0.1,-0.2,9.8,{}\n",
            i as f64 * 0.01,
            temp(i)
        );
    }
    s
}

fn temp_profile(table: &str) -> String {
    format!("{REST_PROFILE}[temperature]\n{table}\n")
}

#[test]
fn a_temperature_column_is_converted_to_deg_c() {
    let dir = scratch("temperature");
    for (table, raw, celsius) in [
        ("column = \"temp\"\nunit = \"degC\"", 21.5, 21.5),
        ("column = 8\nunit = \"K\"", 300.0, 300.0 - 273.15),
        (
            "column = \"temp\"\nunit = \"degF\"",
            98.6,
            (98.6 - 32.0) * (5.0 / 9.0),
        ),
        (
            "column = \"temp\"\nunit = \"counts\"\noffset = -12420.2\nsensitivity = 340.0",
            -2000.0,
            (-2000.0 + 12420.2) / 340.0,
        ),
    ] {
        let imported = import(
            &dir,
            &temp_profile(table),
            &[("data.csv", rest_temp_csv(300, |_| format!("{raw}")))],
        )
        .unwrap();
        for r in &imported.imu.records {
            assert_eq!(r.temp, Some(celsius), "{table}");
        }
        let text = std::fs::read_to_string(&imported.written.imu).unwrap();
        assert!(text.starts_with("t,wx,wy,wz,fx,fy,fz,temp\n"), "{text}");
    }
    // Without [temperature] no temp column, though the file has one.
    let imported = import(
        &dir,
        REST_PROFILE,
        &[("data.csv", rest_temp_csv(300, |_| "20".into()))],
    )
    .unwrap();
    assert!(imported.imu.records.iter().all(|r| r.temp.is_none()));
    let text = std::fs::read_to_string(&imported.written.imu).unwrap();
    assert!(text.starts_with("t,wx,wy,wz,fx,fy,fz\n"), "{text}");
}

#[test]
fn a_temperature_outside_its_range_is_refused_with_file_line_and_field() {
    let dir = scratch("temperature-refused");
    // Line 8 is row 6: raw counts declared as deg C.
    let csv = rest_temp_csv(300, |i| if i == 6 { "412.5".into() } else { "25".into() });
    let e = message(
        import(
            &dir,
            &temp_profile("column = \"temp\"\nunit = \"degC\""),
            &[("data.csv", csv)],
        )
        .unwrap_err(),
    );
    assert!(
        e.contains("data.csv: line 8: temperature (column `temp`), field 8: `412.5` degC gives 412.5 deg C: expected -100 .. 200 deg C"),
        "{e}"
    );
    // Kelvins declared as deg F come out far above the range; by number, no field is added.
    let csv = rest_temp_csv(300, |_| "500".into());
    let e = message(
        import(
            &dir,
            &temp_profile("column = 8\nunit = \"degF\""),
            &[("data.csv", csv)],
        )
        .unwrap_err(),
    );
    assert!(
        e.contains("data.csv: line 2: temperature (column 8): `500` degF gives 260 deg C"),
        "{e}"
    );
    let csv = rest_temp_csv(300, |_| "-200".into());
    let e = message(
        import(
            &dir,
            &temp_profile("column = 8\nunit = \"K\""),
            &[("data.csv", csv)],
        )
        .unwrap_err(),
    );
    assert!(
        e.contains("line 2: temperature (column 8): `-200` K gives -473.") && e.contains(" deg C"),
        "{e}"
    );
    // The profile's own mistakes.
    for (table, expected) in [
        ("column = \"temp\"\nunit = \"counts\"", "needs offset"),
        (
            "column = \"temp\"\nunit = \"counts\"\noffset = 0.0\nsensitivity = 0.0",
            "sensitivity = 0",
        ),
        (
            "column = \"temp\"\nunit = \"K\"\noffset = 1.0",
            "apply to unit = \"counts\" only",
        ),
        ("column = \"temp\"\nunit = \"C\"", "unknown variant `C`"),
        ("column = \"gx\"\nunit = \"K\"", "is used twice"),
    ] {
        let e = message(
            import(
                &dir,
                &temp_profile(table),
                &[("data.csv", rest_temp_csv(10, |_| "20".into()))],
            )
            .unwrap_err(),
        );
        assert!(e.contains(expected), "{table}: {e}");
    }
}

#[test]
fn comment_lines_move_the_lines_named_the_same_in_the_streamed_import() {
    let dir = scratch("comments");
    // Comments between rows, a gap after one and a row beyond the gyro's range: the lines the
    // report and the refusals name come from the line map of the streamed import.
    let mut text = String::from("time,gx,gy,gz,ax,ay,az\n");
    for i in 0..400 {
        if i % 37 == 5 {
            text += "# a comment\n";
        }
        let t = if i >= 250 {
            0.5 + i as f64 * 0.01
        } else {
            i as f64 * 0.01
        };
        let gx = if i == 301 { 2500.0 } else { 0.5 };
        text += &format!("{t},{gx},-0.25,1.0,0.1,-0.2,9.8\n");
    }
    let toml = format!("{REST_PROFILE}\n[checks]\ngap_factor = 1.5\n")
        .replace("header_line = 1", "header_line = 1\ncomment = \"#\"")
        .replace(
            "unit = \"deg/s\"",
            "unit = \"deg/s\"\nrange = [-2000.0, 2000.0]",
        );
    let profile = setup(&dir, &toml, &[("data.csv", text)]).unwrap();
    let e = message(import_with(&profile, &ImportOptions::default()).unwrap_err());
    assert!(e.contains("a gap of 0.51 s"), "{e}");
    let imported = import_with(&profile, &ImportOptions { allow_gaps: true }).unwrap();
    assert_eq!(imported.report.gaps.len(), 1);
    let sat = &imported.report.saturation[0];
    assert_eq!(sat.count, 1);
    assert_eq!(sat.first_line, Some(2 + 301 + 9));
}
