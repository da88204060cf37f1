//! A calibration allocates nothing per IMU step or per measurement instant: a counting global
//! allocator watches two whole 28-state estimations of the same simulated run of the paper's
//! program (the scan, the program-start search and three passes), the second with twice the
//! measurement instants. What allocates is the setup of each pass (filter, layout, buffers
//! reserved once) and the result, so both counts are far below the number of instants and
//! equal to within a few. This file holds a single test so that no other test thread
//! allocates while it counts.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use calib::config::RunConfig;
use calib::estimate::{FitStatistics, Plan, Records, RunData, run};
use calib::io::{ImuData, TurntableData};

#[path = "paper_20hz.rs"]
mod paper_20hz;
use paper_20hz::paper_20hz_run;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations of one 28-state estimation of `sim` under `c`, and its fit statistics.
fn count(c: &RunConfig, imu: &ImuData, tt: &TurntableData) -> (usize, FitStatistics) {
    let data = RunData {
        imu,
        imu_file: "imu.csv",
        turntable: Some((tt, "turntable.csv").into()),
    };
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    let est = run(Plan::fit_only(c), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .unwrap();
    (ALLOCATIONS.load(Ordering::SeqCst) - before, est.stats)
}

#[test]
fn a_calibration_allocates_nothing_per_step_or_instant() {
    let (c, imu, tt) = paper_20hz_run(7);
    let (a, sa) = count(&c, &imu, &tt);
    // The same data with twice the measurement instants.
    let mut twice = c.clone();
    twice.filter.accel_rate_hz *= 2.0;
    twice.filter.turntable_rate_hz *= 2.0;
    let (b, sb) = count(&twice, &imu, &tt);
    println!(
        "{a} allocations for {} passes of {} steps and {} updates each; {b} with {} updates",
        sa.passes,
        sa.imu_steps,
        sa.accel_updates + sa.turntable_updates,
        sb.accel_updates + sb.turntable_updates,
    );
    let (ia, ib) = (
        sa.accel_updates + sa.turntable_updates,
        sb.accel_updates + sb.turntable_updates,
    );
    assert!(sa.passes >= 2 && sb.passes >= 2 && ia > 5000 && ib > ia * 19 / 10);
    // One allocation per measurement instant of one pass would add `ib - ia` (over 5000) to
    // the count, one per IMU step 54 540 to both; the setup of a pass does not scale.
    assert!(
        a < ia / 2 && b.abs_diff(a) < (ib - ia) / 100,
        "{a} allocations for {ia} instants per pass, {b} for {ib}"
    );
}
