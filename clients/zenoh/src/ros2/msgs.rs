//! The ROS 2 messages the bridge speaks, as serde structs in field order, written and read as
//! CDR little-endian with the 4-byte encapsulation header (what rmw_zenoh puts on the wire), and
//! each type's DDS name and RIHS01 hash for one pinned distribution (Jazzy).
//!
//! The hashes are REP 2011's RIHS01 (SHA-256 of the type description); they are constants of the
//! distribution, checked against `rosbags`' `typestore.hash_rihs01` (`Stores.ROS2_JAZZY`) by the
//! bridge's tests.

use serde::{Deserialize, Serialize, Serializer};

/// A message type: its ROS name, its DDS name (the key expression's type chunk) and its hash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RosType {
    /// `pkg/msg/Name`.
    pub name: &'static str,
    /// `pkg::msg::dds_::Name_`.
    pub dds_name: &'static str,
    /// `RIHS01_<64 hex>` for ROS 2 Jazzy.
    pub hash: &'static str,
}

/// `sensor_msgs/msg/PointCloud2`.
pub const POINT_CLOUD2: RosType = RosType {
    name: "sensor_msgs/msg/PointCloud2",
    dds_name: "sensor_msgs::msg::dds_::PointCloud2_",
    hash: "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5",
};
/// `tf2_msgs/msg/TFMessage`.
pub const TF_MESSAGE: RosType = RosType {
    name: "tf2_msgs/msg/TFMessage",
    dds_name: "tf2_msgs::msg::dds_::TFMessage_",
    hash: "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
};
/// `geometry_msgs/msg/WrenchStamped`.
pub const WRENCH_STAMPED: RosType = RosType {
    name: "geometry_msgs/msg/WrenchStamped",
    dds_name: "geometry_msgs::msg::dds_::WrenchStamped_",
    hash: "RIHS01_8dc3deaf06b2ab281f9f9a742a8961c328ca7cec16e3fd6586d3a5c83fa78f77",
};
/// `geometry_msgs/msg/PoseStamped`.
pub const POSE_STAMPED: RosType = RosType {
    name: "geometry_msgs/msg/PoseStamped",
    dds_name: "geometry_msgs::msg::dds_::PoseStamped_",
    hash: "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
};
/// `geometry_msgs/msg/TwistStamped`.
pub const TWIST_STAMPED: RosType = RosType {
    name: "geometry_msgs/msg/TwistStamped",
    dds_name: "geometry_msgs::msg::dds_::TwistStamped_",
    hash: "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
};

/// Every type the bridge speaks.
pub const ALL: [RosType; 5] = [
    POINT_CLOUD2,
    TF_MESSAGE,
    WRENCH_STAMPED,
    POSE_STAMPED,
    TWIST_STAMPED,
];

/// `builtin_interfaces/Time`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds since the Unix epoch.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// The time `unix_ns` nanoseconds after the Unix epoch.
    pub fn from_unix_ns(unix_ns: u64) -> Self {
        Self {
            sec: (unix_ns / 1_000_000_000).min(i32::MAX as u64) as i32,
            nanosec: (unix_ns % 1_000_000_000) as u32,
        }
    }
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Time of the data.
    pub stamp: Time,
    /// Frame the data are in.
    pub frame_id: String,
}

/// `sensor_msgs/PointField`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointField {
    /// Field name (`x`, `rgb`, ...).
    pub name: String,
    /// Byte offset in a point.
    pub offset: u32,
    /// `FLOAT32` = 7.
    pub datatype: u8,
    /// Elements in the field.
    pub count: u32,
}

/// `PointField.FLOAT32`.
pub const FLOAT32: u8 = 7;

/// A `uint8[]` written as one run of bytes (serde would write it element by element).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Bytes(pub Vec<u8>);

impl Serialize for Bytes {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(&self.0)
    }
}

