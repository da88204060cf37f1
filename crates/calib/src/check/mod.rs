//! Checks of a fit: the innovation diagnostics and the consistency statistics.
//!
//! - [`diagnostics`]: tests of a fit from its innovations (NIS per segment, whiteness, lines at
//!   the program's frequencies, regression on candidate terms);
//! - [`score`]: score tests of candidate terms, one at a time or all from one extended pass;
//! - [`stats`]: NEES and chi-square bands.

pub mod diagnostics;
pub mod score;
pub mod stats;
