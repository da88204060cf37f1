//! Interchange formats: exact round trips and clear refusals of bad input.

use calib::io::{
    ImuData, ImuKind, ImuRecord, IoError, ResultFile, ResultParameter, TurntableData,
    TurntableRecord, check_overlap, format_f64, format_imu_csv, format_turntable_csv,
    parse_imu_csv, parse_turntable_csv, read_imu_csv, read_result_json, read_turntable_csv,
    write_imu_csv, write_result_json, write_truth_json, write_turntable_csv,
};
use std::path::PathBuf;

fn temp_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("calib-io-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Awkward values: tiny, huge, negative zero, subnormal, many digits.
fn awkward(i: usize) -> f64 {
    let v = [
        1.0 / 3.0,
        -2.718281828459045e-7,
        1.2345678901234567e-300,
        -0.0,
        5e-324,
        9.87654321e15,
        0.1 + 0.2,
        -1e-5,
        std::f64::consts::PI * 1e-12,
    ];
    v[i % v.len()] * (1.0 + i as f64 * 1e-3)
}

fn imu_data(kind: ImuKind, temp: bool) -> ImuData {
    ImuData {
        kind,
        records: (0..50)
            .map(|i| ImuRecord {
                t: 0.01 * (i + 1) as f64 + 1e-9 * awkward(i).abs().min(1.0),
                gyro: [awkward(i), awkward(i + 1), awkward(i + 2)],
                accel: [awkward(i + 3), 9.81 + awkward(i + 4), awkward(i + 5)],
                // Within the temperatures a `temp` column may hold (`TEMP_RANGE_DEG_C`).
                temp: temp.then(|| (20.0 + awkward(i + 6)).clamp(-100.0, 200.0)),
            })
            .collect(),
    }
}

fn same_bits(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits()
}

fn assert_imu_identical(a: &ImuData, b: &ImuData) {
    assert_eq!(a.kind, b.kind);
    assert_eq!(a.records.len(), b.records.len());
    for (x, y) in a.records.iter().zip(&b.records) {
        assert!(same_bits(x.t, y.t));
        for (u, v) in x
            .gyro
            .iter()
            .chain(&x.accel)
            .zip(y.gyro.iter().chain(&y.accel))
        {
            assert!(same_bits(*u, *v), "{u:e} vs {v:e}");
        }
        assert_eq!(x.temp.map(f64::to_bits), y.temp.map(f64::to_bits));
    }
}

#[test]
fn f64_text_round_trips_bit_for_bit() {
    for i in 0..200 {
        let x = awkward(i);
        assert!(same_bits(format_f64(x).parse::<f64>().unwrap(), x), "{x:e}");
    }
    for x in [f64::MAX, f64::MIN_POSITIVE, 1e-4, 1e15, 123456.789] {
        assert!(same_bits(format_f64(x).parse::<f64>().unwrap(), x));
    }
}

#[test]
fn imu_files_round_trip_exactly() {
    for (kind, temp) in [
        (ImuKind::Increments, false),
        (ImuKind::Rates, false),
        (ImuKind::Increments, true),
        (ImuKind::Rates, true),
    ] {
        let data = imu_data(kind, temp);
        let path = temp_path(&format!("imu-{kind:?}-{temp}.csv"));
        write_imu_csv(&path, &data).unwrap();
        let back = read_imu_csv(&path).unwrap();
        assert_imu_identical(&data, &back);
        let header = std::fs::read_to_string(&path).unwrap();
        let header = header.lines().next().unwrap().to_string();
        let expected = match (kind, temp) {
            (ImuKind::Increments, false) => "t,dthx,dthy,dthz,dvx,dvy,dvz",
            (ImuKind::Rates, false) => "t,wx,wy,wz,fx,fy,fz",
            (ImuKind::Increments, true) => "t,dthx,dthy,dthz,dvx,dvy,dvz,temp",
            (ImuKind::Rates, true) => "t,wx,wy,wz,fx,fy,fz,temp",
        };
        assert_eq!(header, expected);
    }
    // Columns in another order, CRLF line ends and a trailing blank line are fine.
    let text = "dvz,t,dthx,dthy,dthz,dvx,dvy\r\n3.5,0.01,1e-3,2e-3,3e-3,1.5,2.5\r\n\r\n";
    let d = parse_imu_csv(text, "reordered.csv").unwrap();
    assert_eq!(d.records[0].t, 0.01);
    assert_eq!(d.records[0].gyro, [1e-3, 2e-3, 3e-3]);
    assert_eq!(d.records[0].accel, [1.5, 2.5, 3.5]);
}

#[test]
fn turntable_files_round_trip_exactly() {
    let data = TurntableData {
        records: (0..40)
            .map(|i| TurntableRecord {
                t: 1234.5678 + 0.02 * i as f64,
                k_deg: [awkward(i) * 1e3, -90.0 + awkward(i + 1), awkward(i + 2)],
            })
            .collect(),
    };
    let path = temp_path("turntable.csv");
    write_turntable_csv(&path, &data).unwrap();
    let back = read_turntable_csv(&path).unwrap();
    assert_eq!(back.records.len(), data.records.len());
    for (x, y) in data.records.iter().zip(&back.records) {
        assert!(same_bits(x.t, y.t));
        for g in 0..3 {
            assert!(same_bits(x.k_deg[g], y.k_deg[g]));
        }
    }
    assert!(format_turntable_csv(&data).starts_with("t,k1,k2,k3\n"));
}

/// The message names the file, `line N` and contains the expectation.
fn assert_refused(
    result: Result<impl std::fmt::Debug, IoError>,
    file: &str,
    line: usize,
    what: &[&str],
) {
    let err = result.expect_err("bad input must be refused");
    let msg = err.to_string();
    assert!(msg.contains(file), "no file name in: {msg}");
    assert!(
        msg.contains(&format!("line {line}:")),
        "no `line {line}` in: {msg}"
    );
    for w in what {
        assert!(msg.contains(w), "no `{w}` in: {msg}");
    }
}

#[test]
fn bad_imu_files_are_refused_with_file_line_and_expectation() {
    let f = "run7/imu.csv";
    let h = "t,dthx,dthy,dthz,dvx,dvy,dvz\n";
    let row = |t: f64| format!("{t},1e-4,2e-4,3e-4,0.01,0.02,0.098\n");
    // A temperature no `temp` column holds (in kelvin, counts, or 1e300).
    for (temp, line) in [(1e300, 3), (-273.15 - 1.0, 3), (400.0, 3)] {
        let text = format!(
            "t,dthx,dthy,dthz,dvx,dvy,dvz,temp\n0.01,0,0,0,0,0,0.098,25\n0.02,0,0,0,0,0,0.098,{temp}\n"
        );
        assert_refused(parse_imu_csv(&text, f), f, line, &["temp", "deg C"]);
    }
    // Empty file and header only.
    assert_refused(
        parse_imu_csv("", f),
        f,
        1,
        &["empty file", "expected a header"],
    );
    assert_refused(
        parse_imu_csv(h, f),
        f,
        2,
        &["expected at least one data row"],
    );
    // Header problems.
    assert_refused(
        parse_imu_csv("t,dthx,dthy,dthz,dvx,dvy\n0.01,1,2,3,4,5\n", f),
        f,
        1,
        &[
            "missing column `dvz`",
            "expected t,dthx,dthy,dthz,dvx,dvy,dvz",
        ],
    );
    assert_refused(
        parse_imu_csv("t,dthx,dthy,dthz,dvx,dvy,dvz,pressure\n", f),
        f,
        1,
        &["unknown column `pressure`", "expected t,dthx"],
    );
    assert_refused(
        parse_imu_csv("t,dthx,dthy,dthz,fx,fy,fz\n", f),
        f,
        1,
        &["mixes increments and rates", "expected"],
    );
    assert_refused(
        parse_imu_csv("t,t,dthx,dthy,dthz,dvx,dvy,dvz\n", f),
        f,
        1,
        &["`t` twice"],
    );
    assert_refused(
        parse_imu_csv("t,temp\n1,2\n", f),
        f,
        1,
        &["no sensor columns"],
    );
    // Wrong number of fields on line 3.
    let text = format!("{h}{}0.02,1e-4,2e-4,3e-4,0.01,0.02\n", row(0.01));
    assert_refused(
        parse_imu_csv(&text, f),
        f,
        3,
        &["expected 7 comma-separated fields", "found 6"],
    );
    // A blank line in the middle is not silently skipped.
    let text = format!("{h}{}\n{}", row(0.01), row(0.02));
    assert_refused(parse_imu_csv(&text, f), f, 3, &["found an empty line"]);
    // Not a number, on line 4.
    let text = format!(
        "{h}{}{}0.03,1e-4,abc,3e-4,0.01,0.02,0.098\n",
        row(0.01),
        row(0.02)
    );
    assert_refused(
        parse_imu_csv(&text, f),
        f,
        4,
        &["column `dthy`", "expected a number", "`abc`"],
    );
    // NaN and infinity.
    for bad in ["NaN", "inf", "-infinity"] {
        let text = format!("{h}{}0.02,1e-4,2e-4,3e-4,0.01,{bad},0.098\n", row(0.01));
        assert_refused(
            parse_imu_csv(&text, f),
            f,
            3,
            &["column `dvy`", "expected a finite number"],
        );
    }
    // Time not increasing: repeated and going back.
    let text = format!("{h}{}{}{}", row(0.01), row(0.02), row(0.02));
    assert_refused(
        parse_imu_csv(&text, f),
        f,
        4,
        &["expected strictly increasing time"],
    );
    let text = format!("{h}{}{}", row(0.02), row(0.01));
    assert_refused(
        parse_imu_csv(&text, f),
        f,
        3,
        &["expected strictly increasing time"],
    );
    // Temperature column present: it must be a number too.
    let text = "t,wx,wy,wz,fx,fy,fz,temp\n0.01,0,0,0,0,0,9.8,hot\n";
    assert_refused(
        parse_imu_csv(text, f),
        f,
        2,
        &["column `temp`", "expected a number"],
    );
    // Through the file system the path names the file.
    let path = temp_path("bad-imu.csv");
    std::fs::write(&path, format!("{h}{}0.02,x,0,0,0,0,0\n", row(0.01))).unwrap();
    assert_refused(read_imu_csv(&path), "bad-imu.csv", 3, &["column `dthx`"]);
    let missing = temp_path("does-not-exist.csv");
    let msg = read_imu_csv(&missing).unwrap_err().to_string();
    assert!(
        msg.contains("does-not-exist.csv") && msg.contains("cannot read"),
        "{msg}"
    );
}

#[test]
fn bad_turntable_files_are_refused_with_file_line_and_expectation() {
    let f = "turntable.csv";
    assert_refused(
        parse_turntable_csv("", f),
        f,
        1,
        &["empty file", "t,k1,k2,k3"],
    );
    assert_refused(
        parse_turntable_csv("t,k1,k2,k3\n", f),
        f,
        2,
        &["expected at least one data row"],
    );
    assert_refused(
        parse_turntable_csv("t,k1,k2\n0,1,2\n", f),
        f,
        1,
        &["missing column `k3`", "expected t,k1,k2,k3"],
    );
    assert_refused(
        parse_turntable_csv("t,k1,k2,k3,k4\n", f),
        f,
        1,
        &["unknown column `k4`", "expected t,k1,k2,k3"],
    );
    let h = "t,k1,k2,k3\n";
    assert_refused(
        parse_turntable_csv(&format!("{h}0,1,2,3,4\n"), f),
        f,
        2,
        &["expected 4 comma-separated fields", "found 5"],
    );
    assert_refused(
        parse_turntable_csv(&format!("{h}0,1,2,3\n1,1,,3\n"), f),
        f,
        3,
        &["column `k2`", "expected a number"],
    );
    assert_refused(
        parse_turntable_csv(&format!("{h}0,1,2,3\n1,1,2,nan\n"), f),
        f,
        3,
        &["column `k3`", "expected a finite number"],
    );
    assert_refused(
        parse_turntable_csv(&format!("{h}5,1,2,3\n6,1,2,3\n5.5,1,2,3\n"), f),
        f,
        4,
        &["expected strictly increasing time"],
    );
}

#[test]
fn turntable_data_must_overlap_the_imu_run() {
    assert!(check_overlap((0.0, 100.0), (50.0, 150.0), "tt.csv").is_ok());
    // Touching the IMU run at one instant, or overlapping it for less than a second (two
    // records, a file cut short): no angle would be measured.
    for tt in [(-10.0, 0.0), (99.5, 120.0), (3.0, 3.02)] {
        let msg = check_overlap((0.0, 100.0), tt, "tt.csv")
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("tt.csv") && msg.contains("expected turntable records over at least 1 s"),
            "{msg}"
        );
    }
    for tt in [(200.0, 300.0), (-50.0, -1.0), (f64::NAN, 1.0)] {
        let msg = check_overlap((0.0, 100.0), tt, "run7/turntable.csv")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("run7/turntable.csv"), "{msg}");
        assert!(msg.contains("do not overlap the IMU data"), "{msg}");
        assert!(
            msg.contains("expected turntable records during the IMU run"),
            "{msg}"
        );
    }
}

