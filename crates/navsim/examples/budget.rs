//! Error budget of the paper's two calibration results on the default snake flight.
//!
//! `cargo run -p navsim --release --example budget [-- [--sensitivity] [--per-parameter] [flight.toml]]`:
//! the budget for the default flight (or the given TOML file); `--sensitivity` adds the totals
//! for variations of the flight, `--per-parameter` rho for each parameter alone. Every number of `docs/navsim.md` comes from this program.

use std::time::Instant;

use navsim::{
    BudgetGroup, InstrumentCovariance, NavOptions, SnakeConfig, SnakeTrajectory, error_budget,
    rho_series, trajectory::SegmentKind,
};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sensitivity = args.iter().any(|a| a == "--sensitivity");
    let per_parameter = args.iter().any(|a| a == "--per-parameter");
    let cfg = match args.iter().find(|a| !a.starts_with("--")) {
        Some(path) => {
            let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
            SnakeConfig::from_toml_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
        }
        None => SnakeConfig::default_config(),
    };
    let flight = SnakeTrajectory::new(&cfg).expect("valid flight");
    let legs = flight
        .segments()
        .iter()
        .filter(|s| s.kind == SegmentKind::Leg)
        .count();
    println!(
        "flight: {} m/s, legs {} km ({:.1} s), turns r = {:.0} m, bank {:.1} deg, {:.2} deg/s, {:.1} s each; \
         {} legs and {} turns in {} s; start {} N, heading {} deg",
        cfg.speed_m_s,
        cfg.leg_length_m / 1000.0,
        cfg.leg_time_s(),
        cfg.turn_radius(),
        cfg.bank_angle_rad().to_degrees(),
        cfg.turn_rate_rad_s().to_degrees(),
        cfg.turn_time_s(),
        legs,
        flight.segments().len() - legs,
        cfg.duration_s,
        cfg.start_latitude_deg,
        cfg.start_heading_deg
    );

    let rows = [
        (
            "paper, without turntable angles",
            InstrumentCovariance::paper_without_turntable(),
            sins_model::paper::RHO_IMU_ONLY_M,
        ),
        (
            "paper, with turntable angles",
            InstrumentCovariance::paper_with_turntable(),
            sins_model::paper::RHO_WITH_TURNTABLE_M,
        ),
    ];
    for takeoff in [false, true] {
        let opts = NavOptions {
            takeoff_velocity_error: takeoff,
            ..NavOptions::default()
        };
        println!();
        println!(
            "## rho after {} s [m], initial velocity error {}",
            cfg.duration_s,
            if takeoff {
                "from take-off (dV0 = V0 x beta0)"
            } else {
                "zero"
            }
        );
        print!("| group |");
        for (name, _, _) in &rows {
            print!(" {name} |");
        }
        println!();
        println!("|---|{}", "---:|".repeat(rows.len()));
        let budgets: Vec<_> = rows
            .iter()
            .map(|(_, c, _)| error_budget(&flight, c, &opts).expect("budget"))
            .collect();
        for g in BudgetGroup::ALL {
            print!("| {} |", g.label());
            for b in &budgets {
                print!(" {:.0} |", b.get(g).unwrap());
            }
            println!();
        }
        print!("| root-sum-square of the groups |");
        for b in &budgets {
            print!(" {:.0} |", b.rss_m());
        }
        println!();
        print!("| **total** |");
        for b in &budgets {
            print!(" **{:.0}** |", b.total_m);
        }
        println!();
        print!("| paper |");
        for (_, _, p) in &rows {
            print!(" {p:.0} |");
        }
        println!();
        println!(
            "ratio without/with turntable: {:.2} (paper: {:.2})",
            budgets[0].total_m / budgets[1].total_m,
            sins_model::paper::RHO_IMU_ONLY_M / sins_model::paper::RHO_WITH_TURNTABLE_M
        );
    }

    // rho at a few times, and the propagation time.
    let opts = NavOptions::default();
    println!();
    println!("## rho(t) [m], default options");
    print!("| t [min] |");
    for (name, _, _) in &rows {
        print!(" {name} |");
    }
    println!();
    println!("|---:|{}", "---:|".repeat(rows.len()));
    let series: Vec<_> = rows
        .iter()
        .map(|(_, c, _)| rho_series(&flight, c, &opts).expect("series"))
        .collect();
    for min in [10.0, 20.0, 30.0, 40.0, 50.0, 60.0] {
        print!("| {min:.0} |");
        for s in &series {
            print!(" {:.0} |", s.at(min * 60.0));
        }
        println!();
    }
    let start = Instant::now();
    let n = 10;
    for _ in 0..n {
        std::hint::black_box(rho_series(&flight, &rows[0].1, &opts).expect("series"));
    }
    println!();
    println!(
        "one propagation of {} s at {} s steps: {:.1} ms",
        cfg.duration_s,
        opts.dt_s,
        start.elapsed().as_secs_f64() * 1e3 / n as f64
    );

    let covs = rows.map(|(_, c, _)| c);
    if per_parameter {
        per_parameter_table(&flight, &covs);
    }
    if sensitivity {
        sensitivity_table(&cfg, &covs);
    }
}

