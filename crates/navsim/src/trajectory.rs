//! True trajectories: the snake flight and a vehicle at rest.
//!
//! Frames: the navigation frame is local geographic ENU (x1 East, x2 North, x3 Up). The aircraft
//! body (= instrument) frame is x1 right wing, x2 forward (nose), x3 up, so that at zero attitude
//! with heading north it coincides with ENU. Attitude is heading `psi` (clockwise from north),
//! pitch (always 0 here: level flight, angle of attack neglected, the body x2 axis lies along the
//! velocity) and bank `gamma` (right wing down positive):
//! `c_body_to_enu = rot_z(-psi) * rot_y(gamma)`.
//!
//! A [`TrajectoryPoint`] carries the kinematics relative to the Earth (position, ENU velocity and
//! its rate, attitude, body rate relative to ENU); the inertial body rate and the specific force
//! follow for a given Earth rotation rate ([`TrajectoryPoint::body_rate`],
//! [`TrajectoryPoint::specific_force_body`]) so that tests can switch Earth rotation off.

use nalgebra::{Matrix3, Vector3};
use sins_model::attitude::{rot_y, rot_z};
use sins_model::earth::{Site, meridian_radius, prime_vertical_radius};

use crate::config::{ConfigError, SnakeConfig, TurnDirection};

/// The true motion of the vehicle at one instant (SI units, ENU, body = x1 right, x2 fwd, x3 up).
#[derive(Clone, Debug, PartialEq)]
pub struct TrajectoryPoint {
    /// Time since the start of the flight \[s\].
    pub t: f64,
    /// Geodetic latitude \[rad\].
    pub latitude: f64,
    /// Longitude \[rad\].
    pub longitude: f64,
    /// Height above the ellipsoid \[m\].
    pub height: f64,
    /// Heading, clockwise from north \[rad\].
    pub heading: f64,
    /// Bank angle, right wing down positive \[rad\].
    pub bank: f64,
    /// Velocity relative to the Earth in ENU (m/s).
    pub velocity_enu: Vector3<f64>,
    /// Time derivative of the ENU velocity components (m/s^2) (not including the rotation of
    /// the ENU frame).
    pub accel_enu: Vector3<f64>,
    /// Body-to-ENU direction cosine matrix.
    pub c_body_to_enu: Matrix3<f64>,
    /// Angular rate of the body relative to the ENU frame, in body axes [rad/s]:
    /// `d(c_body_to_enu)/dt = c_body_to_enu * skew(rate_body_wrt_enu)`.
    pub rate_body_wrt_enu: Vector3<f64>,
}

impl TrajectoryPoint {
    /// The site (latitude, longitude, height) of the point.
    pub fn site(&self) -> Site {
        Site {
            latitude: self.latitude,
            longitude: self.longitude,
            height: self.height,
        }
    }

    /// Meridian radius plus height \[m\].
    pub fn radius_north(&self) -> f64 {
        meridian_radius(self.latitude) + self.height
    }

    /// Prime-vertical radius plus height \[m\].
    pub fn radius_east(&self) -> f64 {
        prime_vertical_radius(self.latitude) + self.height
    }

    /// Earth rate in ENU for an Earth rotating at `earth_rate` (rad/s).
    pub fn earth_rate_enu(&self, earth_rate: f64) -> Vector3<f64> {
        Vector3::new(
            0.0,
            earth_rate * self.latitude.cos(),
            earth_rate * self.latitude.sin(),
        )
    }

    /// Transport rate (rate of ENU relative to the Earth) in ENU [rad/s]:
    /// `(-V_N/(R_M+h), V_E/(R_N+h), V_E tan(phi)/(R_N+h))`.
    pub fn transport_rate_enu(&self) -> Vector3<f64> {
        let v = &self.velocity_enu;
        let re = self.radius_east();
        Vector3::new(
            -v.y / self.radius_north(),
            v.x / re,
            v.x * self.latitude.tan() / re,
        )
    }

