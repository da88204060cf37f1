//! The files `sins-calib export` writes (docs/formats.md, "Files written by `export`"): this
//! tool's noise levels and calibration re-expressed in the conventions of Kalibr (`imu.yaml`),
//! OpenVINS (`kalibr_imu_chain.yaml`) and imu_tk (`*_acc.calib`, `*_gyro.calib`). Pure
//! functions from values to text; reading, checking and writing are `export`'s.
//!
//! This tool's correction (`calib::model::correction`, linear part) is
//! `w = M_g (w' + nu0 + G f)`, `f = M_a (f' - df0)`, with `M_g = (I - Theta)^-1` full,
//! `M_a = (I + Gamma)^-1` lower-triangular, `w'`, `f'` the raw outputs and `f` the corrected
//! specific force. The targets' models and how each is matched exactly:
//!
//! - OpenVINS (`model: "kalibr"`, `ov_core` `State::Dm`, the propagator):
//!   `a = R_ACCtoIMU Da (a_m - b_a)`, `w = R_GYROtoIMU Dw (w_m - b_g - Tg a)`, with
//!   `Dw = Tw^-1`, `Da = Ta^-1` of which only the lower triangle is used, and
//!   `R_GYROtoIMU = R_IMUtoGYRO^T`. Matched by `M_g = Q L` (Q a rotation, L lower-triangular
//!   with a positive diagonal: [`ql`]), `R_IMUtoGYRO = Q^T`, `Tw = L^-1`; `R_IMUtoACC = I`,
//!   `Ta = M_a^-1 = I + Gamma`; `Tg = -G`; `b_g = -nu0`, `b_a = df0`.
//! - imu_tk (`CalibratedTriad_`): `X' = T K (X - B)`, T with a unit diagonal, K diagonal. Matched
//!   by `K = diag(M)`, `T = M K^-1` (the same linear map; imu_tk's `load` reads T and K as full
//!   3x3 matrices), `B = -nu0` (gyros) and `B = df0` (accelerometers).

use nalgebra::{Matrix3, Vector3};
use std::fmt::Write as _;

/// A number as text that every YAML reader (YAML 1.1 as Kalibr's, 1.2, OpenCV's) and a C++
/// stream take as the same `f64`: the shortest representation that reads back exactly, always
/// with a decimal point, and in scientific form with a signed exponent (`1.5e-7`, YAML 1.1
/// reads `1e-7` as a string).
pub(crate) fn number(x: f64) -> String {
    if x == 0.0 {
        return "0.0".into();
    }
    let a = x.abs();
    if (1e-4..1e7).contains(&a) {
        let s = format!("{x}");
        return if s.contains('.') { s } else { s + ".0" };
    }
    let s = format!("{x:e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let m = if m.contains('.') {
        m.to_string()
    } else {
        format!("{m}.0")
    };
    let e = if e.starts_with('-') {
        e.to_string()
    } else {
        format!("+{e}")
    };
    format!("{m}e{e}")
}

/// `M = Q L`: Q orthogonal, L lower-triangular with a positive diagonal (Gram-Schmidt on the
/// columns from the last: column j of M is `sum_{k >= j} L_kj q_k`). `None` when M is
/// singular or its determinant is negative (Q would then be a reflection, no rotation).
pub(crate) fn ql(m: &Matrix3<f64>) -> Option<(Matrix3<f64>, Matrix3<f64>)> {
    if m.determinant().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let mut q = Matrix3::zeros();
    let mut l = Matrix3::zeros();
    for j in (0..3).rev() {
        let mut r: Vector3<f64> = m.column(j).into();
        for k in j + 1..3 {
            let qk: Vector3<f64> = q.column(k).into();
            let c = qk.dot(&r);
            l[(k, j)] = c;
            r -= c * qk;
        }
        let n = r.norm();
        if n == 0.0 || !n.is_finite() {
            return None;
        }
        l[(j, j)] = n;
        q.set_column(j, &(r / n));
    }
    Some((q, l))
}

/// The white level and bias walk of one sensor for Kalibr, SI (`*_noise_density` per
/// sqrt(Hz), `*_random_walk` per sqrt(Hz) of the derivative), with the axis each is taken from.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Densities {
    /// rad/s/sqrt(Hz) (gyro) or m/s^2/sqrt(Hz) (accelerometer).
    pub(crate) noise_density: f64,
    /// The axis (`x`, `y`, `z`) the noise density is of.
    pub(crate) noise_axis: char,
    /// rad/s^2/sqrt(Hz) (gyro) or m/s^3/sqrt(Hz) (accelerometer).
    pub(crate) random_walk: f64,
    /// The axis the random walk is of.
    pub(crate) walk_axis: char,
}

/// Both sensors' figures, the record rate and the topic: everything of Kalibr's `imu.yaml`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct NoiseFigures {
    /// Gyros.
    pub(crate) gyro: Densities,
    /// Accelerometers.
    pub(crate) accel: Densities,
    /// Records per second (1 / the noise file's median interval).
    pub(crate) update_rate_hz: f64,
    /// The ROS topic the IMU is published on.
    pub(crate) rostopic: String,
}

