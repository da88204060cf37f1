//! The snake flight configuration (TOML).
//!
//! The default is embedded from `config/snake_default.toml`; every field is documented there and
//! in `docs/navsim.md`. Angles are in degrees in the file only (the unit is in the field name);
//! the library converts to SI radians.

use serde::{Deserialize, Serialize};
use sins_model::earth::Site;
use thiserror::Error;

/// The default flight as TOML text (the file `config/snake_default.toml` of this crate).
pub const DEFAULT_SNAKE_TOML: &str = include_str!("../config/snake_default.toml");

/// Largest bank angle a configuration may ask for \[deg\] (a 2 g turn).
pub const MAX_BANK_DEG: f64 = 60.0;

/// An error in a snake configuration; always names the offending field.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ConfigError {
    /// The TOML text could not be read into a [`SnakeConfig`]; the message from the TOML parser
    /// names the field (missing, unknown or of the wrong type) and the line.
    #[error("snake configuration: {0}")]
    Parse(String),
    /// A field has a value outside its valid range.
    #[error("snake configuration: field `{field}`: {reason}")]
    Invalid {
        /// Name of the field as written in the TOML file.
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
}

/// Direction of a turn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TurnDirection {
    /// Clockwise seen from above: heading increases, right wing down (positive bank).
    Right,
    /// Counter-clockwise seen from above: heading decreases, left wing down (negative bank).
    Left,
}

impl TurnDirection {
    /// `+1` for a right turn, `-1` for a left turn (sign of the heading rate and of the bank).
    pub fn sign(self) -> f64 {
        match self {
            TurnDirection::Right => 1.0,
            TurnDirection::Left => -1.0,
        }
    }

    /// The other direction.
    pub fn opposite(self) -> Self {
        match self {
            TurnDirection::Right => TurnDirection::Left,
            TurnDirection::Left => TurnDirection::Right,
        }
    }
}

/// A snake ("zmeika") flight: parallel straight legs joined by 180-degree coordinated turns
/// that alternate right and left, at constant speed and altitude.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SnakeConfig {
    /// Ground speed (m/s).
    pub speed_m_s: f64,
    /// Length of each straight leg \[m\].
    pub leg_length_m: f64,
    /// Radius of the constant-bank part of each turn \[m\]; exactly one of this and
    /// `turn_rate_deg_s` must be given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_radius_m: Option<f64>,
    /// Heading rate in the constant-bank part of each turn (deg/s); exactly one of this and
    /// `turn_radius_m` must be given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_rate_deg_s: Option<f64>,
    /// Roll-in and roll-out time of each turn (the bank changes linearly) \[s\]; 0 = instantaneous.
    pub roll_time_s: f64,
    /// Height above the WGS-84 ellipsoid \[m\].
    pub altitude_m: f64,
    /// Latitude of the start (and alignment) point \[deg\].
    pub start_latitude_deg: f64,
    /// Longitude of the start point \[deg\].
    pub start_longitude_deg: f64,
    /// Heading of the first leg, clockwise from north \[deg\].
    pub start_heading_deg: f64,
    /// Direction of the first turn; the turns alternate after it.
    pub first_turn: TurnDirection,
    /// Length of the flight \[s\].
    pub duration_s: f64,
    /// The unit's temperature in flight (and at the alignment) (deg C); optional. A
    /// calibration's thermal terms act on its departure from their reference temperature;
    /// without it they are left out of the navigation figure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
}

impl Default for SnakeConfig {
    fn default() -> Self {
        Self::default_config()
    }
}

/// A field out of its range.
fn bad(field: &'static str, reason: impl Into<String>) -> ConfigError {
    ConfigError::Invalid {
        field,
        reason: reason.into(),
    }
}

/// A field that must be a finite number.
fn finite(field: &'static str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(bad(field, format!("must be a finite number, got {v}")))
    }
}

impl SnakeConfig {
    /// The documented default flight, parsed from [`DEFAULT_SNAKE_TOML`].
    pub fn default_config() -> Self {
        Self::from_toml_str(DEFAULT_SNAKE_TOML)
            .expect("the embedded default configuration is valid")
    }

