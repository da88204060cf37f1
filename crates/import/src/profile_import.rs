//! The import of a recording a profile describes ([`import_into`]), in memory independent of
//! the recording's length: the source rows are read, converted and written one at a time, and
//! the checks that need the whole recording (the median interval, the gaps, the magnitudes, the
//! quietest second, the sections) read the written `imu.csv` again. What is held: the lines of
//! the source rows where they do not follow each other (comments, blank lines skipped; none in
//! a plain file), the gaps and saturated stretches the report lists, and one second of running
//! sums for the quietest window.

use crate::checks::{
    JoinRow, beyond_magnitude, celsius, check_gaps, check_time_base, join_pair, join_tolerance,
    magnitude_error, static_force, time_not_finite, time_not_increasing, too_short, unpartnered,
};
use crate::columns::{Layout, time_of, wanted_of};
use crate::profile::{AngleUnit, Form, Profile};
use crate::report::{Saturation, gap_reports, saturation_reports_of};
use crate::sections::{self, SectionsFile};
use crate::text::Rows;
use crate::{
    ImportError, ImportOptions, ImportReport, InputFile, QUIET_WINDOW_S, StaticForce, Written,
};
use calib::io::timing::{self, GapAt, Timing};
use calib::io::{ImuKind, ImuRecord, format_f64};
use sins_model::timing::StreamedIntervalMedian;
use std::io::Write;
use std::path::{Path, PathBuf};

/// What [`import_into`] found and wrote.
#[derive(Clone, Debug)]
pub struct ImportedFiles {
    /// What was read and found (`import.json`).
    pub report: ImportReport,
    /// The sections written to `sections.json`, when the profile has a section list.
    pub sections: Option<SectionsFile>,
    /// The files written.
    pub written: Written,
}

/// The source line of each data row, held only where a row's line does not follow the line of
/// the row before (the first row, and rows after comments).
#[derive(Default)]
struct LineMap {
    /// `(row, line)` at each break.
    breaks: Vec<(usize, usize)>,
}

impl LineMap {
    fn push(&mut self, k: usize, line: usize) {
        if self
            .breaks
            .last()
            .is_some_and(|&(r, l)| l + (k - r) == line)
        {
            return;
        }
        self.breaks.push((k, line));
    }

    fn line(&self, k: usize) -> usize {
        let i = self.breaks.partition_point(|&(r, _)| r <= k);
        let (r, l) = self.breaks[i.max(1) - 1];
        l + (k - r)
    }
}

/// An input file read through once: every row parsed and its time checked.
struct Scan {
    role: &'static str,
    path: PathBuf,
    file: String,
    rows: usize,
    lines: LineMap,
}

impl Scan {
    fn input_file(&self) -> InputFile {
        InputFile {
            role: self.role.into(),
            file: self.file.clone(),
            rows: self.rows,
            first_line: self.lines.line(0),
            last_line: self.lines.line(self.rows - 1),
        }
    }
}

/// An input file's rows with their times.
struct Reading<'a> {
    profile: &'a Profile,
    rows: Rows,
    layout: Layout,
    i: usize,
}

impl<'a> Reading<'a> {
    fn open(profile: &'a Profile, role: &str, path: &Path) -> Result<Self, ImportError> {
        let (wanted, layout) = wanted_of(profile, role);
        let rows = Rows::open(path, &profile.input, &wanted, &profile.origin)?;
        Ok(Self {
            profile,
            rows,
            layout,
            i: 0,
        })
    }

    /// The next row's line and time; its values in `self.rows.values`.
    fn next(&mut self) -> Result<Option<(usize, f64)>, ImportError> {
        let Some(line) = self.rows.next_row()? else {
            return Ok(None);
        };
        let v = &self.rows.values;
        let t = time_of(self.profile, self.layout.time.map(|j| v[j]), self.i);
        self.i += 1;
        Ok(Some((line, t)))
    }

    fn triad(&self, at: Option<usize>) -> [f64; 3] {
        let at = at.unwrap_or(0);
        let v = &self.rows.values;
        [v[at], v[at + 1], v[at + 2]]
    }
}