/// `sensor_msgs/PointCloud2`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PointCloud2 {
    /// Stamp and frame.
    pub header: Header,
    /// Rows (1: unordered).
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// The fields of a point.
    pub fields: Vec<PointField>,
    /// Byte order of `data` (false: little-endian).
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// `height * row_step` bytes.
    pub data: Bytes,
    /// No invalid points.
    pub is_dense: bool,
}

/// `geometry_msgs/Vector3`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl From<[f32; 3]> for Vector3 {
    fn from(v: [f32; 3]) -> Self {
        Self {
            x: f64::from(v[0]),
            y: f64::from(v[1]),
            z: f64::from(v[2]),
        }
    }
}

impl From<Vector3> for [f64; 3] {
    fn from(v: Vector3) -> Self {
        [v.x, v.y, v.z]
    }
}

/// `geometry_msgs/Quaternion` (x, y, z, w order on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Quaternion {
    /// From splatphys' (w, x, y, z).
    pub fn from_wxyz(q: [f32; 4]) -> Self {
        Self {
            x: f64::from(q[1]),
            y: f64::from(q[2]),
            z: f64::from(q[3]),
            w: f64::from(q[0]),
        }
    }

    /// To splatphys' (w, x, y, z).
    pub fn to_wxyz(self) -> [f64; 4] {
        [self.w, self.x, self.y, self.z]
    }
}

/// `geometry_msgs/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Transform {
    /// Translation, m.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent frame.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `geometry_msgs/Wrench`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Wrench {
    /// Force, N.
    pub force: Vector3,
    /// Torque, N·m.
    pub torque: Vector3,
}

/// `geometry_msgs/WrenchStamped`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WrenchStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The wrench.
    pub wrench: Wrench,
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position, m.
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// `geometry_msgs/Twist`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity, m/s.
    pub linear: Vector3,
    /// Angular velocity, rad/s.
    pub angular: Vector3,
}

/// `geometry_msgs/TwistStamped`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The twist.
    pub twist: Twist,
}

/// The CDR bytes of `msg`: encapsulation header `00 01 00 00` (little-endian) and the body.
///
/// # Errors
/// Never for these types in practice; cdr's error is passed on.
pub fn to_cdr<T: Serialize>(msg: &T) -> Result<Vec<u8>, cdr::Error> {
    cdr::serialize::<_, _, cdr::CdrLe>(msg, cdr::Infinite)
}