    /// Parse and validate a configuration from TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        let cfg: SnakeConfig =
            toml::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The configuration as TOML text (round-trips through [`SnakeConfig::from_toml_str`]).
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("a SnakeConfig always serialises")
    }

    /// Check every field's range; the error names the field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_flight()?;
        self.validate_turn()
    }

    /// The straight flight: speed, legs, roll time, altitude, start and duration.
    fn validate_flight(&self) -> Result<(), ConfigError> {
        finite("speed_m_s", self.speed_m_s)?;
        if !(self.speed_m_s > 0.0 && self.speed_m_s <= 1000.0) {
            return Err(bad(
                "speed_m_s",
                format!("must be in (0, 1000] m/s, got {}", self.speed_m_s),
            ));
        }
        finite("leg_length_m", self.leg_length_m)?;
        if self.leg_length_m < 0.0 {
            return Err(bad(
                "leg_length_m",
                format!("must be >= 0, got {}", self.leg_length_m),
            ));
        }
        finite("roll_time_s", self.roll_time_s)?;
        if self.roll_time_s < 0.0 {
            return Err(bad(
                "roll_time_s",
                format!("must be >= 0, got {}", self.roll_time_s),
            ));
        }
        finite("altitude_m", self.altitude_m)?;
        if !(-500.0..=20_000.0).contains(&self.altitude_m) {
            return Err(bad(
                "altitude_m",
                format!("must be in [-500, 20000] m, got {}", self.altitude_m),
            ));
        }
        finite("start_latitude_deg", self.start_latitude_deg)?;
        if self.start_latitude_deg.abs() > 80.0 {
            return Err(bad(
                "start_latitude_deg",
                format!(
                    "must be within +-80 deg (geographic axes degenerate at the poles), got {}",
                    self.start_latitude_deg
                ),
            ));
        }
        finite("start_longitude_deg", self.start_longitude_deg)?;
        finite("start_heading_deg", self.start_heading_deg)?;
        if let Some(t) = self.temperature_c {
            finite("temperature_c", t)?;
            if !(-100.0..=200.0).contains(&t) {
                return Err(bad(
                    "temperature_c",
                    format!("must be in [-100, 200] deg C, got {t}"),
                ));
            }
        }
        finite("duration_s", self.duration_s)?;
        if !(self.duration_s > 0.0 && self.duration_s <= 48.0 * 3600.0) {
            return Err(bad(
                "duration_s",
                format!("must be in (0, 172800] s, got {}", self.duration_s),
            ));
        }
        Ok(())
    }

    /// The turns: one of radius and rate, a bank angle the aircraft can fly, roll-in and
    /// roll-out that leave a constant-bank part. Needs the flight checked first (the bank
    /// depends on the speed and the start).
    fn validate_turn(&self) -> Result<(), ConfigError> {
        match (self.turn_radius_m, self.turn_rate_deg_s) {
            (Some(_), Some(_)) => {
                return Err(bad(
                    "turn_radius_m",
                    "give only one of `turn_radius_m` and `turn_rate_deg_s`",
                ));
            }
            (None, None) => {
                return Err(bad(
                    "turn_radius_m",
                    "give one of `turn_radius_m` and `turn_rate_deg_s`",
                ));
            }
            (Some(r), None) => {
                finite("turn_radius_m", r)?;
                if r <= 0.0 {
                    return Err(bad("turn_radius_m", format!("must be > 0, got {r}")));
                }
            }
            (None, Some(w)) => {
                finite("turn_rate_deg_s", w)?;
                if w <= 0.0 {
                    return Err(bad(
                        "turn_rate_deg_s",
                        format!("must be > 0 (the direction is `first_turn`), got {w}"),
                    ));
                }
            }
        }
        let bank = self.bank_angle_rad().to_degrees();
        if bank > MAX_BANK_DEG {
            let field = if self.turn_radius_m.is_some() {
                "turn_radius_m"
            } else {
                "turn_rate_deg_s"
            };
            return Err(bad(
                field,
                format!("needs a bank angle of {bank:.1} deg, more than {MAX_BANK_DEG} deg"),
            ));
        }
        // The roll-in and roll-out must leave a non-negative constant-bank part.
        if self.hold_time_s() < 0.0 {
            return Err(bad(
                "roll_time_s",
                format!(
                    "{} s is too long: roll-in and roll-out alone turn by more than 90 deg each",
                    self.roll_time_s
                ),
            ));
        }
        Ok(())
    }

    /// The site of the start point at flight altitude.
    pub fn start_site(&self) -> Site {
        Site::from_degrees(
            self.start_latitude_deg,
            self.start_longitude_deg,
            self.altitude_m,
        )
    }

    /// Gravity used to size the coordinated bank: normal gravity at the start point and altitude.
    pub fn design_gravity(&self) -> f64 {
        self.start_site().normal_gravity()
    }

    /// Heading rate in the constant-bank part of a turn (rad/s) (positive).
    pub fn turn_rate_rad_s(&self) -> f64 {
        match (self.turn_radius_m, self.turn_rate_deg_s) {
            (Some(r), _) => self.speed_m_s / r,
            (None, Some(w)) => w.to_radians(),
            (None, None) => f64::NAN,
        }
    }

    /// Radius of the constant-bank part of a turn \[m\].
    pub fn turn_radius(&self) -> f64 {
        self.speed_m_s / self.turn_rate_rad_s()
    }

    /// Bank angle of the constant-bank part of a turn \[rad\] (positive):
    /// `tan(bank) = v * turn_rate / g` (coordinated level turn).
    pub fn bank_angle_rad(&self) -> f64 {
        (self.speed_m_s * self.turn_rate_rad_s() / self.design_gravity()).atan()
    }

    /// Heading change accumulated during the roll-in (and, by symmetry, the roll-out) \[rad\]:
    /// `(g/v) * (T_r / bank) * (-ln cos bank)`.
    pub fn roll_heading_change_rad(&self) -> f64 {
        let b = self.bank_angle_rad();
        let k = self.design_gravity() / self.speed_m_s;
        if self.roll_time_s == 0.0 {
            0.0
        } else {
            k * self.roll_time_s / b * (-b.cos().ln())
        }
    }

    /// Duration of the constant-bank part of a turn \[s\], so that the whole turn is 180 degrees.
    pub fn hold_time_s(&self) -> f64 {
        let b = self.bank_angle_rad();
        let k = self.design_gravity() / self.speed_m_s;
        (std::f64::consts::PI - 2.0 * self.roll_heading_change_rad()) / (k * b.tan())
    }

    /// Duration of one straight leg \[s\].
    pub fn leg_time_s(&self) -> f64 {
        self.leg_length_m / self.speed_m_s
    }

    /// Duration of one 180-degree turn (roll-in + hold + roll-out) \[s\].
    pub fn turn_time_s(&self) -> f64 {
        2.0 * self.roll_time_s + self.hold_time_s()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_parses_and_has_the_documented_values() {
        let c = SnakeConfig::default_config();
        assert_eq!(c.speed_m_s, 150.0);
        assert_eq!(c.leg_length_m, 60_000.0);
        assert_eq!(c.turn_radius_m, Some(5000.0));
        assert_eq!(c.duration_s, 3600.0);
        assert_eq!(c.first_turn, TurnDirection::Right);
        // Bank and turn rate quoted in the file header.
        assert!((c.bank_angle_rad().to_degrees() - 24.6).abs() < 0.05);
        assert!((c.turn_rate_rad_s().to_degrees() - 1.72).abs() < 0.005);
        assert!((c.leg_time_s() - 400.0).abs() < 1e-9);
    }

    #[test]
    fn round_trip_through_toml() {
        let c = SnakeConfig::default_config();
        let back = SnakeConfig::from_toml_str(&c.to_toml_string()).unwrap();
        assert_eq!(c, back);
    }

    fn with_line_replaced(key: &str, line: Option<&str>) -> String {
        DEFAULT_SNAKE_TOML
            .lines()
            .filter_map(|l| {
                if l.starts_with(key) {
                    line.map(|s| s.to_string())
                } else {
                    Some(l.to_string())
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn parse_errors_name_the_field() {
        // Missing field.
        let e = SnakeConfig::from_toml_str(&with_line_replaced("speed_m_s", None)).unwrap_err();
        assert!(e.to_string().contains("speed_m_s"), "{e}");
        // Wrong type.
        let e = SnakeConfig::from_toml_str(&with_line_replaced(
            "leg_length_m",
            Some("leg_length_m = \"long\""),
        ))
        .unwrap_err();
        assert!(e.to_string().contains("leg_length_m"), "{e}");
        // Unknown field (a typo).
        let e = SnakeConfig::from_toml_str(&format!("{DEFAULT_SNAKE_TOML}\nspeeed_m_s = 3.0\n"))
            .unwrap_err();
        assert!(e.to_string().contains("speeed_m_s"), "{e}");
        // Bad enum value.
        let e = SnakeConfig::from_toml_str(&with_line_replaced(
            "first_turn",
            Some("first_turn = \"up\""),
        ))
        .unwrap_err();
        assert!(e.to_string().contains("first_turn"), "{e}");
        // Out of range.
        let e =
            SnakeConfig::from_toml_str(&with_line_replaced("speed_m_s", Some("speed_m_s = -3.0")))
                .unwrap_err();
        assert!(
            matches!(
                e,
                ConfigError::Invalid {
                    field: "speed_m_s",
                    ..
                }
            ),
            "{e}"
        );
        // Both turn fields.
        let e = SnakeConfig::from_toml_str(&with_line_replaced(
            "# turn_rate_deg_s =",
            Some("turn_rate_deg_s = 2.0"),
        ))
        .unwrap_err();
        assert!(
            e.to_string().contains("turn_rate_deg_s") && e.to_string().contains("turn_radius_m"),
            "{e}"
        );
        // Neither.
        let e = SnakeConfig::from_toml_str(&with_line_replaced("turn_radius_m", None)).unwrap_err();
        assert!(e.to_string().contains("turn_radius_m"), "{e}");
        // Too steep a bank.
        let e = SnakeConfig::from_toml_str(&with_line_replaced(
            "turn_radius_m",
            Some("turn_radius_m = 500.0"),
        ))
        .unwrap_err();
        assert!(
            matches!(
                e,
                ConfigError::Invalid {
                    field: "turn_radius_m",
                    ..
                }
            ),
            "{e}"
        );
        // Roll so long that there is no constant-bank part.
        let e = SnakeConfig::from_toml_str(&with_line_replaced(
            "roll_time_s",
            Some("roll_time_s = 500.0"),
        ))
        .unwrap_err();
        assert!(
            matches!(
                e,
                ConfigError::Invalid {
                    field: "roll_time_s",
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn turn_rate_form_gives_the_same_bank_as_the_radius_form() {
        let mut c = SnakeConfig::default_config();
        let w = c.turn_rate_rad_s();
        c.turn_radius_m = None;
        c.turn_rate_deg_s = Some(w.to_degrees());
        c.validate().unwrap();
        assert!((c.turn_radius() - 5000.0).abs() < 1e-9);
    }
}