/// Read an input file through once: every row parsed (a row that is not is refused first: the
/// whole file is read before its times are looked at), every time finite and after the one
/// before.
fn scan(profile: &Profile, role: &'static str, path: &Path) -> Result<Scan, ImportError> {
    let mut reading = Reading::open(profile, role, path)?;
    let file = reading.rows.file().to_string();
    let mut lines = LineMap::default();
    let mut refused: Option<ImportError> = None;
    let mut previous: Option<(f64, usize)> = None;
    let mut rows = 0;
    while let Some((line, ti)) = reading.next()? {
        lines.push(rows, line);
        rows += 1;
        if refused.is_some() {
            continue;
        }
        if !ti.is_finite() {
            refused = Some(time_not_finite(&file, line, ti));
        } else if let Some((p, pl)) = previous
            && ti.partial_cmp(&p) != Some(std::cmp::Ordering::Greater)
        {
            refused = Some(time_not_increasing(profile, &file, line, ti, p, pl));
        }
        previous = Some((ti, line));
    }
    if let Some(e) = refused {
        return Err(e);
    }
    Ok(Scan {
        role,
        path: path.to_path_buf(),
        file,
        rows,
        lines,
    })
}

/// Check the join of two files: the gyro file's median interval (four readings of its times),
/// then both files read side by side.
fn check_join(profile: &Profile, g: &Scan, a: &Scan) -> Result<(), ImportError> {
    let median = sins_model::timing::median_interval_streamed(|visit| {
        let mut r = Reading::open(profile, g.role, &g.path)?;
        while let Some((_, t)) = r.next()? {
            visit(t);
        }
        Ok::<(), ImportError>(())
    })?;
    let tol = join_tolerance(profile, &g.file, median)?;
    let mut rg = Reading::open(profile, g.role, &g.path)?;
    let mut ra = Reading::open(profile, a.role, &a.path)?;
    let n = g.rows.min(a.rows);
    let roles = [g.role, a.role];
    for _ in 0..n {
        let (Some((lg, tg)), Some((la, ta))) = (rg.next()?, ra.next()?) else {
            unreachable!("both files have n rows");
        };
        let row_g = JoinRow {
            file: &g.file,
            line: lg,
            t: tg,
        };
        let row_a = JoinRow {
            file: &a.file,
            line: la,
            t: ta,
        };
        if let Some(e) = join_pair(profile, tol, row_g, row_a, roles) {
            return Err(e);
        }
    }
    if g.rows != a.rows {
        let (long, mut reading, short) = if g.rows > a.rows {
            (g, rg, a)
        } else {
            (a, ra, g)
        };
        let (line, t) = reading.next()?.expect("the longer file has row n");
        let row = JoinRow {
            file: &long.file,
            line,
            t,
        };
        return Err(unpartnered(row, n, &short.file, roles));
    }
    Ok(())
}

/// A file written line by line.
pub(crate) struct Out {
    path: PathBuf,
    w: std::io::BufWriter<std::fs::File>,
}

impl Out {
    pub(crate) fn create(path: PathBuf) -> Result<Self, ImportError> {
        let f = std::fs::File::create(&path)
            .map_err(|source| ImportError::write(&path.display().to_string(), source))?;
        Ok(Self {
            w: std::io::BufWriter::with_capacity(1 << 16, f),
            path,
        })
    }

    pub(crate) fn write(&mut self, text: &str) -> Result<(), ImportError> {
        self.w
            .write_all(text.as_bytes())
            .map_err(|source| ImportError::write(&self.path.display().to_string(), source))
    }

    pub(crate) fn finish(mut self) -> Result<PathBuf, ImportError> {
        self.w
            .flush()
            .map_err(|source| ImportError::write(&self.path.display().to_string(), source))?;
        Ok(self.path)
    }
}

/// What the conversion reading found.
struct Converted {
    kind: ImuKind,
    records: usize,
    t_first: f64,
    t_last: f64,
    saturation: [Saturation; 2],
    median: StreamedIntervalMedian,
    turntable: Option<PathBuf>,
}

