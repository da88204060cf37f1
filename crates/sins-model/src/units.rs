//! The paper's units in SI: every conversion at the edges (configuration files, reports,
//! tables) goes through these constants, so that one place says what an arc minute is.

use std::f64::consts::PI;

/// One degree (rad).
pub const DEG: f64 = PI / 180.0;
/// One arc minute (rad).
pub const ARCMIN: f64 = DEG / 60.0;
/// One arc second (rad).
pub const ARCSEC: f64 = ARCMIN / 60.0;
/// One degree per hour (rad/s).
pub const DEG_PER_HOUR: f64 = DEG / 3600.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions() {
        assert_eq!(90.0 * DEG, PI / 2.0);
        assert!((60.0 * ARCMIN - 1f64.to_radians()).abs() < 1e-18);
        assert!((3600.0 * ARCSEC - 1f64.to_radians()).abs() < 1e-18);
        // The Earth rate, 15.041 deg/h, is 7.292e-5 rad/s.
        assert!((15.041067 * DEG_PER_HOUR - 7.292115e-5).abs() < 1e-10);
    }
}