/// A message from its CDR bytes (either byte order, as the encapsulation header says).
///
/// # Errors
/// Bytes too short or not of this type.
pub fn from_cdr<'de, T: Deserialize<'de>>(bytes: &'de [u8]) -> Result<T, cdr::Error> {
    cdr::deserialize(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hex(s: &str) -> Vec<u8> {
        s.split_whitespace()
            .map(|b| u8::from_str_radix(b, 16).unwrap())
            .collect()
    }

    fn header() -> Header {
        Header {
            stamp: Time { sec: 1, nanosec: 2 },
            frame_id: "map".into(),
        }
    }

    fn field(name: &str, offset: u32) -> PointField {
        PointField {
            name: name.into(),
            offset,
            datatype: FLOAT32,
            count: 1,
        }
    }

    // Reference bytes from rosbags 0.11.9 (`get_typestore(Stores.ROS2_JAZZY).serialize_cdr`).

    #[test]
    fn a_point_cloud_matches_rosbags_bytes() {
        let mut data = Vec::new();
        for v in [1.0f32, 2.0, 3.0] {
            data.extend_from_slice(&v.to_le_bytes());
        }
        let msg = PointCloud2 {
            header: header(),
            height: 1,
            width: 1,
            fields: vec![field("x", 0), field("y", 4), field("z", 8)],
            is_bigendian: false,
            point_step: 12,
            row_step: 12,
            data: Bytes(data),
            is_dense: true,
        };
        let want = hex(
            "00 01 00 00 01 00 00 00 02 00 00 00 04 00 00 00 6d 61 70 00 01 00 00 00 01 00 00 00 \
             03 00 00 00 02 00 00 00 78 00 00 00 00 00 00 00 07 00 00 00 01 00 00 00 02 00 00 00 \
             79 00 00 00 04 00 00 00 07 00 00 00 01 00 00 00 02 00 00 00 7a 00 00 00 08 00 00 00 \
             07 00 00 00 01 00 00 00 00 00 00 00 0c 00 00 00 0c 00 00 00 0c 00 00 00 00 00 80 3f \
             00 00 00 40 00 00 40 40 01",
        );
        assert_eq!(to_cdr(&msg).unwrap(), want);
    }

    #[test]
    fn a_tf_message_matches_rosbags_bytes() {
        let msg = TfMessage {
            transforms: vec![TransformStamped {
                header: Header {
                    stamp: Time { sec: 1, nanosec: 2 },
                    frame_id: "world".into(),
                },
                child_frame_id: "base_link".into(),
                transform: Transform {
                    translation: Vector3 {
                        x: 1.0,
                        y: 2.0,
                        z: 3.0,
                    },
                    rotation: Quaternion::from_wxyz([1.0, 0.0, 0.0, 0.0]),
                },
            }],
        };
        let want = hex(
            "00 01 00 00 01 00 00 00 01 00 00 00 02 00 00 00 06 00 00 00 77 6f 72 6c 64 00 00 00 \
             0a 00 00 00 62 61 73 65 5f 6c 69 6e 6b 00 00 00 00 00 00 00 00 00 f0 3f 00 00 00 00 \
             00 00 00 40 00 00 00 00 00 00 08 40 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 \
             00 00 00 00 00 00 00 00 00 00 00 00 00 00 f0 3f",
        );
        assert_eq!(to_cdr(&msg).unwrap(), want);
    }

    #[test]
    fn a_wrench_matches_rosbags_bytes_and_a_twist_reads_back() {
        let msg = WrenchStamped {
            header: header(),
            wrench: Wrench {
                force: [1.0, 2.0, 3.0].into(),
                torque: [4.0, 5.0, 6.0].into(),
            },
        };
        let want = hex(
            "00 01 00 00 01 00 00 00 02 00 00 00 04 00 00 00 6d 61 70 00 00 00 00 00 00 00 f0 3f \
             00 00 00 00 00 00 00 40 00 00 00 00 00 00 08 40 00 00 00 00 00 00 10 40 00 00 00 00 \
             00 00 14 40 00 00 00 00 00 00 18 40",
        );
        assert_eq!(to_cdr(&msg).unwrap(), want);
        // TwistStamped has the same layout: rosbags' bytes read as a twist.
        let twist: TwistStamped = from_cdr(&want).unwrap();
        assert_eq!(twist.header, header());
        assert_eq!(<[f64; 3]>::from(twist.twist.linear), [1.0, 2.0, 3.0]);
        assert_eq!(<[f64; 3]>::from(twist.twist.angular), [4.0, 5.0, 6.0]);
    }

    #[test]
    fn a_pose_reads_from_rosbags_bytes() {
        let bytes = hex(
            "00 01 00 00 01 00 00 00 02 00 00 00 04 00 00 00 6d 61 70 00 00 00 00 00 00 00 f0 3f \
             00 00 00 00 00 00 00 40 00 00 00 00 00 00 08 40 00 00 00 00 00 00 00 00 00 00 00 00 \
             00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 f0 3f",
        );
        let pose: PoseStamped = from_cdr(&bytes).unwrap();
        assert_eq!(<[f64; 3]>::from(pose.pose.position), [1.0, 2.0, 3.0]);
        assert_eq!(pose.pose.orientation.to_wxyz(), [1.0, 0.0, 0.0, 0.0]);
        assert!(from_cdr::<PoseStamped>(&bytes[..40]).is_err());
    }

    #[test]
    fn times_split_into_seconds_and_nanoseconds() {
        let t = Time::from_unix_ns(1_700_000_000_123_456_789);
        assert_eq!((t.sec, t.nanosec), (1_700_000_000, 123_456_789));
    }
}
