//! The static detector ([`detect_static_streamed`]) on records read again from their start, in
//! memory independent of their number.
//!
//! Nothing is kept per record: each pass's windowed deviations and mean rate are worked out
//! again at every reading, a window of `2 h + 2` prefix sums sliding along the records
//! ([`read_windows`]; the sums of each gap-free block taken about its first record, for
//! precision), and each pass takes its noise floor by an exact streamed selection
//! ([`super::select`]). What is kept is what the answer needs: the runs of static and of clearly
//! moving records of the first pass (a few per rest and per motion), the static intervals with
//! their sums, the gaps.
//!
//! Readings: four for the median interval, two for each pass's noise floor (more when a
//! million windows share sixteen bits of their deviation), one for the first pass's runs, one
//! for the intervals; with rests missed, one more for their deviations (two or more) and the
//! suggested settings' pass (three).

use super::adapt::{adapt, half_window, noise_factor_for, suggested_lengths};
use super::segmentation::{
    MissReason, QuietStretch, Segmentation, Span, StaticInterval, Suggestion, gap,
};
use super::select::{quantile_rank, select_streamed};
use super::settings::{
    CLEAR_FACTOR, DetectorSettings, FIRST_PASS_WINDOW_S, MERGE_GAP_INTERVALS, MERGE_MAX_ANGLE_RAD,
    MIN_HALF_WINDOW_RECORDS, MIN_QUIET_STRETCH_S, NOISE_FLOOR_QUANTILE,
};
use crate::io::timing::GapAt;
use std::collections::VecDeque;

/// Records in rate form `(t, w, f)` (s, rad/s, m/s^2), visited from the first at every call.
pub type Reading<'a> =
    dyn FnMut(&mut dyn FnMut(f64, [f64; 3], [f64; 3])) -> Result<(), String> + 'a;

/// What a window gives one record.
#[derive(Clone, Copy, Debug)]
pub(super) struct Win {
    pub index: usize,
    pub t: f64,
    pub w: [f64; 3],
    pub f: [f64; 3],
    pub std_f: f64,
    pub std_w: f64,
    pub rate: f64,
}

/// Receiver of a reading's windows.
pub(super) trait Visit {
    /// A block starts at record `first` (time `t`); `before` is the time of the record before
    /// it when a gap precedes it.
    fn block_start(&mut self, _first: usize, _t: f64, _before: Option<f64>) {}
    /// The window of the next record, in record order.
    fn record(&mut self, win: &Win);
    /// The block ends before record `end`; `after` is that record's time (the end of a gap),
    /// `None` at the end of the records.
    fn block_end(&mut self, _end: usize, _after: Option<f64>) {}
}

/// Prefix sums of both triads (sum and sum of squares of the differences from the block's
/// first record).
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    sf: [f64; 3],
    qf: [f64; 3],
    sw: [f64; 3],
    qw: [f64; 3],
}

/// Mean (about the reference `r`) and summed variance over `[a, b)` (`m` records) from the
/// prefix sums at `a` and `b`.
#[inline]
fn stats(
    sa: &[f64; 3],
    qa: &[f64; 3],
    sb: &[f64; 3],
    qb: &[f64; 3],
    m: f64,
    r: &[f64; 3],
) -> ([f64; 3], f64) {
    let mut mean = [0.0; 3];
    let mut var = 0.0;
    for k in 0..3 {
        let mu = (sb[k] - sa[k]) / m;
        var += ((qb[k] - qa[k]) / m - mu * mu).max(0.0);
        mean[k] = mu + r[k];
    }
    (mean, var)
}

