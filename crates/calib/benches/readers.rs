//! The hand-written `imu.csv` reader against the csv crate doing the same work (issue 11: the
//! csv crate for the readers, unless the hand-written one is measured to be much faster).
//!
//! Both parse the same text (the paper run's 100-Hz increments, 272 700 records, 37.9 MB) into
//! rows of seven numbers, checking every field and keeping the line of each record (the csv
//! crate's `position().line()`), in one criterion group, so both run in the same process.
//!
//! `cargo bench -p calib --bench readers`

use calib::config::RunConfig;
use calib::io::{ImuData, format_imu_csv, parse_imu_csv};
use calib::simulate::simulate_run;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

/// The csv crate's reading of the same file: header checked, every field parsed as f64, the
/// line of each record kept for messages.
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

fn bench(c: &mut Criterion) {
    let mut config = RunConfig::paper();
    config.truth.imu_rate_hz = 100.0;
    let sim = simulate_run(&config, "bench").unwrap();
    let text = format_imu_csv(&ImuData::from_samples(&sim.imu), "imu.csv").unwrap();
    let records = parse_imu_csv(&text, "imu.csv").unwrap().records.len();
    assert_eq!(parse_with_csv_crate(&text).unwrap().len(), records);
    let mut g = c.benchmark_group(format!(
        "imu.csv, {records} records, {} MB",
        text.len() / 1_000_000
    ));
    g.sample_size(10);
    g.bench_function("hand-written reader (calib::io)", |b| {
        b.iter(|| black_box(parse_imu_csv(black_box(&text), "imu.csv").unwrap()))
    });
    g.bench_function("csv crate", |b| {
        b.iter(|| black_box(parse_with_csv_crate(black_box(&text)).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
