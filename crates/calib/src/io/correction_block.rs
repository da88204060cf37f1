//! The `correction` block of a result file: the inverted instrument model in matrix form
//! (`docs/formats.md`, "Correction"), as the file holds it. The model that builds and applies it
//! is [`crate::model::correction`].

use serde::{Deserialize, Serialize};

/// What the gyro extension terms (`G`, `a`) are evaluated at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExtensionInputs {
    /// The true (corrected) specific force and rate, as the filter and the simulator model them
    /// (`nu = ... + G f + diag(a) |w|`). Written `"corrected"`; `"true"`, the name earlier
    /// versions wrote (a string a reader could take for a boolean), is read as it.
    #[default]
    #[serde(rename = "corrected", alias = "true")]
    True,
    /// The measured ones, as the free-motion fit models them (`nu = ... + G f' + diag(a) |w'|`).
    Measured,
}

/// The `thermal` part of a [`CorrectionBlock`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalBlock {
    /// Reference temperature (deg C).
    pub reference_c: f64,
    /// `tb_g` (rad/s/K).
    pub gyro_bias: [f64; 3],
    /// `tb_a` (m/s^2/K).
    pub accel_bias: [f64; 3],
    /// `ts_g` (1/K).
    pub gyro_scale: [f64; 3],
    /// `ts_a` (1/K).
    pub accel_scale: [f64; 3],
}

/// The `correction` block of a result file: the `Correction` ([`crate::model::correction::Correction`]) in matrix form, rows of the
/// matrices as arrays (`docs/formats.md`, "Correction").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CorrectionBlock {
    /// The formulas the numbers belong to, for a reader of the file.
    pub convention: String,
    /// What the gyro extension terms are evaluated at (`"corrected"` or `"measured"`).
    pub extension_inputs: ExtensionInputs,
    /// Gyro triad.
    pub gyro: GyroBlock,
    /// Accelerometer triad.
    pub accel: AccelBlock,
    /// The thermal terms, when estimated: `M_g`, `b_g`, `M_a`, `b_a` above are at the
    /// reference temperature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal: Option<ThermalBlock>,
}

/// The gyro part of a [`CorrectionBlock`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroBlock {
    /// `M_g`, row by row.
    pub matrix: [[f64; 3]; 3],
    /// `b_g` (rad/s).
    pub offset: [f64; 3],
    /// `G` (rad/s per m/s^2), row by row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gsens: Option<[[f64; 3]; 3]>,
    /// `a`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub asym: Option<[f64; 3]>,
}

/// The accelerometer part of a [`CorrectionBlock`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelBlock {
    /// `M_a`, row by row.
    pub matrix: [[f64; 3]; 3],
    /// `b_a` (m/s^2).
    pub offset: [f64; 3],
    /// `k2` (1/(m/s^2)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k2: Option<[f64; 3]>,
    /// Row `i`: the offset `r_i` (m) of accelerometer `i`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lever: Option<[[f64; 3]; 3]>,
    /// `d` (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_offset_s: Option<f64>,
}

/// The formulas of a [`CorrectionBlock`], written into it.
pub const CONVENTION_TRUE: &str = "w = M_g (w' + b_g + G f + diag(a) |w|); f = M_a (f' + b_a - \
     diag(k2) (f o f) - s(w, dw/dt) + d df/dt), s_i = e_i . ((skew(dw/dt) + skew(w)^2) r_i), r_i = \
     row i of lever; absent terms zero";
/// The formulas of a [`CorrectionBlock`] with [`ExtensionInputs::Measured`].
pub const CONVENTION_MEASURED: &str = "w = M_g (w' + b_g + G f' + diag(a) |w'|); f = M_a (f' + \
     b_a - diag(k2) (f o f) - s(w, dw/dt) + d df/dt), s_i = e_i . ((skew(dw/dt) + skew(w)^2) \
     r_i), r_i = row i of lever; absent terms zero";