/// The window sums of [`read_windows`] over the block being read.
struct State {
    // Prefix sums of the block at indices `base ..= len`.
    p: VecDeque<Sums>,
    base: usize,
    // Records `next ..< len` of the block, not yet visited.
    pending: VecDeque<(f64, [f64; 3], [f64; 3])>,
    next: usize,
    len: usize,
    block0: usize,
    rf: [f64; 3],
    rw: [f64; 3],
    last_t: f64,
    index: usize,
}
/// Visit the next pending record with its window's deviations and mean rate.
fn emit(s: &mut State, h: usize, visit: &mut dyn Visit) {
    let i = s.next;
    let a = i.saturating_sub(h);
    let b = (i + h + 1).min(s.len);
    let (pa, pb) = (&s.p[a - s.base], &s.p[b - s.base]);
    let m = (b - a) as f64;
    let (_, vf) = stats(&pa.sf, &pa.qf, &pb.sf, &pb.qf, m, &s.rf);
    let (mw, vw) = stats(&pa.sw, &pa.qw, &pb.sw, &pb.qw, m, &s.rw);
    let (t, w, f) = s.pending.pop_front().expect("a pending record");
    visit.record(&Win {
        index: s.block0 + i,
        t,
        w,
        f,
        std_f: vf.sqrt(),
        std_w: vw.sqrt(),
        rate: norm(mw),
    });
    s.next += 1;
    // The prefix sums still needed start at the next record's window.
    while s.base < s.next.saturating_sub(h) {
        s.p.pop_front();
        s.base += 1;
    }
}
/// Visit the block's records still pending (at its end).
fn flush(s: &mut State, h: usize, visit: &mut dyn Visit) {
    while s.next < s.len {
        emit(s, h, visit);
    }
}

/// A new block starts at the record being read: its sums start at zero, taken about its first
/// record's values (sums of differences keep the variances accurate over long blocks).
fn start_block(s: &mut State, w: [f64; 3], f: [f64; 3]) {
    s.p.clear();
    s.p.push_back(Sums::default());
    s.pending.clear();
    s.base = 0;
    s.next = 0;
    s.len = 0;
    s.block0 = s.index;
    s.rf = f;
    s.rw = w;
}

/// The record's prefix sums, and the record held until its window is whole.
fn push_record(s: &mut State, t: f64, w: [f64; 3], f: [f64; 3]) {
    let mut x = *s.p.back().expect("a prefix sum");
    for k in 0..3 {
        let d = f[k] - s.rf[k];
        x.sf[k] += d;
        x.qf[k] += d * d;
        let d = w[k] - s.rw[k];
        x.sw[k] += d;
        x.qw[k] += d * d;
    }
    s.p.push_back(x);
    s.pending.push_back((t, w, f));
}

/// One reading of the records with windows of `h` records each side, cut at the blocks.
pub(super) fn read_windows(
    read: &mut Reading,
    median: f64,
    gap_factor: f64,
    h: usize,
    visit: &mut dyn Visit,
) -> Result<(), String> {
    let mut s = State {
        p: VecDeque::with_capacity(2 * h + 3),
        base: 0,
        pending: VecDeque::with_capacity(h + 2),
        next: 0,
        len: 0,
        block0: 0,
        rf: [0.0; 3],
        rw: [0.0; 3],
        last_t: f64::NAN,
        index: 0,
    };
    read(&mut |t, w, f| {
        let gap = s.index > 0 && t - s.last_t > gap_factor * median;
        if s.index == 0 || gap {
            if gap {
                flush(&mut s, h, visit);
                visit.block_end(s.index, Some(t));
            }
            start_block(&mut s, w, f);
            visit.block_start(s.index, t, gap.then_some(s.last_t));
        }
        push_record(&mut s, t, w, f);
        s.len += 1;
        s.last_t = t;
        s.index += 1;
        while s.next + h < s.len {
            emit(&mut s, h, visit);
        }
    })?;
    if s.index > 0 {
        flush(&mut s, h, visit);
        visit.block_end(s.index, None);
    }
    Ok(())
}

/// A run of records `first ..= last` with the times around it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Run {
    pub first: usize,
    pub last: usize,
    pub t_first: f64,
    pub t_last: f64,
    /// Time of the record before it in its block (NaN at the block's start).
    pub t_before: f64,
    /// Time of the record after it in its block (NaN at the block's end).
    pub t_after: f64,
}

