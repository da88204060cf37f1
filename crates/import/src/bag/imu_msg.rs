//! `sensor_msgs/Imu` decoded from its two wire forms: ROS 1 serialization (little-endian, no
//! alignment, a `seq` in the header, strings as a `u32` length and bytes) by the small reader
//! here, there being no maintained crate for it; ROS 2 CDR (the 4-byte encapsulation header,
//! then aligned fields) by the `cdr` crate.

use serde::Deserialize;

/// One `sensor_msgs/Imu` message (ROS 1 or ROS 2: the same fields but ROS 1's header `seq`).
#[derive(Clone, Debug, PartialEq)]
pub struct ImuMessage {
    /// Header stamp: whole seconds (ROS 1: unsigned 32-bit, ROS 2: signed 32-bit).
    pub stamp_sec: i64,
    /// Header stamp: nanoseconds within the second (0 .. 999 999 999 in a valid stamp).
    pub stamp_nanosec: u32,
    /// Header `frame_id`.
    pub frame_id: String,
    /// Orientation quaternion x, y, z, w.
    pub orientation: [f64; 4],
    /// Row-major 3x3 covariance of the orientation (`-1` first: no orientation estimate).
    pub orientation_covariance: [f64; 9],
    /// Angular velocity x, y, z (rad/s).
    pub angular_velocity: [f64; 3],
    /// Row-major 3x3 covariance of the angular velocity ((rad/s)^2; zeros: unknown).
    pub angular_velocity_covariance: [f64; 9],
    /// Linear acceleration (specific force) x, y, z (m/s^2).
    pub linear_acceleration: [f64; 3],
    /// Row-major 3x3 covariance of the linear acceleration ((m/s^2)^2; zeros: unknown).
    pub linear_acceleration_covariance: [f64; 9],
}

/// Bytes read in order, each read checked against the end.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(format!(
                "the message ends at byte {} within its {what} (which needs {n} bytes from byte \
                 {}): expected a whole sensor_msgs/Imu",
                self.bytes.len(),
                self.at
            ));
        };
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32, String> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn f64s<const N: usize>(&mut self, what: &str) -> Result<[f64; N], String> {
        let b = self.take(8 * N, what)?;
        let mut out = [0.0; N];
        for (k, v) in out.iter_mut().enumerate() {
            let mut w = [0u8; 8];
            w.copy_from_slice(&b[8 * k..8 * k + 8]);
            *v = f64::from_le_bytes(w);
        }
        Ok(out)
    }
}

/// Decode a ROS 1 `sensor_msgs/Imu`: header (`seq` u32, stamp `secs`, `nsecs` u32, `frame_id`
/// string), then 37 float64 (orientation 4, its covariance 9, angular velocity 3, its covariance
/// 9, linear acceleration 3, its covariance 9). Bytes left over are refused: they mean another
/// message definition under the same name.
pub fn decode_ros1(bytes: &[u8]) -> Result<ImuMessage, String> {
    let mut r = Reader { bytes, at: 0 };
    let _seq = r.u32("header.seq")?;
    let sec = r.u32("header.stamp.secs")?;
    let nanosec = r.u32("header.stamp.nsecs")?;
    let len = r.u32("header.frame_id length")? as usize;
    let frame_id = std::str::from_utf8(r.take(len, "header.frame_id")?)
        .map_err(|_| "header.frame_id is not UTF-8 text".to_string())?
        .to_string();
    let m = ImuMessage {
        stamp_sec: i64::from(sec),
        stamp_nanosec: nanosec,
        frame_id,
        orientation: r.f64s("orientation")?,
        orientation_covariance: r.f64s("orientation_covariance")?,
        angular_velocity: r.f64s("angular_velocity")?,
        angular_velocity_covariance: r.f64s("angular_velocity_covariance")?,
        linear_acceleration: r.f64s("linear_acceleration")?,
        linear_acceleration_covariance: r.f64s("linear_acceleration_covariance")?,
    };
    if r.at != bytes.len() {
        return Err(format!(
            "{} bytes, of which a sensor_msgs/Imu uses {}: expected the message to end there",
            bytes.len(),
            r.at
        ));
    }
    Ok(m)
}

/// The ROS 2 message as CDR lays it out (`builtin_interfaces/Time`, `std_msgs/Header`;
/// `geometry_msgs/Quaternion` and `Vector3` are plain float64 fields, laid out as arrays).
/// Tests serialize it to make messages.
#[derive(Deserialize)]
#[cfg_attr(test, derive(serde::Serialize))]
pub(super) struct Ros2Imu {
    pub(super) header: Ros2Header,
    pub(super) orientation: [f64; 4],
    pub(super) orientation_covariance: [f64; 9],
    pub(super) angular_velocity: [f64; 3],
    pub(super) angular_velocity_covariance: [f64; 9],
    pub(super) linear_acceleration: [f64; 3],
    pub(super) linear_acceleration_covariance: [f64; 9],
}

#[derive(Deserialize)]
#[cfg_attr(test, derive(serde::Serialize))]
pub(super) struct Ros2Header {
    pub(super) stamp: Ros2Time,
    pub(super) frame_id: String,
}

#[derive(Deserialize)]
#[cfg_attr(test, derive(serde::Serialize))]
pub(super) struct Ros2Time {
    pub(super) sec: i32,
    pub(super) nanosec: u32,
}

