use calib::config::RunConfig;
use calib::estimate::{RunData, estimate};
use calib::io::{ImuData, TurntableData};
use calib::simulate::simulate_run;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mut config = RunConfig::from_file(std::path::Path::new(&args[1])).unwrap();
    if let Some(s) = args.get(2) {
        config.truth.seed = s.parse().unwrap();
    }
    let with_tt = args.get(3).map(|s| s == "tt").unwrap_or(true);
    let t0 = std::time::Instant::now();
    let sim = simulate_run(&config, "cfg").unwrap();
    let t1 = std::time::Instant::now();
    if let Ok(w) = std::env::var("DUMP") {
        let v: Vec<f64> = w.split(",").map(|x| x.parse().unwrap()).collect();
        dump(&sim, v[0], v[1]);
    }
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: with_tt.then_some((&tt, "turntable.csv")),
    };
    let est = estimate(&config, &data, &mut |_, _| {}).unwrap();
    let t2 = std::time::Instant::now();
    println!(
        "sim {:.2}s est {:.2}s  stats {:?}",
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        est.stats
    );
    let layout = calib::covariance::layout_for(&config, with_tt);
    let d = |a: &str| sim.truth.get(&format!("install.delta.{a}")).unwrap();
    let mounting = turntable::kinematics::Mounting {
        delta_z: nalgebra::Vector3::new(d("x"), d("y"), d("z")),
        gamma_p: nalgebra::Vector3::zeros(),
    };
    let cov = calib::covariance::covariance_analysis_with(&config, &layout, &mounting).unwrap();
    let mut nees = 0.0;
    for (i, name) in est.names.iter().enumerate().skip(3) {
        let truth = sim.truth.get(name).unwrap();
        let s = est.sigma(name).unwrap();
        let e = (est.values[i] - truth) / s;
        nees += e * e;
        println!(
            "{name:20} truth {truth:12.4e} est {:12.4e} sigma {s:10.3e} err/sig {e:7.2} sig/cov {:6.3}",
            est.values[i],
            s / cov.sigma(name).unwrap()
        );
    }
    println!("param NEES {nees:.1} over {}", est.names.len() - 3);
}
#[allow(dead_code)]
pub fn dump(sim: &turntable::simulate::Simulation, a: f64, b: f64) {
    for r in sim.turntable.iter().filter(|r| r.t_tt >= a && r.t_tt <= b) {
        println!("{:.3} {:?}", r.t_tt, r.k_deg);
    }
}