/// Read the files (side by side with two) and write `imu.csv` and `turntable.csv` row by row,
/// in the text `calib::io`'s writers give.
fn convert(profile: &Profile, scans: &[Scan], dir: &Path) -> Result<Converted, ImportError> {
    let (g, a) = (&scans[0], scans.last().expect("one or two"));
    let mut rg = Reading::open(profile, g.role, &g.path)?;
    let mut ra = if scans.len() == 2 {
        Some(Reading::open(profile, a.role, &a.path)?)
    } else {
        None
    };
    let kind = match profile.form {
        Form::Rates => ImuKind::Rates,
        Form::Increments => ImuKind::Increments,
    };
    let mut imu = Out::create(dir.join("imu.csv"))?;
    let mut header = String::from("t,");
    header += &kind.columns().join(",");
    if profile.temperature.is_some() {
        header += ",temp";
    }
    header.push('\n');
    imu.write(&header)?;
    let angles = profile.angles.as_ref().zip(rg.layout.angles);
    let mut turntable = match angles {
        Some(_) => {
            let mut out = Out::create(dir.join("turntable.csv"))?;
            out.write(&(calib::io::TURNTABLE_COLUMNS.join(",") + "\n"))?;
            Some(out)
        }
        None => None,
    };
    let mut converted = Converted {
        kind,
        records: 0,
        t_first: f64::NAN,
        t_last: f64::NAN,
        saturation: [Saturation::new(), Saturation::new()],
        median: StreamedIntervalMedian::new(),
        turntable: None,
    };
    let mut line = String::new();
    for k in 0..g.rows {
        let (lg, tk) = rg.next()?.expect("the rows scanned");
        let raw_g = rg.triad(rg.layout.gyro);
        let raw_a = match &mut ra {
            Some(ra) => {
                ra.next()?.expect("as many rows (the join)");
                ra.triad(ra.layout.accel)
            }
            None => rg.triad(rg.layout.accel),
        };
        converted.saturation[0].push(k, tk, profile.gyro.saturated(&raw_g));
        converted.saturation[1].push(k, tk, profile.accel.saturated(&raw_a));
        line.clear();
        line += &format_f64(tk);
        for v in profile
            .gyro
            .convert(raw_g)
            .iter()
            .chain(&profile.accel.convert(raw_a))
        {
            line.push(',');
            line += &format_f64(*v);
        }
        if let (Some(tc), Some(j)) = (&profile.temperature, rg.layout.temp) {
            let c = celsius(tc, rg.rows.values[j], rg.rows.file(), lg, &rg.rows.place(j))?;
            line.push(',');
            line += &format_f64(c);
        }
        line.push('\n');
        imu.write(&line)?;
        if let (Some(out), Some((an, at))) = (&mut turntable, angles) {
            let f = match an.unit {
                AngleUnit::Deg => 1.0,
                AngleUnit::Rad => 180.0 / std::f64::consts::PI,
            };
            let k_deg = rg.triad(Some(at)).map(|v| v * f);
            line.clear();
            line += &format_f64(tk);
            for v in k_deg {
                line.push(',');
                line += &format_f64(v);
            }
            line.push('\n');
            out.write(&line)?;
        }
        converted.median.push(tk);
        if k == 0 {
            converted.t_first = tk;
        }
        converted.t_last = tk;
        converted.records += 1;
    }
    imu.finish()?;
    converted.turntable = turntable.map(Out::finish).transpose()?;
    Ok(converted)
}

/// The records of the written `imu.csv`, read again.
pub(crate) fn read_imu(path: &Path, mut visit: impl FnMut(&ImuRecord)) -> Result<(), ImportError> {
    let mut r = calib::io::ImuReader::open(path)?;
    while let Some(rec) = r.next_record()? {
        visit(&rec);
    }
    Ok(())
}

/// The quietest window of the specific force: `[start, end)` of the [`QUIET_WINDOW_S`] window
/// with the smallest standard deviation within one gap-free stretch (a recording shorter than
/// the window: its longest gap-free stretch), found from the records given one at a time: each
/// gap-free block's running sums of the specific force about its first record, the last
/// `len + 1` of them held.
pub(crate) struct Quietest {
    len: usize,
    ring: Vec<([f64; 3], [f64; 3])>,
    reference: [f64; 3],
    sums: ([f64; 3], [f64; 3]),
    /// First record and length of the block so far.
    b0: usize,
    j: usize,
    best: (usize, usize, f64),
    longest: (usize, usize, f64),
}

