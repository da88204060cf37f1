//! The strongest correlations of a calibration explained in words, for the laboratory report:
//! for a pair of estimates correlated at |r| >= [`EXPLAINED_ABOVE`], which two, the value, what
//! the data determine of them and, where the pair is one this program knows, why its
//! measurements cannot tell them apart.
//!
//! What the data determine: with errors `e_a`, `e_b` of sigmas `s_a`, `s_b` and correlation r,
//! the combination `e_a / s_a - sign(r) e_b / s_b` has the standard deviation
//! `sqrt(2 (1 - |r|))` (in units of their sigmas), while each alone has 1: for r = +0.99 the
//! difference of the two (each in units of its sigma) is known seven times better than either.

/// Correlations at least this strong (in magnitude) are explained.
pub const EXPLAINED_ABOVE: f64 = 0.9;

/// The axis letter after the last dot of a parameter name, or the two letters of a matrix
/// entry (`gyro.theta.yz` gives `yz`).
fn suffix(name: &str) -> &str {
    name.rsplit('.').next().unwrap_or("")
}

/// The axis (x, y, z) that is neither of the two letters of `pair`, when they differ.
fn third_axis(pair: &str) -> Option<char> {
    let c: Vec<char> = pair.chars().collect();
    if c.len() != 2 || c[0] == c[1] {
        return None;
    }
    ['x', 'y', 'z'].into_iter().find(|a| !c.contains(a))
}

/// Why the measurements of this program cannot separate `a` and `b`, for the pairs whose
/// cause lies in the model's structure; `None` for others.
fn cause(a: &str, b: &str) -> Option<String> {
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    let theta_delta = a.starts_with("gyro.theta.") && b.starts_with("install.delta.");
    if theta_delta && third_axis(suffix(a)) == suffix(b).chars().next() {
        let axis = suffix(b);
        return Some(format!(
            "the turntable's angles measure the orientation of the gyro triad on the platform, \
             which is the mounting misalignment about {axis} plus the antisymmetric part of the \
             gyro misalignments about {axis}; only the accelerometers, through gravity at the \
             rests, tell the accelerometer-defined body frame from the gyro triad, far less \
             precisely than the angle sensors do"
        ));
    }
    if a.starts_with("accel.gamma.") && b.starts_with("gyro.theta.") {
        let (p, q): (Vec<char>, Vec<char>) =
            (suffix(a).chars().collect(), suffix(b).chars().collect());
        let same_pair = p.len() == 2 && q.len() == 2 && p[0] != p[1] && {
            let (mut p, mut q) = (p.clone(), q.clone());
            p.sort_unstable();
            q.sort_unstable();
            p == q
        };
        if same_pair && let Some(axis) = third_axis(suffix(a)) {
            return Some(format!(
                "the rests see gravity through the accelerometers and the attitude between \
                 them is the gyros': a rotation of one triad against the other about {axis} \
                 shows as either misalignment, and only the turntable's angles (or rests whose \
                 turns differ in axis) tell which triad is turned"
            ));
        }
    }
    if a.starts_with("gyro.theta.") && b.starts_with("gyro.theta.") {
        let (p, q): (Vec<char>, Vec<char>) =
            (suffix(a).chars().collect(), suffix(b).chars().collect());
        if p.len() == 2 && q.len() == 2 && p[0] == q[1] && p[1] == q[0] && p[0] != p[1] {
            return Some(
                "the two misalignments between the same pair of gyro axes share their \
                 antisymmetric part (a rotation of the triad), which the data determine only \
                 together with the mounting misalignment"
                    .into(),
            );
        }
    }
    // The bias of axis i and the row i of its sensor's matrix (the error of sensor i).
    let same_axis = suffix(a).chars().next() == suffix(b).chars().next();
    if a.starts_with("accel.bias.") && b.starts_with("accel.gamma.") && same_axis {
        return Some(format!(
            "accelerometer {} is held in few orientations against gravity: its rests measure \
             the bias plus g times the scale factor, and only a rest with that axis the other \
             way up separates them",
            suffix(a)
        ));
    }
    if a.starts_with("gyro.bias.") && b.starts_with("gyro.theta.") && same_axis {
        return Some(format!(
            "gyro {} turns little or at one rate: its bias and its scale factor (or \
             misalignment) add to the same drift unless it also turns the other way or at \
             another rate",
            suffix(a)
        ));
    }
    if a.starts_with("install.delta.") && b.starts_with("base.gamma.")
        || a.starts_with("base.gamma.") && b.starts_with("install.delta.")
    {
        return Some(
            "both are constant rotations of the attitude; only the turntable's rotations tell \
             them apart (the mounting turns with the platform, the base does not)"
                .into(),
        );
    }
    if a.starts_with("attitude.beta.") || b.starts_with("attitude.beta.") {
        return Some(
            "the initial attitude error and this parameter turn the computed attitude alike \
             over the data; motion that makes their effects grow differently separates them"
                .into(),
        );
    }
    if a == "turntable.tau" || b == "turntable.tau" {
        return Some(
            "a delay of the angle data shows as an angle error proportional to the rate, as a \
             scale or misalignment error does while the rate is constant"
                .into(),
        );
    }
    None
}