#[test]
fn result_and_truth_json_follow_the_design_format() {
    let result = ResultFile {
        parameters: vec![
            ResultParameter {
                name: "gyro.bias.x".into(),
                value: 1.2345e-6,
                sigma: Some(3e-8),
                unit: "rad/s".into(),
            },
            ResultParameter {
                name: "turntable.tau".into(),
                value: 0.013,
                sigma: Some(1e-4),
                unit: "s".into(),
            },
        ],
        ..ResultFile::default()
    };
    let path = temp_path("result.json");
    write_result_json(&path, &result).unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(v["parameters"][0]["name"], "gyro.bias.x");
    assert_eq!(v["parameters"][0]["sigma"].as_f64(), Some(3e-8));
    assert_eq!(v["parameters"][1]["unit"], "s");
    let back = read_result_json(&path).unwrap();
    assert_eq!(back.get("turntable.tau").unwrap().value, 0.013);
    assert_eq!(back.parameters.len(), 2);

    // Truth: no sigma.
    let truth = turntable::simulate::Truth {
        parameters: vec![turntable::simulate::TruthParameter {
            name: "accel.bias.z".into(),
            value: -0.0125,
            unit: "m/s^2".into(),
        }],
        temperature_reference_c: None,
    };
    let path = temp_path("truth.json");
    write_truth_json(&path, &truth).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(!text.contains("sigma"), "{text}");
    let back = read_result_json(&path).unwrap();
    assert_eq!(back.get("accel.bias.z").unwrap().value, -0.0125);
    assert_eq!(back.get("accel.bias.z").unwrap().sigma, None);

    // Not a result file: refused with the file name.
    let path = temp_path("bad.json");
    std::fs::write(&path, "{\"parameters\": [{\"name\": 3}]}").unwrap();
    let msg = read_result_json(&path).unwrap_err().to_string();
    assert!(
        msg.contains("bad.json") && msg.contains("not a result file"),
        "{msg}"
    );
}

