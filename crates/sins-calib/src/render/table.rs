//! Plain-text tables in the paper's units: parameter groups, number formatting, alignment.

/// Parameter groups of the reports that are not candidate terms: (title, name prefix).
const GROUPS: [(&str, &str); 7] = [
    ("Gyro biases nu0", "gyro.bias."),
    (
        "Gyro matrix Theta (diagonal: scale factors, off-diagonal: misalignments)",
        "gyro.theta.",
    ),
    ("Accelerometer biases df0", "accel.bias."),
    (
        "Accelerometer matrix Gamma (diagonal: scale factors, below: non-orthogonality)",
        "accel.gamma.",
    ),
    (
        "Installation misalignment delta_z (instrument on the platform)",
        sins_model::names::INSTALL_PREFIX,
    ),
    (
        "Delay tau of the turntable data (after the [clock] relation)",
        sins_model::names::TURNTABLE_TAU,
    ),
    (
        "Base misalignment gamma_p (turntable base against ENU)",
        sins_model::names::BASE_PREFIX,
    ),
];

/// Title of the group a parameter belongs to: the paper's and the turntable's groups, then
/// each candidate term's, from its declaration.
fn group_title(name: &str) -> &'static str {
    let candidates = sins_model::candidates::Candidate::ALL.map(|c| {
        let d = c.declaration();
        (d.group_title, d.params.prefix())
    });
    GROUPS
        .iter()
        .chain(&candidates)
        .find(|(_, prefix)| name.starts_with(prefix))
        .map_or("Other parameters", |(title, _)| title)
}

/// Indices of the parameters (attitude errors excluded) grouped for a report: each group with its
/// title, groups in the order of their first parameter, parameters in state order.
pub fn grouped(names: &[String]) -> Vec<(&'static str, Vec<usize>)> {
    let mut groups: Vec<(&'static str, Vec<usize>)> = Vec::new();
    for (i, name) in names.iter().enumerate() {
        if name.starts_with("attitude.") {
            continue;
        }
        let title = group_title(name);
        match groups.iter_mut().find(|(t, _)| *t == title) {
            Some((_, members)) => members.push(i),
            None => groups.push((title, vec![i])),
        }
    }
    groups
}

/// Exponent of the last digit shown for a standard deviation (two significant digits).
fn last_digit(sigma: f64) -> i32 {
    sigma.abs().log10().floor() as i32 - 1
}

/// Whether numbers with this sigma are shown in fixed-point notation.
fn fixed_point(sigma: f64) -> bool {
    (1e-4..1e6).contains(&sigma.abs())
}

/// `x` to the precision that `sigma` (its standard deviation, same unit) warrants: fixed-point
/// for sigmas from 1e-4 to 1e6, else scientific with as many digits as the sigma allows.
pub fn with_precision_of(x: f64, sigma: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    if !(sigma.is_finite() && sigma > 0.0) {
        return significant(x, 6);
    }
    let last = last_digit(sigma);
    if fixed_point(sigma) && x.abs() < 1e9 {
        let decimals = (-last).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        let exponent = x.abs().log10().floor() as i32;
        let digits = (exponent - last).clamp(0, 12) as usize;
        format!("{x:.digits$e}")
    }
}

/// A standard deviation with two significant digits.
pub fn sigma(s: f64) -> String {
    if !(s.is_finite() && s > 0.0) {
        return format!("{s}");
    }
    with_precision_of(s, s)
}

/// `x` with `n` significant digits (fixed-point from 1e-3 to 1e6, else scientific).
pub fn significant(x: f64, n: usize) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let exponent = x.abs().log10().floor() as i32;
    if (-3..6).contains(&exponent) {
        let decimals = (n as i32 - 1 - exponent).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        let digits = n.saturating_sub(1);
        format!("{x:.digits$e}")
    }
}

/// `x` with up to seven significant digits and no trailing zeros (times, rates, durations).
pub fn compact(x: f64) -> String {
    let s = significant(x, 7);
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
        }
        None if s.contains('.') => s.trim_end_matches('0').trim_end_matches('.').to_string(),
        _ => s,
    }
}

/// An axis tick of a plot: [`compact`], and 0 for what rounding left of a zero (a tick at
/// `-1.4e-18` where the axis crosses zero). The plots' axes are in sigmas, correlations, ratios,
/// seconds or segment numbers, none of which has a meaningful tick below 1e-12.
pub fn tick(x: f64) -> String {
    if x.abs() < 1e-12 {
        "0".to_string()
    } else {
        compact(x)
    }
}

