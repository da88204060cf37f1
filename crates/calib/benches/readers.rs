//! The readers of `calib::io` (`parse_imu_csv`, `parse_turntable_csv`: hand-written, a block at
//! a time, `memchr` and `fast-float2`) against the readers on the csv crate they replaced
//! (`baseline/csv_reader.rs`, kept as the baseline), against the bare csv crate (a
//! `StringRecord` per line and `str::parse`, no other check), and against the floor: the lines
//! found with `memchr` and every field parsed with `fast-float2`, no check.
//!
//! All parse the same text (the paper run's 100-Hz increments, 272 700 records, 37.9 MB, and
//! its turntable file, 136 379 records) in one criterion group per file, so all run in the same
//! process on the same text; the readers are checked to give bit-identical records first.
//!
//! `cargo bench -p calib --bench readers`

#[path = "baseline/csv_reader.rs"]
mod csv_reader;

use calib::config::RunConfig;
use calib::io::{
    ImuData, TurntableData, format_imu_csv, format_turntable_csv, parse_imu_csv,
    parse_turntable_csv,
};
use calib::simulate::simulate_run;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

/// The bare csv crate on the same file: header width checked, every field parsed as f64, the
/// line of each record kept; none of the reader's other checks (time order, finite numbers,
/// blank lines, line end of the last line, column names).
fn parse_with_csv_crate(text: &str) -> Result<Vec<([f64; 7], u64)>, String> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(text.as_bytes());
    let header = rdr.headers().map_err(|e| e.to_string())?.clone();
    if header.len() != 7 {
        return Err(format!("header has {} columns, expected 7", header.len()));
    }
    let mut out = Vec::new();
    let mut rec = csv::StringRecord::new();
    while rdr.read_record(&mut rec).map_err(|e| e.to_string())? {
        let line = rec.position().map_or(0, |p| p.line());
        let mut row = [0.0; 7];
        for (i, f) in rec.iter().enumerate().take(7) {
            row[i] = f
                .trim()
                .parse::<f64>()
                .map_err(|e| format!("line {line}: field {}: {e}", i + 1))?;
        }
        out.push((row, line));
    }
    Ok(out)
}

/// The floor: the lines found with `memchr`, the fields split at commas and parsed with
/// `fast-float2`; no check of anything (UTF-8, spaces, field count, time order).
fn floor(text: &str) -> Vec<f64> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len() / 18);
    let mut start = memchr::memchr(b'\n', bytes).map_or(bytes.len(), |i| i + 1);
    for end in memchr::memchr_iter(b'\n', bytes) {
        if end < start {
            continue;
        }
        let fields = bytes[start..end].split(|&b| b == b',');
        out.extend(fields.map(|f| fast_float2::parse::<f64, _>(f).unwrap()));
        start = end + 1;
    }
    out
}

fn bench(c: &mut Criterion) {
    let mut config = RunConfig::paper();
    config.truth.imu_rate_hz = 100.0;
    config.truth.turntable_rate_hz = 50.0;
    let sim = simulate_run(&config, "bench").unwrap();
    let text = format_imu_csv(&ImuData::from_samples(&sim.imu), "imu.csv").unwrap();
    let data = parse_imu_csv(&text, "imu.csv").unwrap();
    let old = csv_reader::parse_imu_csv(&text, "imu.csv").unwrap();
    let bits = |d: &ImuData| -> Vec<u64> {
        let r = d.records.iter();
        r.flat_map(|r| [r.t].into_iter().chain(r.gyro).chain(r.accel))
            .map(f64::to_bits)
            .collect()
    };
    assert_eq!(bits(&old), bits(&data));
    let records = data.records.len();
    assert_eq!(parse_with_csv_crate(&text).unwrap().len(), records);
    let mut g = c.benchmark_group(format!(
        "imu.csv, {records} records, {} MB",
        text.len() / 1_000_000
    ));
    g.sample_size(10);
    g.bench_function("calib::io::parse_imu_csv (hand-written)", |b| {
        b.iter(|| black_box(parse_imu_csv(black_box(&text), "imu.csv").unwrap()))
    });
    g.bench_function("csv-crate reader (before)", |b| {
        b.iter(|| black_box(csv_reader::parse_imu_csv(black_box(&text), "imu.csv").unwrap()))
    });
    g.bench_function("bare csv crate", |b| {
        b.iter(|| black_box(parse_with_csv_crate(black_box(&text)).unwrap()))
    });
    g.bench_function("floor (memchr, fast-float2, no checks)", |b| {
        b.iter(|| black_box(floor(black_box(&text))))
    });
    g.finish();

    let turntable = format_turntable_csv(&TurntableData::from_samples(&sim.turntable));
    let data = parse_turntable_csv(&turntable, "turntable.csv").unwrap();
    let old = csv_reader::parse_turntable_csv(&turntable, "turntable.csv").unwrap();
    let bits = |d: &TurntableData| -> Vec<u64> {
        let r = d.records.iter();
        r.flat_map(|r| [r.t].into_iter().chain(r.k_deg))
            .map(f64::to_bits)
            .collect()
    };
    assert_eq!(bits(&old), bits(&data));
    let mut g = c.benchmark_group(format!(
        "turntable.csv, {} records, {} MB",
        data.records.len(),
        turntable.len() / 1_000_000
    ));
    g.sample_size(10);
    g.bench_function("calib::io::parse_turntable_csv (hand-written)", |b| {
        b.iter(|| black_box(parse_turntable_csv(black_box(&turntable), "t.csv").unwrap()))
    });
    g.bench_function("csv-crate reader (before)", |b| {
        b.iter(|| {
            black_box(csv_reader::parse_turntable_csv(black_box(&turntable), "t.csv").unwrap())
        })
    });
    g.bench_function("floor (memchr, fast-float2, no checks)", |b| {
        b.iter(|| black_box(floor(black_box(&turntable))))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
