//! The turntable side of a fit, set up once for every pass.

use super::angles::AngleInterpolator;
use super::pass::AngleReader;
use super::{EstimateError, Scan};
use crate::config::{ClockConfig, RunConfig};
use crate::io::angle_records::AngleRecords;
use crate::io::{IoError, check_overlap};
use crate::model::engine::RateChanges;
use crate::motion::program_start::check_turntable_clock;

/// The turntable side of the estimation, set up once for every pass: the records checked
/// against the IMU span and the clock relation, their median spacing and rate.
pub(super) struct TurntableSetup<'a> {
    pub(super) records: AngleRecords<'a>,
    pub(super) clock: ClockConfig,
    pub(super) median_interval: f64,
    /// Record rate on the IMU clock (Hz).
    pub(super) record_rate_hz: f64,
    /// One sample per record rather than one per IMU step ([`AngleReader::per_record`]).
    pub(super) per_record: bool,
    /// Variance of one angle record (rad^2).
    pub(super) angle_var: f64,
    pub(super) rate_changes: RateChanges,
}

impl<'a> TurntableSetup<'a> {
    /// Check the records of `file` against the IMU span and the clock relation.
    pub(super) fn new(
        config: &RunConfig,
        tt: AngleRecords<'a>,
        scan: &Scan,
        program: &turntable::program::Program,
    ) -> Result<Self, EstimateError> {
        let clock = config.clock;
        let dt = 1.0 / config.filter.imu_rate_hz;
        let file = tt.file();
        let summary = tt.summary();
        if summary.count == 0 {
            return Err(IoError::File {
                file: file.to_string(),
                message: "expected turntable records, found none".into(),
            }
            .into());
        }
        let span = summary.span;
        check_overlap(
            (scan.span.0 - dt, scan.span.1),
            (clock.imu_time(span.0), clock.imu_time(span.1)),
            file,
        )?;
        let med = summary.median_interval;
        if !(med.is_finite() && med > 0.0) {
            return Err(IoError::File {
                file: file.to_string(),
                message: "expected at least two turntable records".into(),
            }
            .into());
        }
        let record_rate_hz = (1.0 + clock.turntable_rate_error) / med;
        // The delay is searched within its prior (three sigma).
        // About two thousand records spread over the file are plenty.
        check_turntable_clock(
            &tt.clock_sample(),
            &clock,
            program,
            scan.program_start,
            3.0 * config.priors.tau_s,
        )
        .map_err(|source| EstimateError::TurntableClock {
            file: file.to_string(),
            source,
        })?;
        Ok(Self {
            records: tt,
            clock,
            median_interval: med,
            record_rate_hz,
            per_record: 1.0 / record_rate_hz > 2.0 * dt,
            angle_var: config.angle_psd() * record_rate_hz,
            rate_changes: RateChanges::new(program),
        })
    }

    /// The reader of one pass, for a program starting at `program_start` (IMU clock).
    pub(super) fn reader(&self, program_start: f64) -> Result<AngleReader<'_>, IoError> {
        Ok(AngleReader {
            interp: AngleInterpolator::new(
                self.records.window()?,
                self.clock,
                self.median_interval,
            ),
            rate_changes: &self.rate_changes,
            program_start,
            per_record: self.per_record,
            rate_change_hint: 0,
        })
    }
}