    /// Normal gravity vector (plumb line, incl. centrifugal) in ENU: `(0, 0, -g)`.
    pub fn gravity_enu(&self) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, -self.site().normal_gravity())
    }

    /// Angular rate of the body relative to inertial space, in body axes [rad/s]: what an ideal
    /// gyro triad measures. `C^T (Omega_ie + omega_en) + omega_nb`.
    pub fn body_rate(&self, earth_rate: f64) -> Vector3<f64> {
        self.c_body_to_enu.transpose()
            * (self.earth_rate_enu(earth_rate) + self.transport_rate_enu())
            + self.rate_body_wrt_enu
    }

    /// Specific force in ENU [m/s^2]: `dV/dt + (2 Omega_ie + omega_en) x V - g`.
    pub fn specific_force_enu(&self, earth_rate: f64) -> Vector3<f64> {
        let w = 2.0 * self.earth_rate_enu(earth_rate) + self.transport_rate_enu();
        self.accel_enu + w.cross(&self.velocity_enu) - self.gravity_enu()
    }

    /// Specific force in body axes [m/s^2]: what an ideal accelerometer triad measures.
    pub fn specific_force_body(&self, earth_rate: f64) -> Vector3<f64> {
        self.c_body_to_enu.transpose() * self.specific_force_enu(earth_rate)
    }
}

/// Body-to-ENU DCM of level flight: `rot_z(-heading) * rot_y(bank)`.
pub fn c_body_to_enu(heading: f64, bank: f64) -> Matrix3<f64> {
    rot_z(-heading) * rot_y(bank)
}

/// A true trajectory the navigation errors are propagated along.
pub trait Trajectory {
    /// Length of the trajectory \[s\]; it starts at `t = 0`.
    fn duration_s(&self) -> f64;
    /// The true motion at time `t` (clamped to `[0, duration]`).
    fn point(&self, t: f64) -> TrajectoryPoint;
    /// Times inside `(0, duration)` where the body rate or the acceleration jump (start and end
    /// of legs, turns and roll phases), in increasing order. The propagator ends a step at each
    /// of them so that a jump never falls inside a step.
    fn breakpoints(&self) -> Vec<f64> {
        Vec::new()
    }
}

/// A vehicle at rest at a site with a given heading (level).
#[derive(Clone, Debug, PartialEq)]
pub struct StaticTrajectory {
    /// Where the vehicle stands.
    pub site: Site,
    /// Its heading, clockwise from north \[rad\].
    pub heading: f64,
    /// How long \[s\].
    pub duration_s: f64,
}

impl Trajectory for StaticTrajectory {
    fn duration_s(&self) -> f64 {
        self.duration_s
    }

    fn point(&self, t: f64) -> TrajectoryPoint {
        TrajectoryPoint {
            t: t.clamp(0.0, self.duration_s),
            latitude: self.site.latitude,
            longitude: self.site.longitude,
            height: self.site.height,
            heading: self.heading,
            bank: 0.0,
            velocity_enu: Vector3::zeros(),
            accel_enu: Vector3::zeros(),
            c_body_to_enu: c_body_to_enu(self.heading, 0.0),
            rate_body_wrt_enu: Vector3::zeros(),
        }
    }
}

/// What a part of the snake is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegmentKind {
    /// A straight leg.
    Leg,
    /// A 180-degree coordinated turn.
    Turn(TurnDirection),
}

/// One leg or turn of the snake.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Leg or turn.
    pub kind: SegmentKind,
    /// Start time \[s\].
    pub t_start: f64,
    /// End time \[s\] (the last segment is cut at the end of the flight).
    pub t_end: f64,
    /// Heading at the start of the segment \[rad\].
    pub heading_start: f64,
}

/// Heading, its rate, bank and its rate at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Attitude {
    heading: f64,
    heading_rate: f64,
    bank: f64,
    bank_rate: f64,
}

/// The snake flight of a [`SnakeConfig`]: legs and turns, with the position integrated on the
/// WGS-84 ellipsoid.
///
/// A turn is flown as roll-in (bank ramps linearly from 0 to the full bank in `roll_time_s`),
/// constant bank, roll-out (bank ramps back to 0). The heading rate is that of a coordinated
/// level turn at every instant, `psi_dot = (g0/v) tan(bank)` with `g0` the normal gravity at the
/// start point and altitude; the constant-bank time is chosen so that each turn is exactly 180
/// degrees. The position (latitude, longitude) is integrated from the velocity with RK4 at 0.1 s
/// knots; between knots one RK4 step from the previous knot gives a smooth position.
#[derive(Clone, Debug)]
pub struct SnakeTrajectory {
    config: SnakeConfig,
    speed: f64,
    height: f64,
    /// `g0 / v` [1/s]: heading rate per unit tan(bank).
    k: f64,
    bank_max: f64,
    roll_time: f64,
    hold_time: f64,
    roll_heading: f64,
    segments: Vec<Segment>,
    /// Knot spacing of the stored position \[s\].
    knot_dt: f64,
    /// Latitude and longitude at the knots \[rad\].
    knots: Vec<(f64, f64)>,
}

