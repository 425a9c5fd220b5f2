//! rmw_zenoh's conventions (ROS 2 Jazzy, rmw_zenoh_cpp 0.2.4 and later): the key expression of a
//! topic's data, the liveliness tokens that put a node and its publishers and subscriptions in
//! the ROS graph, the QoS string inside them, and the attachment every sample carries. Read from
//! rmw_zenoh_cpp's `liveliness_utils.cpp`, `attachment_helpers.cpp` and `qos.cpp`.

use xxhash_rust::xxh3::xxh3_128;

use super::msgs::RosType;

/// Whether `name` is a valid ROS name token (`[A-Za-z_][A-Za-z0-9_]*`).
pub fn is_ros_token(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `name` as a ROS name token: characters outside `[A-Za-z0-9_]` become `_`, and a leading digit
/// (or nothing) gets an `o` in front (`"3d"` → `"o3d"`, `"#3 red cup"` → `"_3_red_cup"`).
pub fn ros_token(name: &str) -> String {
    let mut out: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !out.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
        out.insert(0, 'o');
    }
    out
}

/// A fully qualified name (`/a/b`) with every `/` written `%`, as in liveliness tokens.
pub fn mangle(name: &str) -> String {
    name.replace('/', "%")
}

/// The key expression of a topic's samples: `<domain>/<topic without the outer slashes>/<DDS
/// type>/<type hash>`, e.g. `0/splatphys/gaussians/sensor_msgs::msg::dds_::PointCloud2_/RIHS01_…`.
pub fn topic_key(domain: u32, topic: &str, ty: &RosType) -> String {
    format!(
        "{domain}/{}/{}/{}",
        topic.trim_matches('/'),
        ty.dds_name,
        ty.hash
    )
}

/// Quality of service, as far as the liveliness token states it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliable (else best effort).
    pub reliable: bool,
    /// Transient local (else volatile).
    pub transient_local: bool,
    /// Keep-last depth.
    pub depth: u32,
}

impl Qos {
    /// rclcpp's default: reliable, volatile, keep last 10.
    pub const DEFAULT: Qos = Qos {
        reliable: true,
        transient_local: false,
        depth: 10,
    };
    /// Sensor data: best effort, volatile, keep last 5.
    pub const SENSOR_DATA: Qos = Qos {
        reliable: false,
        transient_local: false,
        depth: 5,
    };
    /// What tf2's broadcaster uses: reliable, volatile, keep last 100.
    pub const TF: Qos = Qos {
        reliable: true,
        transient_local: false,
        depth: 100,
    };

    /// rmw_zenoh's string form `rel:dur:hist,depth:deadline:lifespan:liveliness`, each field
    /// left empty where it equals rmw_zenoh's default (reliable, volatile, keep last 42,
    /// infinite durations, automatic liveliness): `::,10:,:,:,,` for [`Qos::DEFAULT`].
    pub fn to_key(self) -> String {
        let reliability = if self.reliable { "" } else { "2" };
        let durability = if self.transient_local { "1" } else { "" };
        let depth = if self.depth == 42 {
            String::new()
        } else {
            self.depth.to_string()
        };
        format!("{reliability}:{durability}:,{depth}:,:,:,,")
    }
}

/// Kind of a graph entity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntityKind {
    /// A publisher (`MP`).
    Publisher,
    /// A subscription (`MS`).
    Subscription,
}

/// The node the bridge shows in the ROS graph, in one Zenoh session.
#[derive(Debug, Clone)]
pub struct Node {
    /// ROS domain id.
    pub domain: u32,
    /// The Zenoh session id as rmw_zenoh writes it (`ZenohId`'s `Display`).
    pub zid: String,
    /// Node id (also its entity id).
    pub id: u32,
    /// Node namespace (`/` for none).
    pub namespace: String,
    /// Node name.
    pub name: String,
}

impl Node {
    fn prefix(&self, entity_id: u32, kind: &str) -> String {
        format!(
            "@ros2_lv/{}/{}/{}/{entity_id}/{kind}/%/{}/{}",
            self.domain,
            self.zid,
            self.id,
            mangle(&self.namespace),
            self.name
        )
    }

    /// The node's liveliness token: `@ros2_lv/<domain>/<zid>/<nid>/<nid>/NN/%/<ns>/<name>`.
    pub fn token(&self) -> String {
        self.prefix(self.id, "NN")
    }

    /// A publisher's or subscription's token: the node's fields, then the topic (mangled), the
    /// DDS type, its hash and the QoS string.
    pub fn entity_token(
        &self,
        entity_id: u32,
        kind: EntityKind,
        topic: &str,
        ty: &RosType,
        qos: Qos,
    ) -> String {
        let kind = match kind {
            EntityKind::Publisher => "MP",
            EntityKind::Subscription => "MS",
        };
        format!(
            "{}/{}/{}/{}/{}",
            self.prefix(entity_id, kind),
            mangle(topic),
            ty.dds_name,
            ty.hash,
            qos.to_key()
        )
    }
}