/// The thresholds of one pass, the deviations' raised to `noise_factor` times the noise floor.
#[derive(Clone, Copy, Debug)]
pub(super) struct Levels {
    pub floor_f: f64,
    pub floor_w: f64,
    pub max_std_f: f64,
    pub max_std_w: f64,
    pub max_rate: f64,
}

impl Levels {
    fn is_static(&self, x: &Win) -> bool {
        x.std_f < self.max_std_f && x.std_w < self.max_std_w && x.rate < self.max_rate
    }
    fn is_clear_motion(&self, x: &Win) -> bool {
        x.std_f >= CLEAR_FACTOR * self.max_std_f
            || x.std_w >= CLEAR_FACTOR * self.max_std_w
            || x.rate >= CLEAR_FACTOR * self.max_rate
    }
}

/// The records' common facts, from the first readings.
#[derive(Clone, Copy, Debug)]
pub(super) struct Frame {
    pub n: usize,
    pub median: f64,
    pub gap_factor: f64,
}

/// The thresholds of a pass with `h` records each side of a window: the noise floors (the
/// [`NOISE_FLOOR_QUANTILE`] of the windowed deviations) by streamed selection.
fn levels(
    read: &mut Reading,
    frame: &Frame,
    h: usize,
    settings: &DetectorSettings,
    noise_factor: f64,
) -> Result<Levels, String> {
    struct Feed<'a>(&'a mut dyn FnMut(usize, f64));
    impl Visit for Feed<'_> {
        fn record(&mut self, x: &Win) {
            (self.0)(0, x.std_f);
            (self.0)(1, x.std_w);
        }
    }
    let floors = select_streamed(
        2,
        |_, n| quantile_rank(n, NOISE_FLOOR_QUANTILE),
        |visit| read_windows(read, frame.median, frame.gap_factor, h, &mut Feed(visit)),
    )?;
    let (floor_f, floor_w) = (floors[0], floors[1]);
    Ok(Levels {
        max_std_f: settings.max_std_f_m_s2.max(noise_factor * floor_f),
        max_std_w: settings.max_std_w_rad_s.max(noise_factor * floor_w),
        max_rate: settings.max_rate_rad_s,
        floor_f,
        floor_w,
    })
}

/// Maximal runs of records for which `keep` holds, within the blocks.
struct Runs<F: Fn(&Win) -> bool> {
    keep: F,
    open: Option<Run>,
    out: Vec<Run>,
    prev_t: f64,
    want_after: bool,
}

impl<F: Fn(&Win) -> bool> Runs<F> {
    fn new(keep: F) -> Self {
        Self {
            keep,
            open: None,
            out: Vec::new(),
            prev_t: f64::NAN,
            want_after: false,
        }
    }
    fn record(&mut self, x: &Win) {
        if self.want_after {
            if let Some(r) = self.out.last_mut() {
                r.t_after = x.t;
            }
            self.want_after = false;
        }
        let prev_t = std::mem::replace(&mut self.prev_t, x.t);
        if (self.keep)(x) {
            match &mut self.open {
                Some(r) => {
                    r.last = x.index;
                    r.t_last = x.t;
                }
                None => {
                    self.open = Some(Run {
                        first: x.index,
                        last: x.index,
                        t_first: x.t,
                        t_last: x.t,
                        t_before: prev_t,
                        t_after: f64::NAN,
                    })
                }
            }
        } else if let Some(mut r) = self.open.take() {
            r.t_after = x.t;
            self.out.push(r);
        }
    }
    fn block_end(&mut self) {
        if let Some(r) = self.open.take() {
            self.out.push(r);
        }
        self.prev_t = f64::NAN;
        self.want_after = false;
    }
}

/// A block `first .. end` with its first and last time stamps.
#[derive(Clone, Copy, Debug)]
pub(super) struct Block {
    pub first: usize,
    pub end: usize,
    pub t_first: f64,
    pub t_last: f64,
}

