//! The result file (JSON): its parameters, temperature and verdict, written and read back.

use super::csv_rows::excerpt;
use super::{IoError, read_text, write_text};
use serde::{Deserialize, Serialize};
use std::path::Path;
use turntable::simulate::Truth;

/// One parameter of a result or truth file (SI units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResultParameter {
    /// Documented name, e.g. `gyro.theta.xy`.
    pub name: String,
    /// Value (SI).
    pub value: f64,
    /// Standard deviation (SI); absent in a truth file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma: Option<f64>,
    /// SI unit name.
    pub unit: String,
}

/// A result (or truth) file: `{"parameters": [...]}`, and in a calibration's result the
/// posterior `correlation` and the `correction` block (absent in older files and in truth
/// files; other keys such as `fit` are ignored when reading).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ResultFile {
    /// The file's schema stamp ([`crate::io::schema`]; absent in files written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema: Option<crate::io::schema::Schema>,
    /// The unit the result is of (absent: not known).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<crate::config::UnitIdentity>,
    /// Parameters in state order.
    pub parameters: Vec<ResultParameter>,
    /// Correlation matrix of the parameters (rows and columns in the order of `parameters`),
    /// [`crate::io::posterior::correlation`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub correlation: Option<Vec<Vec<f64>>>,
    /// The estimated model inverted, in matrix form ([`crate::model::correction`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub correction: Option<super::correction_block::CorrectionBlock>,
    /// The verdict `calibrate` wrote beside them (read only: the writer of the result file
    /// writes its own), so that `apply` can refuse a calibration the data contradicted.
    #[serde(default, skip_serializing)]
    pub verdict: Option<ResultVerdict>,
    /// The temperatures of the recording and the reference the thermal terms are about, when
    /// the records had a temperature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature: Option<ResultTemperature>,
}

/// The temperature of a calibrated recording (deg C).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResultTemperature {
    /// The temperature the thermal coefficients are about, and the one at which the biases and
    /// scale factors of the result hold.
    pub reference_c: f64,
    /// Why this reference.
    pub reference_reason: String,
    /// Lowest temperature of the records (absent in a simulation's truth).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_c: Option<f64>,
    /// Highest temperature of the records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_c: Option<f64>,
}

/// The verdict of a result file: whether the data contradicted the model, and why.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
pub struct ResultVerdict {
    /// Nothing contradicted the model.
    pub fits: bool,
    /// One line per reason when something did.
    #[serde(default)]
    pub reasons: Vec<String>,
}

impl ResultFile {
    /// Value and sigma of a parameter by name.
    pub fn get(&self, name: &str) -> Option<&ResultParameter> {
        self.parameters.iter().find(|p| p.name == name)
    }
}

impl From<&Truth> for ResultFile {
    fn from(truth: &Truth) -> Self {
        Self {
            parameters: truth
                .parameters
                .iter()
                .map(|p| ResultParameter {
                    name: p.name.clone(),
                    value: p.value,
                    sigma: None,
                    unit: p.unit.clone(),
                })
                .collect(),
            correlation: None,
            correction: None,
            verdict: None,
            temperature: truth
                .temperature_reference_c
                .map(|reference_c| ResultTemperature {
                    reference_c,
                    reference_reason: "the simulation's reference temperature".into(),
                    min_c: None,
                    max_c: None,
                }),
            schema: Some(crate::io::schema::Schema::current(crate::io::schema::TRUTH)),
            unit: None,
        }
    }
}

/// Write a result file as pretty JSON.
pub fn write_result_json(path: &Path, result: &ResultFile) -> Result<(), IoError> {
    let text = serde_json::to_string_pretty(result).expect("plain data serialises");
    write_text(path, &(text + "\n"))
}

/// Write the truth of a simulated run (no sigma).
pub fn write_truth_json(path: &Path, truth: &Truth) -> Result<(), IoError> {
    write_result_json(path, &ResultFile::from(truth))
}

/// The kinds of file [`read_result_json`] reads: they all hold `parameters`.
pub const RESULT_KINDS: [&str; 3] = [
    crate::io::schema::CALIBRATION,
    crate::io::schema::TRUTH,
    crate::io::schema::DIAGNOSIS,
];

/// Read a result or truth file: every value finite and within the physical bounds of
/// [`crate::config::plausible`], each parameter named once, and its schema stamp neither of another
/// kind nor newer than this program ([`crate::io::schema::check`]).
pub fn read_result_json(path: &Path) -> Result<ResultFile, IoError> {
    let text = read_text(path)?;
    let file = path.display().to_string();
    let result: ResultFile = serde_json::from_str(&text).map_err(|source| IoError::Json {
        file: file.clone(),
        source,
    })?;
    if let Some(stamp) = &result.schema {
        let v = serde_json::to_value(stamp).expect("plain data");
        crate::io::schema::check(&file, Some(&v), &RESULT_KINDS, "a result or truth file")
            .map_err(|message| IoError::Stamp { message })?;
    }
    for (i, p) in result.parameters.iter().enumerate() {
        if result.parameters[..i].iter().any(|q| q.name == p.name) {
            return Err(IoError::File {
                file,
                message: format!(
                    "parameter `{}` is given twice: expected each name once",
                    excerpt(&p.name)
                ),
            });
        }
        if !p.value.is_finite() || p.sigma.is_some_and(|s| !s.is_finite()) {
            return Err(IoError::File {
                file,
                message: format!(
                    "parameter `{}`: expected a finite value and sigma",
                    excerpt(&p.name)
                ),
            });
        } // Physical bounds (`crate::config::plausible`): a bias of 1e308 or a 200 % scale error is a
        // typing error or a diverged fit, not a calibration to apply or a truth to compare with.
        if let Err(message) = crate::config::plausible::check(&p.name, p.value) {
            return Err(IoError::File {
                file,
                message: format!("parameter {message}"),
            });
        }
    }
    if let Some(r) = &result.correlation {
        crate::io::posterior::check_correlation(r, result.parameters.len())
            .map_err(|message| IoError::File { file, message })?;
    }
    Ok(result)
}

impl ResultFile {
    /// Refuse a parameter whose unit differs from the one the estimate uses (`expected` gives
    /// the SI unit by name; other names are not checked): values are SI, and a value in another
    /// unit would be compared as if it were.
    pub fn check_units<'a>(
        &self,
        file: &str,
        expected: impl Iterator<Item = (&'a str, &'a str)>,
    ) -> Result<(), IoError> {
        for (name, unit) in expected {
            if let Some(p) = self.get(name)
                && p.unit != unit
            {
                return Err(IoError::File {
                    file: file.to_string(),
                    message: format!(
                        "parameter `{name}` is in `{}`: expected `{unit}` (result and truth files \
                         hold SI values)",
                        excerpt(&p.unit)
                    ),
                });
            }
        }
        Ok(())
    }
}