/// An entity's GID as rmw_zenoh makes it: XXH3-128 of its liveliness token, low then high 64
/// bits, each little-endian.
pub fn gid(token: &str) -> [u8; 16] {
    xxh3_128(token.as_bytes()).to_le_bytes()
}

/// The 33-byte attachment of a sample: sequence number (i64 LE, from 1 per publisher), source
/// timestamp (i64 LE, ns since the Unix epoch), then the GID as a 16-element sequence (LEB128
/// length `0x10`, the bytes) — zenoh-ext's serialization of `(i64, i64, [u8; 16])`.
pub fn attachment(sequence: i64, source_unix_ns: i64, gid: &[u8; 16]) -> [u8; 33] {
    let mut out = [0u8; 33];
    out[..8].copy_from_slice(&sequence.to_le_bytes());
    out[8..16].copy_from_slice(&source_unix_ns.to_le_bytes());
    out[16] = 16;
    out[17..].copy_from_slice(gid);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::msgs::{POINT_CLOUD2, TWIST_STAMPED};

    fn node() -> Node {
        Node {
            domain: 0,
            zid: "d4f1a2b3c4e5f6071829304a5b6c7d8e".into(),
            id: 0,
            namespace: "/".into(),
            name: "splat_bridge".into(),
        }
    }

    // Expected forms from rmw_zenoh_cpp's liveliness_utils.cpp (Jazzy 0.2.10).

    #[test]
    fn keys_and_tokens_have_rmw_zenohs_form() {
        assert_eq!(
            topic_key(0, "/robot1/points", &POINT_CLOUD2),
            "0/robot1/points/sensor_msgs::msg::dds_::PointCloud2_/\
             RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5"
        );
        let n = node();
        assert_eq!(
            n.token(),
            "@ros2_lv/0/d4f1a2b3c4e5f6071829304a5b6c7d8e/0/0/NN/%/%/splat_bridge"
        );
        let mp = n.entity_token(
            1,
            EntityKind::Publisher,
            "/splat/points",
            &POINT_CLOUD2,
            Qos::DEFAULT,
        );
        assert_eq!(
            mp,
            "@ros2_lv/0/d4f1a2b3c4e5f6071829304a5b6c7d8e/0/1/MP/%/%/splat_bridge/%splat%points/\
             sensor_msgs::msg::dds_::PointCloud2_/\
             RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5/::,10:,:,:,,"
        );
        let ms = n.entity_token(
            2,
            EntityKind::Subscription,
            "/cmd",
            &TWIST_STAMPED,
            Qos::SENSOR_DATA,
        );
        assert!(ms.ends_with("/0/2/MS/%/%/splat_bridge/%cmd/geometry_msgs::msg::dds_::TwistStamped_/RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64/2::,5:,:,:,,"), "{ms}");
        // The GID of that publisher, from xxhash's reference implementation.
        assert_eq!(
            gid(&mp),
            [
                0xf9, 0x2e, 0xee, 0xbc, 0xbe, 0x72, 0x8c, 0x14, 0x1d, 0x0a, 0x5d, 0xe7, 0x4b, 0xf4,
                0x24, 0x27
            ]
        );
    }

    #[test]
    fn qos_strings_leave_defaults_empty() {
        assert_eq!(Qos::DEFAULT.to_key(), "::,10:,:,:,,");
        assert_eq!(Qos::SENSOR_DATA.to_key(), "2::,5:,:,:,,");
        let latched = Qos {
            reliable: true,
            transient_local: true,
            depth: 1,
        };
        assert_eq!(latched.to_key(), ":1:,1:,:,:,,");
        let default_depth = Qos {
            depth: 42,
            ..Qos::DEFAULT
        };
        assert_eq!(default_depth.to_key(), "::,:,:,:,,");
    }

    #[test]
    fn the_attachment_has_zenoh_exts_layout() {
        let gid: [u8; 16] = std::array::from_fn(|i| i as u8);
        let a = attachment(1, 1_700_000_000_123_456_789, &gid);
        let want = [
            0x01, 0, 0, 0, 0, 0, 0, 0, 0x15, 0xcd, 0x85, 0x3d, 0xfe, 0x9c, 0x97, 0x17, 0x10, 0, 1,
            2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15,
        ];
        assert_eq!(a, want);
    }

    #[test]
    fn object_names_become_ros_tokens() {
        assert_eq!(ros_token("finger"), "finger");
        assert_eq!(ros_token("#3 red cup"), "_3_red_cup");
        assert_eq!(ros_token("3d"), "o3d");
        assert_eq!(ros_token(""), "o");
        assert!(is_ros_token(&ros_token("vase-1 (copy)")));
        assert!(!is_ros_token("a/b"));
    }
}