/// The first pass's runs: static, clearly moving, and the blocks.
pub(super) struct FirstRuns {
    pub quiet: Vec<Run>,
    pub moving: Vec<Run>,
    pub blocks: Vec<Block>,
    pub gaps: Vec<GapAt>,
}

fn first_runs(
    read: &mut Reading,
    frame: &Frame,
    h: usize,
    lv: &Levels,
) -> Result<FirstRuns, String> {
    struct V<A: Fn(&Win) -> bool, B: Fn(&Win) -> bool> {
        quiet: Runs<A>,
        moving: Runs<B>,
        blocks: Vec<Block>,
        gaps: Vec<GapAt>,
        last_t: f64,
    }
    impl<A: Fn(&Win) -> bool, B: Fn(&Win) -> bool> Visit for V<A, B> {
        fn block_start(&mut self, first: usize, t: f64, before: Option<f64>) {
            if let Some(b) = before {
                self.gaps.push(GapAt {
                    index: first,
                    t_before_s: b,
                    t_after_s: t,
                });
            }
            self.blocks.push(Block {
                first,
                end: first,
                t_first: t,
                t_last: t,
            });
        }
        fn record(&mut self, x: &Win) {
            self.quiet.record(x);
            self.moving.record(x);
            self.last_t = x.t;
        }
        fn block_end(&mut self, end: usize, _: Option<f64>) {
            self.quiet.block_end();
            self.moving.block_end();
            let b = self.blocks.last_mut().expect("a block");
            b.end = end;
            b.t_last = self.last_t;
        }
    }
    let lv = *lv;
    let mut v = V {
        quiet: Runs::new(move |x: &Win| lv.is_static(x)),
        moving: Runs::new(move |x: &Win| lv.is_clear_motion(x)),
        blocks: Vec::new(),
        gaps: Vec::new(),
        last_t: f64::NAN,
    };
    read_windows(read, frame.median, frame.gap_factor, h, &mut v)?;
    Ok(FirstRuns {
        quiet: v.quiet.out,
        moving: v.moving.out,
        blocks: v.blocks,
        gaps: v.gaps,
    })
}

/// Sums of a stretch of records for its static interval's statistics, from its first record.
#[derive(Clone, Copy, Debug)]
struct Acc {
    first: usize,
    t_first: f64,
    rf: [f64; 3],
    rw: [f64; 3],
    s: Sums,
    records: usize,
}

impl Acc {
    fn new(x: &Win) -> Self {
        let mut a = Self {
            first: x.index,
            t_first: x.t,
            rf: x.f,
            rw: x.w,
            s: Sums::default(),
            records: 0,
        };
        a.add(x);
        a
    }
    fn add(&mut self, x: &Win) {
        for k in 0..3 {
            let d = x.f[k] - self.rf[k];
            self.s.sf[k] += d;
            self.s.qf[k] += d * d;
            let d = x.w[k] - self.rw[k];
            self.s.sw[k] += d;
            self.s.qw[k] += d * d;
        }
        self.records += 1;
    }
    /// The static interval of the records summed, the last at `last` (time `t_last`).
    fn interval(&self, last: usize, t_last: f64) -> StaticInterval {
        let m = self.records as f64;
        let z = [0.0; 3];
        let (mf, vf) = stats(&z, &z, &self.s.sf, &self.s.qf, m, &self.rf);
        let (mw, vw) = stats(&z, &z, &self.s.sw, &self.s.qw, m, &self.rw);
        StaticInterval {
            first_record: self.first,
            last_record: last,
            start_s: self.t_first,
            end_s: t_last,
            duration_s: t_last - self.t_first,
            records: last - self.first + 1,
            mean_f_m_s2: mf,
            norm_f_m_s2: norm(mf),
            mean_w_rad_s: mw,
            std_f_m_s2: vf.sqrt(),
            std_w_rad_s: vw.sqrt(),
        }
    }
}