/// The noise lines shared by Kalibr's `imu.yaml` and OpenVINS's `kalibr_imu_chain.yaml`,
/// indented by `indent`.
fn noise_lines(n: &NoiseFigures, indent: &str) -> String {
    let mut s = String::new();
    let rows = [
        (
            "accelerometer_noise_density",
            n.accel.noise_density,
            "m/s^2/sqrt(Hz)",
            n.accel.noise_axis,
        ),
        (
            "accelerometer_random_walk",
            n.accel.random_walk,
            "m/s^3/sqrt(Hz)",
            n.accel.walk_axis,
        ),
        (
            "gyroscope_noise_density",
            n.gyro.noise_density,
            "rad/s/sqrt(Hz)",
            n.gyro.noise_axis,
        ),
        (
            "gyroscope_random_walk",
            n.gyro.random_walk,
            "rad/s^2/sqrt(Hz)",
            n.gyro.walk_axis,
        ),
    ];
    for (key, v, unit, axis) in rows {
        let _ = writeln!(
            s,
            "{indent}{key}: {}  # {unit}, axis {axis} (the largest)",
            number(v)
        );
    }
    let _ = writeln!(s, "{indent}rostopic: {}", yaml_string(&n.rostopic));
    let _ = writeln!(s, "{indent}update_rate: {}  # Hz", number(n.update_rate_hz));
    s
}

/// A YAML scalar string: plain where that reads back as the same string, else double-quoted.
fn yaml_string(s: &str) -> String {
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '/' | '_' | '-' | '.'))
        && !s.starts_with('-')
        && s.parse::<f64>().is_err()
        && !matches!(
            s.to_ascii_lowercase().as_str(),
            "true" | "false" | "yes" | "no" | "on" | "off" | "null" | "y" | "n"
        );
    if plain {
        s.to_string()
    } else {
        serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
    }
}

/// Kalibr's `imu.yaml`, with `header` (comment lines) first.
pub(crate) fn kalibr_yaml(n: &NoiseFigures, header: &str) -> String {
    format!("{header}{}", noise_lines(n, ""))
}

/// A 3x3 matrix as YAML rows (`- [a, b, c]`) indented by `indent`.
fn yaml_matrix(m: &Matrix3<f64>, indent: &str) -> String {
    let mut s = String::new();
    for i in 0..3 {
        let _ = writeln!(
            s,
            "{indent}- [{}, {}, {}]",
            number(m[(i, 0)]),
            number(m[(i, 1)]),
            number(m[(i, 2)])
        );
    }
    s
}

/// OpenVINS's intrinsics and biases of a correction's linear part (module docs).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct OpenVinsIntrinsics {
    /// `Tw = L^-1` (lower-triangular).
    pub(crate) tw: Matrix3<f64>,
    /// `R_IMUtoGYRO = Q^T`.
    pub(crate) r_imu_to_gyro: Matrix3<f64>,
    /// `Ta = M_a^-1` (lower-triangular).
    pub(crate) ta: Matrix3<f64>,
    /// `R_IMUtoACC = I`: this tool's body frame is the accelerometers'.
    pub(crate) r_imu_to_acc: Matrix3<f64>,
    /// `Tg = -G` (rad/s per m/s^2; zero without the g-sensitivity term).
    pub(crate) tg: Matrix3<f64>,
    /// `b_g = -nu0` (rad/s).
    pub(crate) bias_g: Vector3<f64>,
    /// `b_a = df0` (m/s^2).
    pub(crate) bias_a: Vector3<f64>,
}

/// OpenVINS's intrinsics of `w = M_g (w' + b_g + G f)`, `f = M_a (f' + b_a)` (the fields of a
/// [`calib::model::correction::Correction`]); `None` when `M_g` has no positive determinant or
/// `M_a` cannot be inverted or is not lower-triangular.
pub(crate) fn openvins_intrinsics(
    gyro_matrix: &Matrix3<f64>,
    gyro_offset: &Vector3<f64>,
    gsens: Option<&Matrix3<f64>>,
    accel_matrix: &Matrix3<f64>,
    accel_offset: &Vector3<f64>,
) -> Option<OpenVinsIntrinsics> {
    let (q, l) = ql(gyro_matrix)?;
    let tw = l.try_inverse()?.lower_triangle();
    if accel_matrix.upper_triangle() != Matrix3::from_diagonal(&accel_matrix.diagonal()) {
        return None;
    }
    let ta = accel_matrix.try_inverse()?.lower_triangle();
    Some(OpenVinsIntrinsics {
        tw,
        r_imu_to_gyro: q.transpose(),
        ta,
        r_imu_to_acc: Matrix3::identity(),
        tg: -gsens.copied().unwrap_or_else(Matrix3::zeros),
        bias_g: -gyro_offset,
        bias_a: -accel_offset,
    })
}