/// rho after the flight for each instrument parameter alone (alignment derived from it, no
/// noise), and without alignment (zero initial attitude error).
fn per_parameter_table(flight: &SnakeTrajectory, rows: &[InstrumentCovariance; 2]) {
    let quiet = NavOptions {
        gyro_noise_density: 0.0,
        accel_noise_density: 0.0,
        ..NavOptions::default()
    };
    let unaligned = NavOptions {
        initial_attitude: navsim::InitialAttitude::Explicit(nalgebra::Matrix3::zeros()),
        ..quiet.clone()
    };
    println!();
    println!(
        "## rho after the flight [m] for each parameter alone (sigma of the paper's rows), no noise"
    );
    println!(
        "| parameter | without turntable | (no alignment) | with turntable | (no alignment) |"
    );
    println!("|---|---:|---:|---:|---:|");
    for (k, name) in navsim::INSTRUMENT_NAMES.iter().enumerate() {
        print!("| {name} |");
        for row in rows {
            let mut c = InstrumentCovariance::zeros();
            c.cov[(k, k)] = row.cov[(k, k)];
            for o in [&quiet, &unaligned] {
                print!(
                    " {:.0} |",
                    rho_series(flight, &c, o).expect("series").final_rho_m()
                );
            }
        }
        println!();
    }
}

/// Total rho for variations of the flight and of the options.
fn sensitivity_table(base: &SnakeConfig, rows: &[InstrumentCovariance; 2]) {
    type Edit = Box<dyn Fn(&mut SnakeConfig, &mut NavOptions)>;
    let cases: Vec<(&str, Edit)> = vec![
        ("default", Box::new(|_, _| {})),
        ("speed 100 m/s", Box::new(|c, _| c.speed_m_s = 100.0)),
        ("speed 200 m/s", Box::new(|c, _| c.speed_m_s = 200.0)),
        (
            "speed 250 m/s, turn radius 10 km",
            Box::new(|c, _| {
                c.speed_m_s = 250.0;
                c.turn_radius_m = Some(10_000.0);
            }),
        ),
        ("legs 30 km", Box::new(|c, _| c.leg_length_m = 30_000.0)),
        ("legs 120 km", Box::new(|c, _| c.leg_length_m = 120_000.0)),
        ("legs 300 km", Box::new(|c, _| c.leg_length_m = 300_000.0)),
        (
            "turn radius 3 km",
            Box::new(|c, _| c.turn_radius_m = Some(3000.0)),
        ),
        (
            "turn radius 10 km",
            Box::new(|c, _| c.turn_radius_m = Some(10_000.0)),
        ),
        (
            "legs east-west (heading 90 deg)",
            Box::new(|c, _| c.start_heading_deg = 90.0),
        ),
        (
            "first turn left",
            Box::new(|c, _| c.first_turn = navsim::TurnDirection::Left),
        ),
        (
            "start latitude 45 deg",
            Box::new(|c, _| c.start_latitude_deg = 45.0),
        ),
        (
            "no sensor noise",
            Box::new(|_, o| {
                o.gyro_noise_density = 0.0;
                o.accel_noise_density = 0.0;
            }),
        ),
        (
            "take-off velocity error",
            Box::new(|_, o| o.takeoff_velocity_error = true),
        ),
    ];
    println!();
    println!("## sensitivity: total rho after {} s [m]", base.duration_s);
    println!("| variation | without turntable | with turntable | ratio |");
    println!("|---|---:|---:|---:|");
    for (name, edit) in cases {
        let mut cfg = base.clone();
        let mut opts = NavOptions::default();
        edit(&mut cfg, &mut opts);
        let flight = SnakeTrajectory::new(&cfg).expect("valid variation");
        let r: Vec<f64> = rows
            .iter()
            .map(|c| rho_series(&flight, c, &opts).expect("series").final_rho_m())
            .collect();
        println!(
            "| {name} | {:.0} | {:.0} | {:.2} |",
            r[0],
            r[1],
            r[0] / r[1]
        );
    }
}