impl SnakeTrajectory {
    /// Build the trajectory of a (validated) configuration.
    pub fn new(config: &SnakeConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let duration = config.duration_s;
        let leg_time = config.leg_time_s();
        let turn_time = config.turn_time_s();
        let mut segments = Vec::new();
        let mut t = 0.0;
        let mut heading = config.start_heading_deg.to_radians();
        let mut dir = config.first_turn;
        while t < duration {
            if leg_time > 0.0 {
                let t_end = (t + leg_time).min(duration);
                segments.push(Segment {
                    kind: SegmentKind::Leg,
                    t_start: t,
                    t_end,
                    heading_start: heading,
                });
                t = t_end;
                if t >= duration {
                    break;
                }
            }
            let t_end = (t + turn_time).min(duration);
            segments.push(Segment {
                kind: SegmentKind::Turn(dir),
                t_start: t,
                t_end,
                heading_start: heading,
            });
            t += turn_time;
            heading += dir.sign() * std::f64::consts::PI;
            dir = dir.opposite();
        }
        let mut traj = SnakeTrajectory {
            config: config.clone(),
            speed: config.speed_m_s,
            height: config.altitude_m,
            k: config.design_gravity() / config.speed_m_s,
            bank_max: config.bank_angle_rad(),
            roll_time: config.roll_time_s,
            hold_time: config.hold_time_s(),
            roll_heading: config.roll_heading_change_rad(),
            segments,
            knot_dt: 0.1,
            knots: Vec::new(),
        };
        let n = (duration / traj.knot_dt).ceil() as usize + 1;
        let mut pos = (
            config.start_latitude_deg.to_radians(),
            config.start_longitude_deg.to_radians(),
        );
        traj.knots.reserve(n);
        traj.knots.push(pos);
        for i in 1..n {
            pos = traj.rk4(pos, (i - 1) as f64 * traj.knot_dt, traj.knot_dt);
            traj.knots.push(pos);
        }
        Ok(traj)
    }

    /// The configuration the trajectory was built from.
    pub fn config(&self) -> &SnakeConfig {
        &self.config
    }

    /// The legs and turns, in time order, covering `[0, duration]`.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Full bank angle of the turns \[rad\].
    pub fn bank_angle(&self) -> f64 {
        self.bank_max
    }

    fn segment_at(&self, t: f64) -> &Segment {
        let i = self.segments.partition_point(|s| s.t_end <= t);
        &self.segments[i.min(self.segments.len() - 1)]
    }

    fn attitude(&self, t: f64) -> Attitude {
        let seg = self.segment_at(t);
        let dir = match seg.kind {
            SegmentKind::Leg => {
                return Attitude {
                    heading: seg.heading_start,
                    heading_rate: 0.0,
                    bank: 0.0,
                    bank_rate: 0.0,
                };
            }
            SegmentKind::Turn(d) => d.sign(),
        };
        let (bm, tr, th, k) = (self.bank_max, self.roll_time, self.hold_time, self.k);
        let tau = (t - seg.t_start).max(0.0);
        let (dpsi, bank, bank_rate) = if tau < tr {
            // Roll-in: bank = bm tau / tr; heading = k (tr/bm) (-ln cos bank).
            let b = bm * tau / tr;
            (k * tr / bm * (-b.cos().ln()), b, bm / tr)
        } else if tau < tr + th {
            (self.roll_heading + k * bm.tan() * (tau - tr), bm, 0.0)
        } else {
            let tau2 = (tau - tr - th).min(tr);
            let b = if tr > 0.0 {
                bm * (1.0 - tau2 / tr)
            } else {
                0.0
            };
            let roll_out = if tr > 0.0 {
                k * tr / bm * (b.cos() / bm.cos()).ln()
            } else {
                0.0
            };
            let rate = if tr > 0.0 && tau2 < tr { -bm / tr } else { 0.0 };
            (self.roll_heading + k * bm.tan() * th + roll_out, b, rate)
        };
        let bank = dir * bank;
        Attitude {
            heading: seg.heading_start + dir * dpsi,
            heading_rate: k * bank.tan(),
            bank,
            bank_rate: dir * bank_rate,
        }
    }