/// The runs of static records of one pass, kept as static intervals as they end.
struct IntervalRuns<'a> {
    lv: Levels,
    settings: &'a DetectorSettings,
    median: f64,
    n: usize,
    // The run being summed: its own sums, and the sums continuing the last interval kept
    // when the run starts right after it.
    run: Option<(Acc, Option<Acc>, f64, f64)>,
    block_first: usize,
    gap_before: Option<f64>,
    out: Vec<(StaticInterval, f64, f64)>,
    chain: Option<Acc>,
    prev_t: f64,
    // Intervals whose record after is still to come.
    want_after: bool,
}
impl IntervalRuns<'_> {
    /// The run ends: kept when long enough (or at a short gap, to be merged), merged with the
    /// interval before when adjacent with the same gravity direction.
    fn end_run(&mut self, after_block: Option<(usize, Option<f64>)>) {
        let Some((own, cont, t_before, t_last)) = self.run.take() else {
            return;
        };
        let (i, j) = (own.first, own.first + own.records - 1);
        let s = self.settings;
        let at_short_gap = match after_block {
            Some((b1, after)) => {
                s.merge_across_short_gaps
                    && j + 1 == b1
                    && b1 < self.n
                    && after.is_some_and(|ta| ta - t_last <= MERGE_GAP_INTERVALS * self.median)
            }
            None => false,
        };
        let starts_after_short_gap = s.merge_across_short_gaps
            && i == self.block_first
            && i > 0
            && self
                .gap_before
                .is_some_and(|tb| own.t_first - tb <= MERGE_GAP_INTERVALS * self.median);
        if !(t_last - own.t_first >= s.min_duration_s || at_short_gap || starts_after_short_gap) {
            return;
        }
        let mine = own.interval(j, t_last);
        if s.merge_across_short_gaps
            && let (Some((prev, _, _)), Some(cont)) = (self.out.last(), cont)
        {
            let adjacent = mine.first_record == prev.last_record + 1
                && mine.start_s - prev.end_s <= MERGE_GAP_INTERVALS * self.median;
            let (a, b) = (prev.mean_f_m_s2, mine.mean_f_m_s2);
            let cos = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (norm(a) * norm(b));
            if adjacent && cos >= MERGE_MAX_ANGLE_RAD.cos() {
                let (_, before, _) = self.out.pop().expect("the interval before");
                self.out.push((cont.interval(j, t_last), before, f64::NAN));
                self.chain = Some(cont);
                self.want_after = true;
                return;
            }
        }
        self.out.push((mine, t_before, f64::NAN));
        self.chain = Some(own);
        self.want_after = true;
    }
}
impl IntervalRuns<'_> {
    /// The last interval kept, when it still waits for the time of the record after it: `t`.
    fn close_after(&mut self, t: f64) {
        if self.want_after {
            if let Some(last) = self.out.last_mut() {
                last.2 = t;
            }
            self.want_after = false;
        }
    }
}
impl Visit for IntervalRuns<'_> {
    fn block_start(&mut self, first: usize, _: f64, before: Option<f64>) {
        self.block_first = first;
        self.gap_before = before;
    }
    fn record(&mut self, x: &Win) {
        self.close_after(x.t);
        if self.lv.is_static(x) {
            match &mut self.run {
                Some((own, cont, _, t_last)) => {
                    own.add(x);
                    if let Some(c) = cont {
                        c.add(x);
                    }
                    *t_last = x.t;
                }
                None => {
                    let cont = match (self.out.last(), self.chain) {
                        (Some((prev, _, _)), Some(mut c)) if prev.last_record + 1 == x.index => {
                            c.add(x);
                            Some(c)
                        }
                        _ => None,
                    };
                    self.run = Some((Acc::new(x), cont, self.prev_t, x.t));
                }
            }
        } else {
            self.end_run(None);
            // `end_run` may have kept the run that ended at the record before this one.
            self.close_after(x.t);
        }
        self.prev_t = x.t;
    }
    fn block_end(&mut self, end: usize, after: Option<f64>) {
        self.end_run(Some((end, after)));
    }
}