impl Quietest {
    fn new(n: usize, median: f64) -> Self {
        let len = if median.is_finite() && median > 0.0 {
            ((QUIET_WINDOW_S / median).round() as usize).max(2)
        } else {
            n
        };
        Self {
            len,
            ring: vec![([0.0; 3], [0.0; 3]); len.min(n) + 1],
            reference: [0.0; 3],
            sums: ([0.0; 3], [0.0; 3]),
            b0: 0,
            j: 0,
            best: (0, n.min(len), f64::INFINITY),
            longest: (0, 0, f64::NAN),
        }
    }

    /// Mean-free summed variance over `[a, b)` of the block from the sums at `a` and `b`.
    fn variance(a: &([f64; 3], [f64; 3]), b: &([f64; 3], [f64; 3]), m: usize) -> f64 {
        let m = m as f64;
        let mut var = 0.0;
        for k in 0..3 {
            let mu = (b.0[k] - a.0[k]) / m;
            var += ((b.1[k] - a.1[k]) / m - mu * mu).max(0.0);
        }
        var
    }

    /// A gap before record `k`: the block so far ends.
    fn gap(&mut self, k: usize) {
        self.end_block(k);
        self.b0 = k;
        self.j = 0;
        self.sums = ([0.0; 3], [0.0; 3]);
    }

    fn end_block(&mut self, b1: usize) {
        if b1 - self.b0 > self.longest.1 - self.longest.0 {
            let zero = ([0.0; 3], [0.0; 3]);
            let var = Self::variance(&zero, &self.sums, self.j);
            self.longest = (self.b0, b1, var);
        }
    }

    fn push(&mut self, f: [f64; 3]) {
        if self.j == 0 {
            self.reference = f;
            self.ring[0] = ([0.0; 3], [0.0; 3]);
        }
        let (s, q) = &mut self.sums;
        for k in 0..3 {
            let d = f[k] - self.reference[k];
            s[k] += d;
            q[k] += d * d;
        }
        self.j += 1;
        let size = self.ring.len();
        self.ring[self.j % size] = self.sums;
        if self.j >= self.len {
            let a = self.j - self.len;
            let v = Self::variance(&self.ring[a % size], &self.ring[self.j % size], self.len);
            if v < self.best.2 {
                self.best = (self.b0 + a, self.b0 + self.j, v);
            }
        }
    }

    /// The window `[a, b)` and the standard deviation of the specific force over it.
    fn finish(mut self, n: usize) -> (usize, usize, f64) {
        self.end_block(n);
        if self.best.2.is_finite() {
            (self.best.0, self.best.1, self.best.2.sqrt())
        } else {
            (self.longest.0, self.longest.1, self.longest.2.sqrt())
        }
    }
}