    /// (lat, lon) rates (rad/s) at position `pos` flying at heading `psi`.
    fn position_rate(&self, pos: (f64, f64), psi: f64) -> (f64, f64) {
        let (ve, vn) = (self.speed * psi.sin(), self.speed * psi.cos());
        let lat = pos.0;
        (
            vn / (meridian_radius(lat) + self.height),
            ve / ((prime_vertical_radius(lat) + self.height) * lat.cos()),
        )
    }

    fn rk4(&self, p: (f64, f64), t: f64, h: f64) -> (f64, f64) {
        let add = |p: (f64, f64), k: (f64, f64), s: f64| (p.0 + s * k.0, p.1 + s * k.1);
        // The heading at the step's start, middle (twice) and end.
        let psi = [t, t + h / 2.0, t + h].map(|x| self.attitude(x).heading);
        let k1 = self.position_rate(p, psi[0]);
        let k2 = self.position_rate(add(p, k1, h / 2.0), psi[1]);
        let k3 = self.position_rate(add(p, k2, h / 2.0), psi[1]);
        let k4 = self.position_rate(add(p, k3, h), psi[2]);
        (
            p.0 + h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0),
            p.1 + h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1),
        )
    }
}

impl Trajectory for SnakeTrajectory {
    fn duration_s(&self) -> f64 {
        self.config.duration_s
    }

    fn breakpoints(&self) -> Vec<f64> {
        let mut b = Vec::new();
        for s in &self.segments {
            b.push(s.t_start);
            if let SegmentKind::Turn(_) = s.kind {
                b.push(s.t_start + self.roll_time);
                b.push(s.t_start + self.roll_time + self.hold_time);
            }
        }
        let end = self.config.duration_s;
        b.retain(|&t| t > 0.0 && t < end);
        b.sort_by(f64::total_cmp);
        b.dedup();
        b
    }