/// The static intervals of one pass: runs of static records of at least `min_duration_s`,
/// joined across short gaps when the settings say so; with for each the time of the record
/// before it and after it (for the motion between them).
fn intervals_streamed(
    read: &mut Reading,
    frame: &Frame,
    h: usize,
    lv: &Levels,
    settings: &DetectorSettings,
) -> Result<Vec<(StaticInterval, f64, f64)>, String> {
    let mut v = IntervalRuns {
        lv: *lv,
        settings,
        median: frame.median,
        n: frame.n,
        run: None,
        block_first: 0,
        gap_before: None,
        out: Vec::new(),
        chain: None,
        prev_t: f64::NAN,
        want_after: false,
    };
    read_windows(read, frame.median, frame.gap_factor, h, &mut v)?;
    let mut out = v.out;
    out.retain(|s| s.0.duration_s >= settings.min_duration_s);
    Ok(out)
}

/// The records' count, first and last time and median interval (`median` when the caller has
/// it), by one reading (four more for the median).
fn scan(
    read: &mut Reading,
    median: Option<f64>,
    settings: &DetectorSettings,
) -> Result<(Frame, f64, f64), String> {
    let mut n = 0usize;
    let (mut t_first, mut t_last) = (f64::NAN, f64::NAN);
    let mut first_median = sins_model::timing::StreamedIntervalMedian::new();
    read(&mut |t, _, _| {
        if n == 0 {
            t_first = t;
        }
        t_last = t;
        n += 1;
        if median.is_none() {
            first_median.push(t);
        }
    })?;
    if n < 2 {
        return Err(format!(
            "expected at least two records with a time, a rate and a specific force each, found \
             {n}"
        ));
    }
    let median = match median {
        Some(m) => m,
        None => first_median.finish(|visit| read(&mut |t, _, _| visit(t)))?,
    };
    let frame = Frame {
        n,
        median,
        gap_factor: settings.gap_factor,
    };
    Ok((frame, t_first, t_last))
}

/// The motion between the static intervals found (each with the times of the records around
/// it), from the first record at `t[0]` to the last at `t[1]` of `n`.
fn motion_streamed(found: &[(StaticInterval, f64, f64)], n: usize, t: [f64; 2]) -> Vec<Span> {
    let [t_first, t_last] = t;
    let mut motion = Vec::new();
    let mut next = 0;
    let mut t_next = t_first;
    for (s, before, after) in found {
        if s.first_record > next {
            motion.push(Span {
                first_record: next,
                last_record: s.first_record - 1,
                start_s: t_next,
                end_s: *before,
                duration_s: before - t_next,
            });
        }
        next = s.last_record + 1;
        t_next = *after;
    }
    if next < n {
        motion.push(Span {
            first_record: next,
            last_record: n - 1,
            start_s: t_next,
            end_s: t_last,
            duration_s: t_last - t_next,
        });
    }
    motion
}

