//! The registry of the names of the states that are not instrument errors, with their units:
//! the attitude error of the computed frame, and the turntable terms (installation
//! misalignment, delay of the angle data, base misalignment). The instrument errors' names come
//! from their terms ([`crate::terms::ErrorModel::params`]). Every crate that writes or matches
//! these names (the state layout, the simulators' truth, the report table, navigation) takes
//! them from here.

use crate::terms::Unit;

/// Attitude error `beta` of the computed frame (ENU axes), small angles.
pub const ATTITUDE_BETA: [&str; 3] = ["attitude.beta.x", "attitude.beta.y", "attitude.beta.z"];
/// Installation misalignment `delta_z` of the instrument on the platform, small angles.
pub const INSTALL_DELTA: [&str; 3] = ["install.delta.x", "install.delta.y", "install.delta.z"];
/// Delay `tau` of the turntable data after the clock relation (s).
pub const TURNTABLE_TAU: &str = "turntable.tau";
/// Base misalignment `gamma_p` of the turntable against ENU, small angles.
pub const BASE_GAMMA: [&str; 3] = ["base.gamma.x", "base.gamma.y", "base.gamma.z"];

/// The turntable clock relation a simulated run used (truth files only; not estimated).
pub const CLOCK_OFFSET: &str = "turntable.clock.offset";
/// Relative rate error of the simulated turntable clock (truth files only).
pub const CLOCK_RATE_ERROR: &str = "turntable.clock.rate_error";
/// Common prefix of every turntable-data name ([`TURNTABLE_TAU`], the clock).
pub const TURNTABLE_PREFIX: &str = "turntable.";

/// Common prefix of [`INSTALL_DELTA`].
pub const INSTALL_PREFIX: &str = "install.delta.";
/// Common prefix of [`BASE_GAMMA`].
pub const BASE_PREFIX: &str = "base.gamma.";

/// The gyro biases (the paper's `nu0`), the states a gyro drift acts on.
pub const GYRO_BIAS: [&str; 3] = ["gyro.bias.x", "gyro.bias.y", "gyro.bias.z"];
/// Random-walk intensities of the gyro biases (rad/s/sqrt(s)); model options, not states.
pub const GYRO_DRIFT: [&str; 3] = ["gyro.drift.x", "gyro.drift.y", "gyro.drift.z"];
/// Accelerometer biases `df0` (the paper's model).
pub const ACCEL_BIAS: [&str; 3] = ["accel.bias.x", "accel.bias.y", "accel.bias.z"];
/// Random-walk intensities of the accelerometer biases, as listed in a truth file
/// (m/s^2/sqrt(s)).
pub const ACCEL_DRIFT: [&str; 3] = ["accel.drift.x", "accel.drift.y", "accel.drift.z"];

/// Unit of the mounting and attitude states.
pub const ANGLE_UNIT: Unit = Unit::SmallAngle;
/// Unit of [`TURNTABLE_TAU`].
pub const TAU_UNIT: Unit = Unit::Second;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefixes_match_the_names() {
        assert!(INSTALL_DELTA.iter().all(|n| n.starts_with(INSTALL_PREFIX)));
        assert!(BASE_GAMMA.iter().all(|n| n.starts_with(BASE_PREFIX)));
        for n in [TURNTABLE_TAU, CLOCK_OFFSET, CLOCK_RATE_ERROR] {
            assert!(n.starts_with(TURNTABLE_PREFIX));
        }
    }
}
