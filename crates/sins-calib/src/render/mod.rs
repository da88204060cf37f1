//! What the commands print and write about a run: its figures computed once
//! (`calibrate_figures`, `diagnose_figures`), rendered as the console printout (`console`,
//! `table`), the JSON result (`result_json`) and the laboratory report in Markdown and HTML
//! (`lab_report`).

pub mod calibrate_figures;
pub mod console;
pub mod diagnose_figures;
pub mod lab_report;
pub mod result_json;
pub mod table;