/// Import the recording `profile` describes into `dir` (which must exist): `imu.csv`,
/// `turntable.csv` with angles, `sections.json` with a section list, and `import.json`, in
/// memory independent of the recording's length. Files written into `dir` before a refusal are
/// left there (write into a fresh directory and remove it on an error).
pub fn import_into(
    profile: &Profile,
    options: &ImportOptions,
    dir: &Path,
) -> Result<ImportedFiles, ImportError> {
    let mut scans = Vec::new();
    for (role, path) in &profile.input_files() {
        scans.push(scan(profile, role, path)?);
    }
    if let [g, a] = scans.as_slice() {
        check_join(profile, g, a)?;
    }
    let converted = convert(profile, &scans, dir)?;
    let (g, a) = (&scans[0], scans.last().expect("one or two"));
    let imu_path = dir.join("imu.csv");
    if converted.records < 2 {
        return Err(too_short(&g.file, g.lines.line(0)));
    }
    let median = converted
        .median
        .finish(|visit| read_imu(&imu_path, |r| visit(r.t)))?;
    let imu = WrittenImu {
        path: imu_path,
        kind: converted.kind,
        records: converted.records,
        median,
    };
    check_time_base(profile, &g.file, g.lines.line(0), median)?;
    let read = read_timing(profile.checks.gap_factor, profile.form, &imu)?;
    let gap_reports = gap_reports(&read.gaps, &read.timing, &g.file, |k| g.lines.line(k));
    if !options.allow_gaps {
        check_gaps(profile, &read.timing, &gap_reports, |k| g.lines.line(k))?;
    }
    if let Some((k, s, i, v)) = read.beyond {
        let src = if s == 0 { g } else { a };
        return Err(magnitude_error(
            profile,
            s,
            i,
            v,
            &src.file,
            src.lines.line(k),
        ));
    }
    read.stuck
        .check(g.lines.line(0), g.lines.line(imu.records - 1))
        .map_err(|message| ImportError::file(&g.file, message))?;
    let static_force = quietest_force(profile, &imu, read.quiet, a)?;
    let line_g = |k: usize| g.lines.line(k);
    let line_a = |k: usize| a.lines.line(k);
    let [sat_g, sat_a] = &converted.saturation;
    let saturation = saturation_reports_of(
        profile,
        [(sat_g, &g.file, &line_g), (sat_a, &a.file, &line_a)],
    );
    let sections = carry_sections(profile, &imu)?;
    let report = ImportReport {
        profile: Some(profile.origin.clone()),
        description: profile.description.clone(),
        inputs: scans.iter().map(Scan::input_file).collect(),
        form: match imu.kind {
            ImuKind::Rates => "rates",
            ImuKind::Increments => "increments",
        }
        .into(),
        records: imu.records,
        t_first_s: converted.t_first,
        t_last_s: converted.t_last,
        timing: read.timing,
        gaps: gap_reports,
        saturation,
        static_force,
        turntable: converted.turntable.is_some(),
        sections: sections.as_ref().map(|s| s.sections.len()),
        bag: None,
    };
    let written = write_reports(
        dir,
        &report,
        sections.as_ref(),
        imu.path,
        converted.turntable,
    )?;
    Ok(ImportedFiles {
        report,
        sections,
        written,
    })
}

/// The written `imu.csv` as the checks read it again: its path, form, number of records and
/// median interval.
pub(crate) struct WrittenImu {
    pub(crate) path: PathBuf,
    pub(crate) kind: ImuKind,
    pub(crate) records: usize,
    pub(crate) median: f64,
}

/// The specific force of record `k` as a rate (m/s^2): increments over the interval to the
/// record before (`previous`, its time), over the median interval for the first record.
fn rate_force(imu: &WrittenImu, r: &ImuRecord, k: usize, previous: Option<f64>) -> [f64; 3] {
    match imu.kind {
        ImuKind::Rates => r.accel,
        ImuKind::Increments => {
            let dt = match previous {
                Some(p) if k > 0 => r.t - p,
                _ => imu.median,
            };
            r.accel.map(|x| x / dt)
        }
    }
}

/// What one reading of the written records finds: the intervals' range, the gaps, the first
/// value beyond a plausible magnitude (`(record, sensor, axis, value)`) and the quietest
/// window's search.
pub(crate) struct TimingReading {
    pub(crate) timing: Timing,
    pub(crate) gaps: Vec<GapAt>,
    pub(crate) beyond: Option<(usize, usize, usize, f64)>,
    pub(crate) quiet: Quietest,
    pub(crate) stuck: crate::Stuck,
}

/// One reading of the written records: the intervals, the gaps, the magnitudes and the
/// quietest second.
pub(crate) fn read_timing(
    gap_factor: f64,
    form: Form,
    imu: &WrittenImu,
) -> Result<TimingReading, ImportError> {
    let median = imu.median;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut gaps = Vec::new();
    let mut beyond: Option<(usize, usize, usize, f64)> = None;
    let mut quiet = Quietest::new(imu.records, median);
    let mut previous: Option<f64> = None;
    let mut k = 0;
    let mut stuck = crate::Stuck::default();
    read_imu(&imu.path, |r| {
        stuck.push(r);
        if let Some(p) = previous {
            let d = r.t - p;
            lo = lo.min(d);
            hi = hi.max(d);
            if d > gap_factor * median {
                gaps.push(GapAt {
                    index: k,
                    t_before_s: p,
                    t_after_s: r.t,
                });
                quiet.gap(k);
            }
        }
        if beyond.is_none() {
            let dt = previous.map_or(median, |p| r.t - p);
            beyond = beyond_magnitude(form, r, dt).map(|(s, i, v)| (k, s, i, v));
        }
        quiet.push(rate_force(imu, r, k, previous));
        previous = Some(r.t);
        k += 1;
    })?;
    Ok(TimingReading {
        timing: Timing {
            median_interval_s: median,
            min_interval_s: lo,
            max_interval_s: hi,
            gap_factor,
        },
        gaps,
        beyond,
        quiet,
        stuck,
    })
}

