//! The step loop allocates nothing: a counting global allocator watches predict and update
//! (structured, dense, covariance-only, changing measurement dimensions) after construction.
//! This file holds a single test, and only allocations on the test's own thread are counted:
//! the engine runs every step on the calling thread, and the test harness's main thread may
//! allocate at any time (a count of all threads failed now and then, 4 allocations at
//! n = 28, m = 3, in a full `cargo test` run).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use common::*;
use kalman::KalmanFilter;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Whether this thread's allocations are counted (a `const` thread-local: reading it
    /// allocates nothing).
    static COUNTED: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if COUNTED.with(Cell::get) {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn predict_and_update_do_not_allocate() {
    COUNTED.with(|c| c.set(true));
    // (n, m_max): sizes on both sides of faer's small-product threshold (16^3 multiply-adds).
    for (n, m) in [(4usize, 4usize), (28, 3), (28, 6), (60, 6), (28, 9)] {
        let mut rng = Rng::new(n as u64);
        let sys = Structured::random(&mut rng, 3, n, 0.01);
        let (phi, q) = sys.full(n);
        let h = rng.mat(m, n);
        let h_small = rng.mat(m - 1, n);
        let r = rng.spd(m);
        let r_small = rng.spd(m - 1);
        let z = rng.vec(m);
        let mut kf = KalmanFilter::new(&rng.vec(n), rng.spd(n).as_ref(), m).unwrap();
        // one warm-up round (thread-locals of the product kernels may initialise once)
        kf.predict(phi.as_ref(), q.as_ref()).unwrap();
        kf.predict(sys.phi_top.as_ref(), sys.q_top.as_ref())
            .unwrap();
        kf.update(&z, h.as_ref(), r.as_ref()).unwrap();

        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for _ in 0..50 {
            kf.predict(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
            let info = kf.update(&z, h.as_ref(), r.as_ref()).unwrap();
            std::hint::black_box(info);
            kf.predict(phi.as_ref(), q.as_ref()).unwrap();
            kf.update(&z[..m - 1], h_small.as_ref(), r_small.as_ref())
                .unwrap();
            kf.predict_covariance(phi.as_ref(), q.as_ref()).unwrap();
            kf.predict_covariance(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
            kf.update_covariance(h.as_ref(), r.as_ref()).unwrap();
            kf.set_state(0, 0.0);
            std::hint::black_box(kf.std_dev(n - 1));
            std::hint::black_box(kf.innovation());
            std::hint::black_box(kf.innovation_covariance());
            std::hint::black_box(kf.normalised_covariance());
        }
        let after = ALLOCATIONS.load(Ordering::SeqCst);
        assert_eq!(
            after - before,
            0,
            "n = {n}, m = {m}: {} allocations in the step loop",
            after - before
        );
    }
}
