//! One module per subcommand: each declares its arguments (or takes them from `crate::args`)
//! and its `run`, which reads the inputs, calls the libraries and hands the figures to
//! `crate::render` and `crate::plots`.

pub mod analyse;
pub mod apply;
pub mod calibrate;
pub mod design;
pub mod diagnose;
pub mod export;
pub mod import;
pub mod noise;
pub mod segment;
pub mod simulate;