/// Decode a ROS 2 `sensor_msgs/msg/Imu` in CDR (either byte order, as its encapsulation
/// header says).
pub fn decode_cdr(bytes: &[u8]) -> Result<ImuMessage, String> {
    let m: Ros2Imu =
        cdr::deserialize(bytes).map_err(|e| format!("not a CDR sensor_msgs/msg/Imu ({e})"))?;
    // The CDR size of the message with this frame_id (4 bytes of encapsulation header; in the
    // body the stamp, the string's length, its bytes with a NUL, padding to 8, 37 float64):
    // more bytes than that, beyond padding to 8, are another message definition under the
    // same name.
    let body = (4 + 4 + 4 + m.header.frame_id.len() + 1).next_multiple_of(8) + 8 * 37;
    let used = 4 + body;
    if bytes.len() > used.next_multiple_of(8) {
        return Err(format!(
            "{} bytes, of which a sensor_msgs/msg/Imu uses {used}: expected the message to end \
             there",
            bytes.len()
        ));
    }
    Ok(ImuMessage {
        stamp_sec: i64::from(m.header.stamp.sec),
        stamp_nanosec: m.header.stamp.nanosec,
        frame_id: m.header.frame_id,
        orientation: m.orientation,
        orientation_covariance: m.orientation_covariance,
        angular_velocity: m.angular_velocity,
        angular_velocity_covariance: m.angular_velocity_covariance,
        linear_acceleration: m.linear_acceleration,
        linear_acceleration_covariance: m.linear_acceleration_covariance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ROS 1 message laid out by hand: header, then the 37 float64 numbered 0..37.
    fn ros1_bytes(frame_id: &str) -> Vec<u8> {
        let mut b = Vec::new();
        for v in [7u32, 12, 500] {
            b.extend(v.to_le_bytes());
        }
        b.extend((frame_id.len() as u32).to_le_bytes());
        b.extend(frame_id.as_bytes());
        for k in 0..37 {
            b.extend(f64::from(k).to_le_bytes());
        }
        b
    }

    #[test]
    fn ros1_fields_in_order_and_exact_length() {
        let m = decode_ros1(&ros1_bytes("imu")).expect("decodes");
        assert_eq!(
            (m.stamp_sec, m.stamp_nanosec, m.frame_id.as_str()),
            (12, 500, "imu")
        );
        assert_eq!(m.orientation, [0.0, 1.0, 2.0, 3.0]);
        assert_eq!(m.orientation_covariance[8], 12.0);
        assert_eq!(m.angular_velocity, [13.0, 14.0, 15.0]);
        assert_eq!(m.angular_velocity_covariance[0], 16.0);
        assert_eq!(m.linear_acceleration, [25.0, 26.0, 27.0]);
        assert_eq!(m.linear_acceleration_covariance[8], 36.0);
        let mut long = ros1_bytes("imu");
        long.push(0);
        assert!(
            decode_ros1(&long)
                .unwrap_err()
                .contains("expected the message to end")
        );
        let short = ros1_bytes("imu");
        let e = decode_ros1(&short[..short.len() - 1]).unwrap_err();
        assert!(e.contains("linear_acceleration_covariance"), "{e}");
    }

    #[test]
    fn cdr_either_byte_order_and_exact_length() {
        let mut k = 0.0;
        let mut next = || {
            k += 1.0;
            k - 1.0
        };
        let mut filled = |v: &mut [f64]| v.iter_mut().for_each(|x| *x = next());
        let mut msg = Ros2Imu {
            header: Ros2Header {
                stamp: Ros2Time {
                    sec: -3,
                    nanosec: 9,
                },
                frame_id: "imu_link".into(),
            },
            orientation: [0.0; 4],
            orientation_covariance: [0.0; 9],
            angular_velocity: [0.0; 3],
            angular_velocity_covariance: [0.0; 9],
            linear_acceleration: [0.0; 3],
            linear_acceleration_covariance: [0.0; 9],
        };
        filled(&mut msg.orientation);
        filled(&mut msg.orientation_covariance);
        filled(&mut msg.angular_velocity);
        filled(&mut msg.angular_velocity_covariance);
        filled(&mut msg.linear_acceleration);
        filled(&mut msg.linear_acceleration_covariance);
        // Serde lays the arrays out as fixed arrays, as the message's fields.
        for bytes in [
            cdr::serialize::<_, _, cdr::CdrLe>(&msg, cdr::Infinite).expect("ser"),
            cdr::serialize::<_, _, cdr::CdrBe>(&msg, cdr::Infinite).expect("ser"),
        ] {
            let m = decode_cdr(&bytes).expect("decodes");
            assert_eq!((m.stamp_sec, m.stamp_nanosec), (-3, 9));
            assert_eq!(m.frame_id, "imu_link");
            assert_eq!(m.angular_velocity, [13.0, 14.0, 15.0]);
            assert_eq!(m.linear_acceleration, [25.0, 26.0, 27.0]);
            let mut long = bytes.clone();
            long.extend([0u8; 8]);
            assert!(decode_cdr(&long).is_err());
            assert!(decode_cdr(&bytes[..bytes.len() - 8]).is_err());
        }
    }

    #[test]
    fn stamps_to_seconds() {
        use super::super::stamp_seconds;
        assert_eq!(stamp_seconds(101, 318_359_375), 101.318359375);
        assert_eq!(stamp_seconds(0, 100_000_000), 0.1);
        assert_eq!(stamp_seconds(-1, 500_000_000), -0.5);
        let epoch = stamp_seconds(1_700_000_000, 123_456_789);
        assert!(
            (epoch - (1_700_000_000.0 + 0.123_456_789)).abs() <= 2.4e-7,
            "{epoch}"
        );
    }
}