/// Column alignment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    /// Text.
    Left,
    /// Numbers.
    Right,
}

/// A plain-text table with section rows.
#[derive(Debug)]
pub struct Table {
    header: Vec<String>,
    align: Vec<Align>,
    rows: Vec<Option<Vec<String>>>,
    titles: Vec<String>,
}

impl Table {
    /// A table with these column headers and alignments.
    pub fn new(columns: &[(&str, Align)]) -> Self {
        Self {
            header: columns.iter().map(|(h, _)| h.to_string()).collect(),
            align: columns.iter().map(|(_, a)| *a).collect(),
            rows: Vec::new(),
            titles: Vec::new(),
        }
    }

    /// A section title spanning the table.
    pub fn section(&mut self, title: &str) {
        self.titles.push(title.to_string());
        self.rows.push(None);
    }

    /// A row of cells (as many as columns).
    pub fn row(&mut self, cells: Vec<String>) {
        debug_assert_eq!(cells.len(), self.header.len());
        self.rows.push(Some(cells));
    }

    /// The table as text, each line indented by two spaces.
    pub fn render(&self) -> String {
        let mut width: Vec<usize> = self.header.iter().map(|h| h.chars().count()).collect();
        for cells in self.rows.iter().flatten() {
            for (w, c) in width.iter_mut().zip(cells) {
                *w = (*w).max(c.chars().count());
            }
        }
        let line = |cells: &[String]| {
            let mut s = String::from("  ");
            for (k, ((c, w), a)) in cells.iter().zip(&width).zip(&self.align).enumerate() {
                if k > 0 {
                    s.push_str("  ");
                }
                match a {
                    Align::Left => s += &format!("{c:<w$}"),
                    Align::Right => s += &format!("{c:>w$}"),
                }
            }
            s.truncate(s.trim_end().len());
            s.push('\n');
            s
        };
        let mut out = line(&self.header);
        let mut titles = self.titles.iter();
        for row in &self.rows {
            match row {
                Some(cells) => out += &line(cells),
                None => {
                    let title = titles.next().map_or("", String::as_str);
                    out += &format!("  {title}\n");
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every parameter of every candidate term lands in its own group, under its declared
    /// title; the paper's keep theirs.
    #[test]
    fn every_candidate_parameter_has_its_group() {
        for c in sins_model::candidates::Candidate::ALL {
            for name in c.param_names() {
                assert_eq!(group_title(&name), c.declaration().group_title, "{name}");
            }
        }
        assert_eq!(group_title("gyro.bias.x"), "Gyro biases nu0");
        assert_eq!(group_title("gyro.wobble.x"), "Other parameters");
    }

    #[test]
    fn precision_follows_the_sigma() {
        assert_eq!(with_precision_of(-0.298655, 0.00376), "-0.2987");
        assert_eq!(sigma(0.00376), "0.0038");
        assert_eq!(with_precision_of(-1.8398e-3, 1.505e-7), "-1.83980e-3");
        assert_eq!(sigma(1.505e-7), "1.5e-7");
        assert_eq!(with_precision_of(1.7848e-2, 1.925e-5), "1.7848e-2");
        assert_eq!(with_precision_of(0.0, 1.925e-5), "0");
        assert_eq!(with_precision_of(-79.07, 0.0126), "-79.070");
        assert_eq!(significant(0.5, 3), "0.500");
        assert_eq!(significant(3.6e-6, 3), "3.60e-6");
        assert_eq!(compact(0.01), "0.01");
        assert_eq!(compact(2727.0), "2727");
        assert_eq!(compact(2740.04), "2740.04");
        assert_eq!(compact(50.01000000004548), "50.01");
        assert_eq!(compact(2.5e-7), "2.5e-7");
        // Plot ticks: the floating-point sum of steps, and a zero left by rounding.
        assert_eq!(tick(0.1 + 0.2), "0.3");
        assert_eq!(tick(-1.38894e-18), "0");
        assert_eq!(tick(-0.05), "-0.05");
    }

    #[test]
    fn groups_keep_state_order_and_skip_the_attitude() {
        let names: Vec<String> = [
            "attitude.beta.x",
            "gyro.bias.x",
            "gyro.theta.xx",
            "install.delta.x",
            "turntable.tau",
            "gyro.bias.y",
            "something.new",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let g = grouped(&names);
        assert_eq!(g.len(), 5);
        assert_eq!(g[0].1, vec![1, 5]);
        assert_eq!(g[4].0, "Other parameters");
    }
}