#[test]
fn simulator_output_converts_and_writes() {
    use turntable::simulate::{ImuSample, TurntableSample};
    let imu = [ImuSample {
        t: 0.01,
        dtheta: nalgebra::Vector3::new(1e-4, 2e-4, 3e-4),
        dv: nalgebra::Vector3::new(0.0, 0.0, 0.0981),
        temp: None,
    }];
    let d = ImuData::from_samples(&imu);
    let text = format_imu_csv(&d, "x.csv").unwrap();
    assert_imu_identical(&d, &parse_imu_csv(&text, "x.csv").unwrap());
    let tt = TurntableData::from_samples(&[TurntableSample {
        t_tt: 5.0,
        k_deg: [1.0, 2.0, 3.0],
    }]);
    assert_eq!(tt.span(), Some((5.0, 5.0)));
    // A temperature on some records but not all cannot be written.
    let mut d = imu_data(ImuKind::Rates, true);
    d.records[3].temp = None;
    let msg = format_imu_csv(&d, "imu.csv").unwrap_err().to_string();
    assert!(msg.contains("imu.csv") && msg.contains("record 4"), "{msg}");
}

/// A reader that hands out one byte at a time (the reader then never sees a byte-order mark or
/// a line whole in its first read).
struct OneByte(std::io::Cursor<Vec<u8>>);

