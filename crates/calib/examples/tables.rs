//! Print the covariance-analysis tables for the embedded paper configuration, with optional
//! overrides: `cargo run -p calib --release --example tables -- KEY=VALUE ...` where KEY is one of
//! rate (measurement rate Hz for both), reading (average|sample), tilt, heading (deg).
use calib::{
    config::{NoiseReading, RunConfig},
    estimate::covariance::covariance_analysis,
};
fn main() {
    let mut config = RunConfig::paper();
    for a in std::env::args().skip(1) {
        let (k, v) = a.split_once('=').expect("KEY=VALUE");
        match k {
            "rate" => {
                let r: f64 = v.parse().unwrap();
                config.filter.accel_rate_hz = r;
                config.filter.turntable_rate_hz = r;
            }
            "reading" => {
                config.noise.reading = if v == "sample" {
                    NoiseReading::Sample
                } else {
                    NoiseReading::Average
                }
            }
            "tilt" => config.priors.initial_tilt_deg = v.parse().unwrap(),
            "heading" => config.priors.initial_heading_deg = v.parse().unwrap(),
            "arate" => config.filter.accel_rate_hz = v.parse().unwrap(),
            "trate" => config.filter.turntable_rate_hz = v.parse().unwrap(),
            "accel_noise" => config.noise.accel_m_s2 = v.parse().unwrap(),
            "angle_noise" => config.noise.angle_arcsec = v.parse().unwrap(),
            "imu" => config.filter.imu_rate_hz = v.parse().unwrap(),
            _ => panic!("unknown key {k}"),
        }
    }
    for tt in [false, true] {
        let p = covariance_analysis(&config, tt).unwrap();
        let tab = calib::report::paper_table(&p);
        let paper = if tt {
            sins_model::paper::TABLE_WITH_TURNTABLE
        } else {
            sins_model::paper::TABLE_IMU_ONLY
        };
        print!("{}:", if tt { "tt " } else { "imu" });
        for (o, pp) in tab.values().iter().zip(paper.values()) {
            print!(" {:5.2}", o / pp);
        }
        let b = p.sigma("attitude.beta.z").unwrap().to_degrees() * 60.0;
        println!("   (beta_z {b:.2}')");
    }
}