/// OpenVINS's `kalibr_imu_chain.yaml` (`imu0`), with `header` (comment lines) after the
/// `%YAML:1.0` line OpenVINS's own files start with (its reader is OpenCV's).
pub(crate) fn openvins_yaml(n: &NoiseFigures, c: &OpenVinsIntrinsics, header: &str) -> String {
    let mut s = format!("%YAML:1.0\n{header}\nimu0:\n  T_i_b:\n");
    for i in 0..4 {
        let row: Vec<&str> = (0..4).map(|j| if i == j { "1.0" } else { "0.0" }).collect();
        let _ = writeln!(s, "    - [{}]", row.join(", "));
    }
    s += &noise_lines(n, "  ");
    s += "  time_offset: 0.0\n  model: \"kalibr\"\n";
    for (key, m) in [
        ("Tw", &c.tw),
        ("R_IMUtoGYRO", &c.r_imu_to_gyro),
        ("Ta", &c.ta),
        ("R_IMUtoACC", &c.r_imu_to_acc),
        ("Tg", &c.tg),
    ] {
        let _ = writeln!(s, "  {key}:");
        s += &yaml_matrix(m, "    ");
    }
    s += "  # The calibration's biases in OpenVINS's convention (w_m - b_g, a_m - b_a). OpenVINS\n  \
          # reads no bias from this file (its filter estimates them, from zero at its start):\n  \
          # these two keys are for the reader, not for OpenVINS.\n";
    for (key, v, unit) in [
        ("sins_calib_bias_g", &c.bias_g, "rad/s"),
        ("sins_calib_bias_a", &c.bias_a, "m/s^2"),
    ] {
        let _ = writeln!(
            s,
            "  {key}: [{}, {}, {}]  # {unit}",
            number(v[0]),
            number(v[1]),
            number(v[2])
        );
    }
    s
}

/// imu_tk's triad: `X' = T K (X - B)`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ImuTkTriad {
    /// Misalignment, unit diagonal.
    pub(crate) t: Matrix3<f64>,
    /// Scale, diagonal.
    pub(crate) k: Matrix3<f64>,
    /// Bias.
    pub(crate) b: Vector3<f64>,
}

/// The triad of `X' = M (X + offset)`: `K = diag(M)`, `T = M K^-1`, `B = -offset`; `None`
/// when a diagonal entry of M is not positive.
pub(crate) fn imu_tk_triad(m: &Matrix3<f64>, offset: &Vector3<f64>) -> Option<ImuTkTriad> {
    let d = m.diagonal();
    if !d.iter().all(|x| *x > 0.0 && x.is_finite()) {
        return None;
    }
    let k = Matrix3::from_diagonal(&d);
    let t = Matrix3::from_fn(|i, j| if i == j { 1.0 } else { m[(i, j)] / d[j] });
    Some(ImuTkTriad { t, k, b: -offset })
}

/// The text of an imu_tk calibration file as `CalibratedTriad_::save` lays it out and `load`
/// reads it: T (3 rows), a blank line, K, a blank line, B (one value a line), a blank line;
/// values separated by spaces, at full precision.
pub(crate) fn imu_tk_text(t: &ImuTkTriad) -> String {
    let mut s = String::new();
    for m in [&t.t, &t.k] {
        for i in 0..3 {
            let _ = writeln!(
                s,
                "{} {} {}",
                number(m[(i, 0)]),
                number(m[(i, 1)]),
                number(m[(i, 2)])
            );
        }
        s.push('\n');
    }
    for v in t.b.iter() {
        let _ = writeln!(s, "{}", number(*v));
    }
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_exactly_with_a_point() {
        for x in [
            0.0,
            1.0,
            -2.5,
            1e-4,
            9.999e-5,
            1.234_567_890_123e-7,
            3e12,
            -4.2e-20,
            200.0,
        ] {
            let s = number(x);
            assert_eq!(s.parse::<f64>().unwrap(), x, "{s}");
            assert!(s.contains('.'), "{s}");
            if let Some((_, e)) = s.split_once('e') {
                assert!(e.starts_with('-') || e.starts_with('+'), "{s}");
            }
        }
    }

    #[test]
    fn ql_reproduces_the_matrix_with_a_rotation() {
        let m = Matrix3::new(1.001, 2e-4, -3e-4, -1e-4, 0.998, 5e-4, 4e-4, -2e-4, 1.0003);
        let (q, l) = ql(&m).unwrap();
        assert!((q * l - m).abs().max() < 1e-15);
        assert!((q.transpose() * q - Matrix3::identity()).abs().max() < 1e-15);
        assert!((q.determinant() - 1.0).abs() < 1e-15);
        assert_eq!(l.upper_triangle(), Matrix3::from_diagonal(&l.diagonal()));
        assert!(l.diagonal().iter().all(|x| *x > 0.0));
        assert!(ql(&-Matrix3::<f64>::identity()).is_none());
    }

    #[test]
    fn yaml_strings_that_would_change_are_quoted() {
        assert_eq!(yaml_string("/imu0"), "/imu0");
        assert_eq!(yaml_string("yes"), "\"yes\"");
        assert_eq!(yaml_string("1.5"), "\"1.5\"");
        assert_eq!(yaml_string("a: b"), "\"a: b\"");
    }
}