impl std::io::Read for OneByte {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = buf.len().min(1);
        self.0.read(&mut buf[..n])
    }
}

/// The records and the line of each, through `ImuReader`, the bytes read whole or one at a time.
fn imu_lines(bytes: &[u8], one_at_a_time: bool) -> Result<Vec<(ImuRecord, usize)>, IoError> {
    let cursor = std::io::Cursor::new(bytes.to_vec());
    let reader: Box<dyn std::io::BufRead> = if one_at_a_time {
        Box::new(std::io::BufReader::with_capacity(1, OneByte(cursor)))
    } else {
        Box::new(cursor)
    };
    let mut r = calib::io::ImuReader::from_reader(reader, "edge.csv")?;
    let mut out = Vec::new();
    while let Some(rec) = r.next_record()? {
        out.push((rec, r.line()));
    }
    Ok(out)
}

#[test]
fn the_csv_reader_keeps_the_line_rules() {
    let f = "edge.csv";
    let h = "t,dthx,dthy,dthz,dvx,dvy,dvz";
    for one in [false, true] {
        // A byte-order mark is skipped however the bytes arrive; CRLF line ends; lines counted.
        let text = format!("\u{feff}{h}\r\n0.01,1,2,3,4,5,6\r\n 0.02 ,1,2,3,4,5,6\r\n\r\n  \n");
        let rows = imu_lines(text.as_bytes(), one).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!((rows[0].1, rows[1].1), (2, 3));
        assert_eq!(rows[1].0.t, 0.02);
        // Two marks: the second is part of the first name.
        let text = format!("\u{feff}\u{feff}{h}\n0.01,1,2,3,4,5,6\n");
        assert_refused(imu_lines(text.as_bytes(), one), f, 1, &["unknown column"]);
        // Empty and all-space lines before more data, before the header too.
        for gap in ["\n", "\n\n", "  \r\n", "\r\n\n"] {
            let text = format!("{h}\n0.01,1,2,3,4,5,6\n{gap}0.02,1,2,3,4,5,6\n");
            assert_refused(imu_lines(text.as_bytes(), one), f, 3, &["empty line"]);
            let text = format!("{gap}{h}\n0.01,1,2,3,4,5,6\n");
            assert_refused(imu_lines(text.as_bytes(), one), f, 1, &["empty line"]);
        }
        // No quoting: a quoted number is not a number; a lone CR is not a line end.
        let text = format!("{h}\n\"0.01\",1,2,3,4,5,6\n");
        assert_refused(
            imu_lines(text.as_bytes(), one),
            f,
            2,
            &["column `t`", "found `\"0.01\"`"],
        );
        let text = format!("{h}\n0.01,1,2\r3,4,5,6\n");
        assert_refused(imu_lines(text.as_bytes(), one), f, 2, &["column `dthy`"]);
        // Not UTF-8: the byte of the line is named.
        let mut bytes = format!("{h}\n0.01,1,2,3,4,5,6\n0.02,1,2").into_bytes();
        bytes.extend_from_slice(b"\xff,4,5,6,7\n");
        assert_refused(
            imu_lines(&bytes, one),
            f,
            3,
            &["not UTF-8 text (byte 9 of the line)"],
        );
        // The last line without its line end (CRLF file): cut off, quoted without the CR.
        let text = format!("{h}\r\n0.01,1,2,3,4,5,6\r\n0.02,1,2,3,4\r");
        let msg = imu_lines(text.as_bytes(), one).unwrap_err().to_string();
        assert!(
            msg.contains("line 3: the last line has no line end")
                && msg.contains("(`0.02,1,2,3,4`)"),
            "{msg}"
        );
    }
}