    fn point(&self, t: f64) -> TrajectoryPoint {
        let t = t.clamp(0.0, self.config.duration_s);
        let i = ((t / self.knot_dt).floor() as usize).min(self.knots.len() - 1);
        let ti = i as f64 * self.knot_dt;
        let (latitude, longitude) = if t > ti {
            self.rk4(self.knots[i], ti, t - ti)
        } else {
            self.knots[i]
        };
        let a = self.attitude(t);
        let v = self.speed;
        let (s, c) = a.heading.sin_cos();
        let (sb, cb) = a.bank.sin_cos();
        TrajectoryPoint {
            t,
            latitude,
            longitude,
            height: self.height,
            heading: a.heading,
            bank: a.bank,
            velocity_enu: Vector3::new(v * s, v * c, 0.0),
            accel_enu: Vector3::new(v * a.heading_rate * c, -v * a.heading_rate * s, 0.0),
            c_body_to_enu: c_body_to_enu(a.heading, a.bank),
            // d/dt [rot_z(-psi) rot_y(gamma)] = C skew(-psi_dot rot_y(gamma)^T e3 + gamma_dot e2).
            rate_body_wrt_enu: Vector3::new(a.heading_rate * sb, a.bank_rate, -a.heading_rate * cb),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sins_model::attitude::{log_so3, rot_z as rz};
    use sins_model::earth::{EARTH_RATE, WGS84_E2};
    use std::f64::consts::PI;

    fn snake() -> SnakeTrajectory {
        SnakeTrajectory::new(&SnakeConfig::default_config()).unwrap()
    }

    #[test]
    fn legs_turns_and_duration_are_as_configured() {
        let cfg = SnakeConfig::default_config();
        let tr = snake();
        let segs = tr.segments();
        assert_eq!(segs.first().unwrap().t_start, 0.0);
        assert_eq!(segs.last().unwrap().t_end, cfg.duration_s);
        let mut dir = cfg.first_turn;
        for (i, s) in segs.iter().enumerate() {
            if i > 0 {
                assert_eq!(s.t_start, segs[i - 1].t_end);
            }
            let full = s.t_end < cfg.duration_s;
            match s.kind {
                SegmentKind::Leg => {
                    assert_eq!(i % 2, 0);
                    if full {
                        // Leg length from the integrated distance (speed constant).
                        assert!(
                            ((s.t_end - s.t_start) * cfg.speed_m_s - cfg.leg_length_m).abs() < 1e-6
                        );
                    }
                    // Legs are parallel: heading = start heading + k pi.
                    let d = (s.heading_start - cfg.start_heading_deg.to_radians()) / PI;
                    assert!((d - d.round()).abs() < 1e-12);
                }
                SegmentKind::Turn(d) => {
                    assert_eq!(i % 2, 1);
                    assert_eq!(d, dir);
                    dir = dir.opposite();
                    if full {
                        // 180 degrees in the sense of the turn, ending level.
                        let end = tr.point(s.t_end);
                        let start = tr.point(s.t_start);
                        assert!((end.heading - start.heading - d.sign() * PI).abs() < 1e-9);
                        assert!(end.bank.abs() < 1e-12 && start.bank.abs() < 1e-12);
                        let mid = tr.point(0.5 * (s.t_start + s.t_end));
                        assert!((mid.bank - d.sign() * cfg.bank_angle_rad()).abs() < 1e-12);
                        assert!(
                            (mid.heading_rate_check(cfg.speed_m_s)
                                - d.sign() * cfg.turn_rate_rad_s())
                            .abs()
                                < 1e-9
                        );
                    }
                }
            }
        }
        // With the default, a leg + turn cycle takes 400 s + 109.9 s: seven of them and the
        // start of an eighth leg fill the hour.
        assert!(
            (cfg.turn_time_s() - 109.9).abs() < 0.05,
            "{}",
            cfg.turn_time_s()
        );
        let legs = segs.iter().filter(|s| s.kind == SegmentKind::Leg).count();
        let turns = segs.len() - legs;
        assert_eq!((legs, turns), (8, 7));
        // After a right and a left turn the track is displaced sideways by about 4 turn radii
        // (the roll-in/out adds a little): a snake, not a racetrack.
        let p0 = tr.point(0.0);
        let t2 = segs[4].t_start;
        let p2 = tr.point(t2);
        let east = (p2.longitude - p0.longitude) * p0.radius_east() * p0.latitude.cos();
        assert!(east > 4.0 * 5000.0 && east < 4.0 * 5000.0 * 1.02, "{east}");
        // ... and back at about the start latitude at the start of every odd leg.
        assert!((p2.latitude - p0.latitude).abs() * p0.radius_north() < 100.0);
    }

    impl TrajectoryPoint {
        fn heading_rate_check(&self, v: f64) -> f64 {
            // Heading rate from the ENU acceleration: a = v psi_dot (cos psi, -sin psi).
            (self.accel_enu.x * self.heading.cos() - self.accel_enu.y * self.heading.sin()) / v
        }
    }

    /// Times away from phase boundaries: on a leg, in roll-in, in the hold, in roll-out.
    fn probe_times(tr: &SnakeTrajectory) -> Vec<f64> {
        let s = tr.segments();
        let turn = s[1];
        let cfg = tr.config();
        [
            200.0,
            turn.t_start + 0.4 * cfg.roll_time_s,
            turn.t_start + cfg.roll_time_s + 30.0,
            turn.t_end - 0.3 * cfg.roll_time_s,
            s[3].t_start + cfg.roll_time_s + 50.0,
        ]
        .to_vec()
    }

    #[test]
    fn numerical_derivative_of_attitude_gives_the_body_rate_wrt_enu() {
        let tr = snake();
        for t in probe_times(&tr) {
            let h = 1e-3;
            let c0 = tr.point(t).c_body_to_enu;
            let c1 = tr.point(t + h).c_body_to_enu;
            let cm = tr.point(t - h).c_body_to_enu;
            let num = log_so3(&(cm.transpose() * c1)) / (2.0 * h);
            let p = tr.point(t);
            assert!(
                (num - p.rate_body_wrt_enu).norm() < 1e-8,
                "t={t}: {num} vs {}",
                p.rate_body_wrt_enu
            );
            assert!((c0 - p.c_body_to_enu).norm() == 0.0);
        }
    }

    /// ENU-to-ECEF DCM and ECEF position of a geodetic point.
    fn ecef(lat: f64, lon: f64, h: f64) -> (Matrix3<f64>, Vector3<f64>) {
        let (sp, cp) = lat.sin_cos();
        let (sl, cl) = lon.sin_cos();
        let c = Matrix3::new(-sl, -sp * cl, cp * cl, cl, -sp * sl, cp * sl, 0.0, cp, sp);
        let rn = prime_vertical_radius(lat);
        let r = Vector3::new(
            (rn + h) * cp * cl,
            (rn + h) * cp * sl,
            (rn * (1.0 - WGS84_E2) + h) * sp,
        );
        (c, r)
    }

    #[test]
    fn inertial_body_rate_and_specific_force_match_numerical_derivatives() {
        // Independent check through ECEF and inertial space: the body-to-inertial DCM
        // rot_z(Omega t) * C_enu_to_ecef * C_body_to_enu, differentiated numerically, gives the
        // gyro rate; the inertial position, differentiated twice, minus gravitation gives the
        // specific force.
        let tr = snake();
        let w = EARTH_RATE;
        let inertial = |t: f64| {
            let p = tr.point(t);
            let (c_enu_ecef, r) = ecef(p.latitude, p.longitude, p.height);
            (rz(w * t) * c_enu_ecef * p.c_body_to_enu, rz(w * t) * r)
        };
        for t in probe_times(&tr) {
            let p = tr.point(t);
            // Body rate.
            let h = 1e-3;
            let (c1, _) = inertial(t + h);
            let (cm, _) = inertial(t - h);
            let num = log_so3(&(cm.transpose() * c1)) / (2.0 * h);
            let gyro = p.body_rate(w);
            assert!((num - gyro).norm() < 1e-9, "t={t}: {num} vs {gyro}");
            // Specific force: five-point second difference (truncation O(h^4), rounding of the
            // ECEF coordinates ~1e-9 m / h^2).
            let h = 0.1;
            let r = |k: f64| inertial(t + k * h).1;
            let acc_i = (-r(2.0) + 16.0 * r(1.0) - 30.0 * r(0.0) + 16.0 * r(-1.0) - r(-2.0))
                / (12.0 * h * h);
            let (c_enu_ecef, r_e) = ecef(p.latitude, p.longitude, p.height);
            let c_enu_i = rz(w * t) * c_enu_ecef;
            let omega = Vector3::new(0.0, 0.0, w);
            // gravitation = plumb gravity + centripetal part of the Earth rotation.
            let gravitation_i =
                rz(w * t) * (c_enu_ecef * p.gravity_enu() + omega.cross(&omega.cross(&r_e)));
            let f_num = c_enu_i.transpose() * (acc_i - gravitation_i);
            let f = p.specific_force_enu(w);
            assert!(
                (f_num - f).norm() < 2e-6,
                "t={t}: {f_num} vs {f} ({})",
                (f_num - f).norm()
            );
        }
    }

    #[test]
    fn turns_are_coordinated() {
        // In a coordinated turn the specific force has (almost) no right-wing component: only
        // the Coriolis and transport terms, not included in the bank, leave a few mm/s^2.
        let tr = snake();
        for t in probe_times(&tr) {
            let p = tr.point(t);
            let f = p.specific_force_body(EARTH_RATE);
            assert!(f.x.abs() < 0.03, "t={t}: {f}");
            // Without Earth rotation and transport it is exact up to the gravity difference.
            let fe = p.accel_enu - p.gravity_enu();
            let fb = p.c_body_to_enu.transpose() * fe;
            assert!(fb.x.abs() < 1e-3 * fb.norm(), "t={t}: {fb}");
        }
        // In the hold the load factor is 1/cos(bank).
        let s = tr.segments()[1];
        let p = tr.point(0.5 * (s.t_start + s.t_end));
        let f = p.specific_force_body(0.0);
        // (flying over the curved Earth lowers it by v^2/R = 3.5e-4 g).
        assert!(
            (f.z * tr.bank_angle().cos() / tr.config().design_gravity() - 1.0).abs() < 1e-3,
            "{f}"
        );
    }
}