/// Split a recording into static intervals and motion (the module [`super`] says how): the
/// records (rate form: time stamps (s), angular rates (rad/s), specific forces (m/s^2); strictly
/// increasing time, at least two records) read again at every call of `read`, in memory
/// independent of their number; `median` is the median record interval when the caller has it
/// (the same as [`crate::io::timing::median_interval`]), else it is found with four readings.
pub fn detect_static_streamed(
    read: &mut Reading,
    median: Option<f64>,
    settings: &DetectorSettings,
) -> Result<Segmentation, String> {
    settings.check()?;
    let (frame, t_first, t_last) = scan(read, median, settings)?;
    let (n, median) = (frame.n, frame.median);

    // First pass: a short window sees the quiet stretches, however short the rests.
    let h1 = half_window(FIRST_PASS_WINDOW_S, median).max(MIN_HALF_WINDOW_RECORDS);
    let first = levels(read, &frame, h1, settings, settings.noise_factor)?;
    let first_window_s = 2.0 * h1 as f64 * median;
    let runs = first_runs(read, &frame, h1, &first)?;
    let quiet: Vec<f64> = runs.quiet.iter().map(|r| r.t_last - r.t_first).collect();
    let (used, adaptation) = adapt(settings, &quiet, first_window_s, first.floor_f, median);
    let noise_min_duration_s = adaptation.noise_min_duration_s;

    let h = half_window(used.window_s, median);
    let pass = levels(read, &frame, h, settings, settings.noise_factor)?;
    let found = intervals_streamed(read, &frame, h, &pass, &used)?;
    let motion = motion_streamed(&found, n, [t_first, t_last]);
    let intervals: Vec<StaticInterval> = found.into_iter().map(|x| x.0).collect();

    let (motion_events, missed) = missed_streamed(&runs, &intervals);
    let missed_suggestion = if missed.is_empty() {
        None
    } else {
        Some(suggest_streamed(
            read,
            &frame,
            h1,
            &first,
            &runs,
            &used,
            &missed,
            first_window_s,
            noise_min_duration_s,
        )?)
    };
    Ok(Segmentation {
        settings: used,
        records: n,
        t_first_s: t_first,
        t_last_s: t_last,
        median_interval_s: median,
        window_records: 2 * h + 1,
        static_intervals: intervals,
        motion,
        gaps: runs.gaps.iter().map(gap).collect(),
        noise_floor_f_m_s2: pass.floor_f,
        noise_floor_w_rad_s: pass.floor_w,
        threshold_std_f_m_s2: pass.max_std_f,
        threshold_std_w_rad_s: pass.max_std_w,
        adaptation,
        motion_events,
        missed_quiet_stretches: missed,
        missed_suggestion,
    })
}

/// Records of the first pass's static runs within `a ..= b`.
fn quiet_records(quiet: &[Run], a: usize, b: usize) -> usize {
    quiet
        .iter()
        .filter(|r| r.first <= b && a <= r.last)
        .map(|r| r.last.min(b) - r.first.max(a) + 1)
        .sum()
}

/// The motion events of the first pass (runs of clearly moving records, two closer than
/// [`MIN_QUIET_STRETCH_S`] joined) and the quiet stretches between them (and before the first
/// and after the last, within each gap-free block) that hold no static interval; a stretch is
/// too short when at least half its records are quiet at the first pass's window.
fn missed_streamed(runs: &FirstRuns, intervals: &[StaticInterval]) -> (usize, Vec<QuietStretch>) {
    let mut events = 0;
    let mut missed = Vec::new();
    for b in &runs.blocks {
        let (b0, b1) = (b.first, b.end);
        let mut moving: Vec<Run> = Vec::new();
        for r in runs.moving.iter().filter(|r| r.first >= b0 && r.last < b1) {
            match moving.last_mut() {
                Some(last) if r.t_first - last.t_last < MIN_QUIET_STRETCH_S => {
                    last.last = r.last;
                    last.t_last = r.t_last;
                    last.t_after = r.t_after;
                }
                _ => moving.push(*r),
            }
        }
        events += moving.len();
        // The stretches around the motions, with the times of their ends.
        let mut stretches: Vec<(usize, f64, usize, f64)> = Vec::new();
        let (mut a, mut ta) = (b0, b.t_first);
        for r in &moving {
            if r.first > a {
                stretches.push((a, ta, r.first - 1, r.t_before));
            }
            (a, ta) = (r.last + 1, r.t_after);
        }
        if a < b1 {
            stretches.push((a, ta, b1 - 1, b.t_last));
        }
        for (a, ta, bb, tb) in stretches {
            if tb - ta < MIN_QUIET_STRETCH_S || holds_rest(intervals, a, bb) {
                continue;
            }
            let quiet = quiet_records(&runs.quiet, a, bb);
            let records = bb - a + 1;
            missed.push(QuietStretch {
                first_record: a,
                last_record: bb,
                start_s: ta,
                end_s: tb,
                duration_s: tb - ta,
                reason: if 2 * quiet >= records {
                    MissReason::TooShort
                } else {
                    MissReason::TooNoisy
                },
            });
        }
    }
    (events, missed)
}

