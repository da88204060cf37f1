//! The report directory of `diagnose`: `report.md` with the loop's summary, the diagnostics of
//! the base and the final model, and PNG plots of their innovations.

use crate::Error;
use calib::extend::LoopResult;
use std::fmt::Write as _;
use std::path::Path;

/// Write `dir/report.md` and the plots.
pub fn write(dir: &Path, r: &LoopResult, summary: &str) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create: {e}", dir.display()))?;
    let after = (!r.accepted_terms.is_empty())
        .then_some((&r.last.diagnostics, r.last.estimate.innovations.as_slice()));
    let plots = crate::diagnostic_plots::write_diagnostic_plots(
        dir,
        &r.base.diagnostics,
        &r.base.estimate.innovations,
        after,
    )?;
    let mut md = String::from("# Model diagnosis\n\n");
    let _ = writeln!(
        md,
        "Produced by `sins-calib diagnose` (method: docs/model-extension.md). Terms accepted: {}.\n",
        if r.accepted_terms.is_empty() {
            "none".to_string()
        } else {
            r.accepted_terms.join(", ")
        }
    );
    let _ = writeln!(md, "## The loop\n\n```text\n{summary}```\n");
    for (label, fit) in [("paper's model", &r.base), ("final model", &r.last)] {
        let _ = writeln!(md, "## Diagnostics of the {label}\n");
        let d = &fit.diagnostics;
        let _ = writeln!(
            md,
            "Verdict: {}.\n",
            if d.fits {
                "fits".to_string()
            } else {
                format!("does not fit ({})", d.failures.join("; "))
            }
        );
        let _ = writeln!(
            md,
            "Log-likelihood of the innovations {:.1} over {} scalar innovations; mean NIS \
             specific force {:.3}, turntable {:.3}.\n",
            fit.log_likelihood,
            fit.observations,
            fit.estimate.stats.accel_mean_nis,
            fit.estimate.stats.turntable_mean_nis
        );
    }
    let _ = writeln!(md, "## Plots\n");
    for p in plots {
        let name = p
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let _ = writeln!(md, "![{name}]({name})\n");
    }
    let path = dir.join("report.md");
    std::fs::write(&path, md).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    Ok(())
}
