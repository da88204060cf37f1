//! The columns an import wants of an input file in its role (gyro, accelerometer or both),
//! where each quantity is among them, and the time of a row from its time or counter value.

use crate::profile::{Column, Profile};
use crate::text::Wanted;

/// Indices of the columns in a table, by what they hold.
#[derive(Default)]
pub(crate) struct Layout {
    pub(crate) time: Option<usize>,
    pub(crate) gyro: Option<usize>,
    pub(crate) accel: Option<usize>,
    pub(crate) angles: Option<usize>,
    pub(crate) temp: Option<usize>,
}

fn want<'a>(
    wanted: &mut Vec<Wanted<'a>>,
    what: &str,
    columns: &'a [Column],
    axes: [&str; 3],
) -> usize {
    let at = wanted.len();
    for (c, a) in columns.iter().zip(axes) {
        wanted.push(Wanted {
            what: format!("{what} {a} ({c})"),
            column: c,
        });
    }
    at
}

/// The columns wanted of an input file in its role, and where each quantity is among them.
pub(crate) fn wanted_of<'a>(profile: &'a Profile, role: &str) -> (Vec<Wanted<'a>>, Layout) {
    let mut wanted = Vec::new();
    let mut layout = Layout::default();
    let time = &profile.time;
    if let Some(c) = &time.column {
        layout.time = Some(wanted.len());
        wanted.push(Wanted {
            what: format!("time ({c})"),
            column: c,
        });
    } else if let Some(c) = &time.counter_column {
        layout.time = Some(wanted.len());
        wanted.push(Wanted {
            what: format!("sample counter ({c})"),
            column: c,
        });
    }
    let xyz = ["x", "y", "z"];
    if role != "accel" {
        layout.gyro = Some(want(&mut wanted, "gyro", &profile.gyro.columns, xyz));
    }
    if role != "gyro" {
        layout.accel = Some(want(&mut wanted, "accel", &profile.accel.columns, xyz));
    }
    if role != "accel"
        && let Some(a) = &profile.angles
    {
        layout.angles = Some(want(&mut wanted, "angle", &a.columns, ["k1", "k2", "k3"]));
    }
    if role != "accel"
        && let Some(tc) = &profile.temperature
    {
        layout.temp = Some(wanted.len());
        wanted.push(Wanted {
            what: format!("temperature ({})", tc.column),
            column: &tc.column,
        });
    }
    (wanted, layout)
}

/// The time of data row `i` (0-based) from its time or counter value, if the profile has one.
pub(crate) fn time_of(profile: &Profile, value: Option<f64>, i: usize) -> f64 {
    let time = &profile.time;
    match (value, time.counter_column.is_some(), time.rate_hz) {
        (Some(v), false, _) => v / time.unit.unwrap_or_default().per_second(),
        (Some(v), true, Some(r)) => v / r,
        (_, _, Some(r)) => i as f64 / r,
        _ => f64::NAN, // excluded by the profile's check
    }
}