/// Feeds each too-noisy stretch's records' deviation ratios (to the first pass's floors) to a
/// streamed selection.
struct Feed<'a> {
    noisy: &'a [&'a QuietStretch],
    at: usize,
    first: Levels,
    visit: &'a mut dyn FnMut(usize, f64),
}
impl Visit for Feed<'_> {
    fn record(&mut self, x: &Win) {
        while self.at < self.noisy.len() && self.noisy[self.at].last_record < x.index {
            self.at += 1;
        }
        if let Some(m) = self.noisy.get(self.at)
            && m.first_record <= x.index
        {
            let r = (x.std_f / self.first.floor_f).max(x.std_w / self.first.floor_w);
            (self.visit)(self.at, r);
        }
    }
}

/// Settings that would take the missed stretches: the adaptive rule applied to the too-short
/// ones (their longest quiet run at the first pass's window, that window added back), the noise
/// factor raised past the too-noisy ones' deviations (their median ratio to the floor); tried
/// on the records read again.
#[allow(clippy::too_many_arguments)]
fn suggest_streamed(
    read: &mut Reading,
    frame: &Frame,
    h1: usize,
    first: &Levels,
    runs: &FirstRuns,
    used: &DetectorSettings,
    missed: &[QuietStretch],
    first_window_s: f64,
    noise_min_duration_s: f64,
) -> Result<Suggestion, String> {
    let rests: Vec<f64> = missed
        .iter()
        .filter(|m| m.reason == MissReason::TooShort)
        .map(|m| {
            let longest = runs
                .quiet
                .iter()
                .filter(|r| r.first >= m.first_record && r.last <= m.last_record)
                .map(|r| r.t_last - r.t_first)
                .fold(0.0, f64::max);
            longest + first_window_s
        })
        .collect();
    let (window_s, min_duration_s) =
        suggested_lengths(&rests, used, first_window_s, noise_min_duration_s);
    let mut noise_factor = used.noise_factor;
    let noisy: Vec<&QuietStretch> = missed
        .iter()
        .filter(|m| m.reason == MissReason::TooNoisy)
        .collect();
    if !noisy.is_empty() {
        // The median ratio of each too-noisy stretch, by streamed selection over its records.
        let medians = select_streamed(
            noisy.len(),
            |_, n| quantile_rank(n, 0.5),
            |visit| {
                let mut feed = Feed {
                    noisy: &noisy,
                    at: 0,
                    first: *first,
                    visit,
                };
                read_windows(read, frame.median, frame.gap_factor, h1, &mut feed)
            },
        )?;
        for m in medians {
            let needed = noise_factor_for(m);
            if needed.is_finite() {
                noise_factor = noise_factor.max(needed);
            }
        }
    }
    let tried = DetectorSettings {
        window_s,
        min_duration_s,
        noise_factor,
        adapt_window: false,
        adapt_min_duration: false,
        ..*used
    };
    let h = half_window(window_s, frame.median);
    let pass = levels(read, frame, h, &tried, noise_factor)?;
    let intervals: Vec<StaticInterval> = intervals_streamed(read, frame, h, &pass, &tried)?
        .into_iter()
        .map(|x| x.0)
        .collect();
    Ok(Suggestion {
        window_s,
        min_duration_s,
        noise_factor,
        would_take: missed
            .iter()
            .filter(|m| holds_rest(&intervals, m.first_record, m.last_record))
            .count(),
        static_intervals: intervals.len(),
    })
}

/// Whether a static interval shares a record with `first ..= last`.
fn holds_rest(intervals: &[StaticInterval], first: usize, last: usize) -> bool {
    intervals
        .iter()
        .any(|s| s.first_record <= last && first <= s.last_record)
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
