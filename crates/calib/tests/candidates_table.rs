//! The separability of each candidate term under the paper's program, by covariance analysis
//! (printed; `cargo test --release -p calib --test integration candidates_table:: -- --ignored --nocapture`).

use calib::config::RunConfig;
use calib::estimate::covariance::covariance_analysis_ext;
use calib::model::extension::ModelExtension;
use sins_model::candidates::Candidate;

#[test]
#[ignore = "prints the table of docs/estimation.md, Candidate terms"]
fn candidate_separability_table() {
    let mut config = RunConfig::paper();
    config.filter.imu_rate_hz = 100.0;
    for tt in [false, true] {
        let base = covariance_analysis_ext(&config, tt, &ModelExtension::default()).unwrap();
        for a in ["x", "y", "z"] {
            let n = format!("gyro.bias.{a}");
            println!(
                "tt={tt} paper model {n} sigma/prior {:.3}",
                base.sigma_ratio(&n).unwrap()
            );
        }
        for c in Candidate::ALL {
            let t0 = std::time::Instant::now();
            let post = covariance_analysis_ext(&config, tt, &ModelExtension::with(&[c])).unwrap();
            let names = if c == Candidate::GyroBiasDrift {
                vec![
                    "gyro.bias.x".to_string(),
                    "gyro.bias.y".into(),
                    "gyro.bias.z".into(),
                ]
            } else {
                c.param_names()
            };
            for n in names {
                let i = post.index(&n).unwrap();
                let mut corr: Vec<(f64, &String)> = post
                    .names
                    .iter()
                    .filter(|m| **m != n)
                    .map(|m| (post.correlation(&n, m).unwrap(), m))
                    .collect();
                corr.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
                println!(
                    "tt={tt} {:<24} {:<18} sigma/prior {:.3}  top {:+.3} {}  {:+.3} {}  ({:.1} s)",
                    c.id(),
                    n,
                    post.sigma(&n).unwrap() / post.prior_sigma[i],
                    corr[0].0,
                    corr[0].1,
                    corr[1].0,
                    corr[1].1,
                    t0.elapsed().as_secs_f64()
                );
            }
        }
    }
}