/// The sentence of one strongly correlated pair.
pub fn sentence(a: &str, b: &str, r: f64) -> String {
    let what = if r > 0.0 { "difference" } else { "sum" };
    let op = if r > 0.0 { '-' } else { '+' };
    let spread = (2.0 * (1.0 - r.abs())).max(0.0).sqrt();
    let mut s = format!(
        "`{a}` and `{b}` are correlated at {r:+.4}: the data determine their {what}, \
         `{a}`/sigma {op} `{b}`/sigma, to {spread:.3} of a sigma (each alone to 1), and each \
         only as well as the other is known"
    );
    match cause(a, b) {
        Some(c) => {
            s += ". Why: ";
            s += &c;
            s += ".";
        }
        None => {
            s += ". Nothing in this program's motion separates their effects on the \
                       measurements; `sins-calib design` proposes motion that does."
        }
    }
    s
}

/// The sentences of every pair of `strongest` at |r| >= [`EXPLAINED_ABOVE`].
pub fn sentences(strongest: &[(String, String, f64)]) -> Vec<String> {
    strongest
        .iter()
        .filter(|(_, _, r)| r.abs() >= EXPLAINED_ABOVE)
        .map(|(a, b, r)| sentence(a, b, *r))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mounting_pair_is_explained_with_its_axis() {
        let s = sentence("gyro.theta.yz", "install.delta.x", 0.99);
        assert!(s.contains("correlated at +0.9900"), "{s}");
        assert!(s.contains("their difference"), "{s}");
        assert!(s.contains("to 0.141 of a sigma"), "{s}");
        assert!(s.contains("mounting misalignment about x"), "{s}");
        let s = sentence("install.delta.z", "gyro.theta.yx", -0.95);
        assert!(s.contains("their sum"), "{s}");
        assert!(s.contains("about z"), "{s}");
        // theta.yz does not pair with delta.y by this cause.
        assert!(sentence("gyro.theta.yz", "install.delta.y", 0.95).contains("design"));
        let s = sentence("gyro.theta.yz", "accel.gamma.zy", 0.999);
        assert!(s.contains("one triad against the other about x"), "{s}");
    }

    #[test]
    fn only_strong_pairs_get_a_sentence() {
        let pairs = vec![
            (
                "accel.bias.z".to_string(),
                "accel.gamma.zz".to_string(),
                -0.97,
            ),
            (
                "gyro.theta.xy".to_string(),
                "gyro.theta.yx".to_string(),
                -0.85,
            ),
        ];
        let s = sentences(&pairs);
        assert_eq!(s.len(), 1);
        assert!(s[0].contains("accelerometer z"), "{}", s[0]);
    }
}
