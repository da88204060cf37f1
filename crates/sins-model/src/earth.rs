//! WGS-84 Earth model: normal gravity, Earth rate and radii of curvature at a site.
//!
//! Everything here is in SI units; latitude and longitude are in radians.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// WGS-84 semi-major axis `a` (m).
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS-84 flattening `f`.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS-84 first eccentricity squared `e^2 = f (2 - f)`.
pub const WGS84_E2: f64 = WGS84_F * (2.0 - WGS84_F);
/// Earth rotation rate (rad/s) (WGS-84).
pub const EARTH_RATE: f64 = 7.292_115e-5;
/// Normal gravity at the equator (m/s^2) (WGS-84).
pub const GAMMA_EQUATOR: f64 = 9.780_325_335_9;
/// Somigliana constant `k = (b gamma_p) / (a gamma_e) - 1` (WGS-84).
pub const SOMIGLIANA_K: f64 = 0.001_931_852_652_41;
/// WGS-84 geocentric gravitational constant GM (m^3/s^2).
pub const WGS84_GM: f64 = 3.986_004_418e14;
/// `m = omega^2 a^2 b / GM` (WGS-84), used by the free-air correction.
pub const WGS84_M: f64 = 0.003_449_786_506_84;

/// A point on (or above) the WGS-84 ellipsoid.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Site {
    /// Geodetic latitude (rad).
    pub latitude: f64,
    /// Longitude (rad).
    pub longitude: f64,
    /// Height above the ellipsoid (m).
    pub height: f64,
}

impl Site {
    /// A site from latitude and longitude in degrees and height in metres.
    pub fn from_degrees(latitude_deg: f64, longitude_deg: f64, height_m: f64) -> Self {
        Self {
            latitude: latitude_deg.to_radians(),
            longitude: longitude_deg.to_radians(),
            height: height_m,
        }
    }

    /// Magnitude of normal gravity (gravitation + centrifugal) at the site [m/s^2]:
    /// Somigliana's closed formula on the ellipsoid with the WGS-84 second-order free-air
    /// correction for height.
    pub fn normal_gravity(&self) -> f64 {
        let s2 = self.latitude.sin().powi(2);
        let g0 = GAMMA_EQUATOR * (1.0 + SOMIGLIANA_K * s2) / (1.0 - WGS84_E2 * s2).sqrt();
        let h = self.height;
        g0 * (1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + WGS84_M - 2.0 * WGS84_F * s2) * h
            + 3.0 / (WGS84_A * WGS84_A) * h * h)
    }

    /// Specific force measured by an accelerometer triad at rest, in ENU: `(0, 0, g)`.
    pub fn specific_force_at_rest_enu(&self) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, self.normal_gravity())
    }

    /// Earth rotation rate expressed in the local ENU frame [rad/s]:
    /// `(0, Omega cos(phi), Omega sin(phi))`.
    pub fn earth_rate_enu(&self) -> Vector3<f64> {
        earth_rate_enu(self.latitude)
    }

    /// Meridian radius of curvature `R_N` (north-south) (m), without height.
    pub fn meridian_radius(&self) -> f64 {
        meridian_radius(self.latitude)
    }

    /// Prime-vertical radius of curvature `R_E` (east-west) (m), without height.
    pub fn prime_vertical_radius(&self) -> f64 {
        prime_vertical_radius(self.latitude)
    }
}

/// Earth rotation rate in ENU at geodetic latitude `latitude` (rad).
pub fn earth_rate_enu(latitude: f64) -> Vector3<f64> {
    Vector3::new(
        0.0,
        EARTH_RATE * latitude.cos(),
        EARTH_RATE * latitude.sin(),
    )
}

/// Meridian radius of curvature (m) at geodetic latitude (rad).
pub fn meridian_radius(latitude: f64) -> f64 {
    let s2 = latitude.sin().powi(2);
    WGS84_A * (1.0 - WGS84_E2) / (1.0 - WGS84_E2 * s2).powf(1.5)
}

/// Prime-vertical radius of curvature (m) at geodetic latitude (rad).
pub fn prime_vertical_radius(latitude: f64) -> f64 {
    let s2 = latitude.sin().powi(2);
    WGS84_A / (1.0 - WGS84_E2 * s2).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_gravity_matches_published_values() {
        // WGS-84 normal gravity on the ellipsoid: 9.7803253359 at the equator, 9.8321849378 at the pole.
        assert!(
            (Site::from_degrees(0.0, 0.0, 0.0).normal_gravity() - 9.780_325_335_9).abs() < 1e-9
        );
        assert!(
            (Site::from_degrees(90.0, 0.0, 0.0).normal_gravity() - 9.832_184_937_8).abs() < 1e-8
        );
        // Free-air gradient is about -3.086e-6 s^-2.
        let g0 = Site::from_degrees(45.0, 0.0, 0.0).normal_gravity();
        let g1 = Site::from_degrees(45.0, 0.0, 1000.0).normal_gravity();
        assert!(((g1 - g0) / 1000.0 + 3.086e-6).abs() < 0.01e-6);
    }

    #[test]
    fn earth_rate_has_the_right_magnitude_and_direction() {
        let site = Site::from_degrees(55.7, 37.6, 200.0);
        let u = site.earth_rate_enu();
        assert!((u.norm() - EARTH_RATE).abs() < 1e-18);
        assert_eq!(u.x, 0.0);
        assert!((u.z / u.y - 55.7f64.to_radians().tan()).abs() < 1e-12);
    }

    #[test]
    fn radii_bracket_the_semi_major_axis() {
        assert!((prime_vertical_radius(0.0) - WGS84_A).abs() < 1e-6);
        assert!(meridian_radius(0.0) < WGS84_A);
        assert!(meridian_radius(1.5) > prime_vertical_radius(0.0));
    }
}