/// The quietest second read again: its specific force's median magnitude, checked against
/// gravity (the lines named are the accelerometer file's, `a`).
fn quietest_force(
    profile: &Profile,
    imu: &WrittenImu,
    quiet: Quietest,
    a: &Scan,
) -> Result<StaticForce, ImportError> {
    let q = quietest_window(imu, quiet)?;
    static_force(
        profile,
        q.median_norm,
        q.std,
        q.window_s,
        &a.file,
        [a.lines.line(q.records.0), a.lines.line(q.records.1)],
    )
}

/// The quietest second of the written records.
pub(crate) struct QuietWindow {
    /// Median magnitude of the specific force over it (m/s^2).
    pub(crate) median_norm: f64,
    /// Standard deviation of the specific force over it (m/s^2).
    pub(crate) std: f64,
    /// Its first and last time stamp (s).
    pub(crate) window_s: [f64; 2],
    /// Its first and last record (0-based).
    pub(crate) records: (usize, usize),
}

/// The quietest second found by `quiet`, read again for its specific force's median magnitude.
pub(crate) fn quietest_window(
    imu: &WrittenImu,
    quiet: Quietest,
) -> Result<QuietWindow, ImportError> {
    let (wa, wb, std) = quiet.finish(imu.records);
    let mut norms = Vec::with_capacity(wb - wa);
    let mut window_s = [f64::NAN; 2];
    let (mut previous, mut k) = (None, 0);
    read_imu(&imu.path, |r| {
        if (wa..wb).contains(&k) {
            let v = rate_force(imu, r, k, previous);
            norms.push((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
            if k == wa {
                window_s[0] = r.t;
            }
            window_s[1] = r.t;
        }
        previous = Some(r.t);
        k += 1;
    })?;
    Ok(QuietWindow {
        median_norm: timing::median_of(&mut norms),
        std,
        window_s,
        records: (wa, wb - 1),
    })
}

/// The profile's section list carried onto the written records (one more reading), when it
/// has one.
fn carry_sections(
    profile: &Profile,
    imu: &WrittenImu,
) -> Result<Option<SectionsFile>, ImportError> {
    let Some(s) = &profile.sections else {
        return Ok(None);
    };
    let mut carry = sections::Carry::new(
        s,
        &profile.resolve(&s.file),
        imu.records,
        imu.kind,
        imu.median,
        &profile.gyro,
    )?;
    read_imu(&imu.path, |r| carry.push(r.t, r.gyro, r.accel))?;
    Ok(Some(carry.finish(&profile.accel)))
}

/// Write `sections.json` (with a section list) and `import.json`; the files written.
pub(crate) fn write_reports(
    dir: &Path,
    report: &ImportReport,
    sections: Option<&SectionsFile>,
    imu: PathBuf,
    turntable: Option<PathBuf>,
) -> Result<Written, ImportError> {
    let json = |path: &Path, text: String| {
        std::fs::write(path, text + "\n")
            .map_err(|source| ImportError::write(&path.display().to_string(), source))
    };
    let sections_path = match sections {
        Some(s) => {
            let p = dir.join("sections.json");
            json(&p, serde_json::to_string_pretty(s).expect("plain data"))?;
            Some(p)
        }
        None => None,
    };
    let report_path = dir.join("import.json");
    json(
        &report_path,
        serde_json::to_string_pretty(report).expect("plain data"),
    )?;
    Ok(Written {
        imu,
        turntable,
        sections: sections_path,
        report: report_path,
    })
}
