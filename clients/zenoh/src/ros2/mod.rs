//! ROS 2 without a ROS bridge: with `--ros2`, the bridge also speaks rmw_zenoh's conventions
//! (ROS 2 Jazzy), so a ROS 2 machine running `rmw_zenoh_cpp` sees its topics through the
//! `rmw_zenohd` router:
//!
//! | topic (namespace `N`, default `/splatphys`) | type | what |
//! |---|---|---|
//! | `N/gaussians` | `sensor_msgs/msg/PointCloud2` | every Gaussian's centre (x, y, z), colour (`rgb`, packed) and `opacity`, each frame; best effort |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | every object's pose (child frame: its name) in the world frame |
//! | `N/<object>/wrench` | `geometry_msgs/msg/WrenchStamped` | contact force (N) and torque about the COM (N·m), world frame |
//! | `N/<object>/cmd_pose` | `geometry_msgs/msg/PoseStamped` | subscribed with `--allow-commands`: drive a kinematic object (COM position, orientation relative to its rest pose) |
//! | `N/<object>/cmd_twist` | `geometry_msgs/msg/TwistStamped` | subscribed with `--allow-commands`: set an object's velocity (m/s) and angular velocity (rad/s) |
//!
//! - [`msgs`]: the messages, their CDR form and their type hashes;
//! - [`graph`]: key expressions, liveliness tokens, QoS strings, attachments.

pub mod graph;
pub mod msgs;

use std::collections::{HashMap, VecDeque};
use std::time::{SystemTime, UNIX_EPOCH};

use splatphys_ipc::client::{Connection, PendingCommand};
use splatphys_ipc::command::{Command, Reply};
use splatphys_ipc::wire::{FrameGaussian, FrameHeader, ObjectName, ObjectState, SceneGaussian};
use zenoh::Wait;
use zenoh::handlers::FifoChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::sample::Sample;

use self::graph::{EntityKind, Node, Qos, attachment, gid, ros_token, topic_key};
use self::msgs::{
    Bytes, FLOAT32, Header, POINT_CLOUD2, POSE_STAMPED, PointCloud2, PointField, PoseStamped,
    Quaternion, RosType, TF_MESSAGE, TWIST_STAMPED, TfMessage, Time, Transform, TransformStamped,
    TwistStamped, WRENCH_STAMPED, Wrench, WrenchStamped, from_cdr, to_cdr,
};
use crate::bridge::BridgeError;

/// How the ROS 2 side is named.
#[derive(Debug, Clone)]
pub struct Ros2Options {
    /// ROS domain id (`ROS_DOMAIN_ID`).
    pub domain: u32,
    /// Namespace of the topics, e.g. `/splatphys`.
    pub namespace: String,
    /// Frame of the point cloud, the wrenches and the parent of every object's transform.
    pub frame_id: String,
    /// Name of the node in the ROS graph.
    pub node_name: String,
}

impl Default for Ros2Options {
    fn default() -> Self {
        Self {
            domain: 0,
            namespace: "/splatphys".into(),
            frame_id: "world".into(),
            node_name: "splatphys_bridge".into(),
        }
    }
}

/// Bytes of one point of the cloud: x, y, z, rgb, opacity (f32 each).
const POINT_STEP: u32 = 20;
/// SH band-0 constant: colour = 0.5 + C0 · DC (Kerbl et al. 2023).
const SH_C0: f32 = 0.282_094_8;
/// Commands from ROS waiting for the server's reply at most (older ones are not waited for).
const MAX_PENDING: usize = 64;

fn zerr(what: &str) -> impl FnOnce(zenoh::Error) -> BridgeError + '_ {
    move |e| BridgeError::Zenoh {
        what: what.to_string(),
        message: e.to_string(),
    }
}

fn now_unix_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// One ROS publisher: its Zenoh publisher, its liveliness token, its GID and sequence number.
struct Topic<'s> {
    publisher: Publisher<'s>,
    _token: LivelinessToken,
    gid: [u8; 16],
    sequence: i64,
}

impl Topic<'_> {
    fn put(&mut self, cdr: Vec<u8>) -> Result<(), BridgeError> {
        self.sequence += 1;
        let a = attachment(self.sequence, now_unix_ns() as i64, &self.gid);
        self.publisher
            .put(cdr)
            .attachment(a.to_vec())
            .wait()
            .map_err(zerr("publishing to ROS 2"))
    }
}

/// Declares the node's publishers and subscriptions in Zenoh and in the ROS graph.
struct Graph<'s> {
    session: &'s zenoh::Session,
    domain: u32,
    node: Node,
    next_entity: u32,
}

impl<'s> Graph<'s> {
    fn token(&self, key: String) -> Result<LivelinessToken, BridgeError> {
        self.session
            .liveliness()
            .declare_token(key)
            .wait()
            .map_err(zerr("ROS 2 liveliness token"))
    }

    fn entity_key(&mut self, kind: EntityKind, name: &str, ty: &RosType, qos: Qos) -> String {
        let id = self.next_entity;
        self.next_entity += 1;
        self.node.entity_token(id, kind, name, ty, qos)
    }

    /// A publisher on topic `name` and its token; best effort drops under congestion.
    fn publisher(&mut self, name: &str, ty: &RosType, qos: Qos) -> Result<Topic<'s>, BridgeError> {
        let key = self.entity_key(EntityKind::Publisher, name, ty, qos);
        let publisher = self
            .session
            .declare_publisher(topic_key(self.domain, name, ty))
            .congestion_control(if qos.reliable {
                CongestionControl::Block
            } else {
                CongestionControl::Drop
            })
            .wait()
            .map_err(zerr("ROS 2 publisher"))?;
        Ok(Topic {
            publisher,
            _token: self.token(key.clone())?,
            gid: gid(&key),
            sequence: 0,
        })
    }

    /// A subscription's token (the Zenoh subscriber itself listens on a wildcard).
    fn subscription(&mut self, name: &str, ty: &RosType) -> Result<LivelinessToken, BridgeError> {
        let key = self.entity_key(EntityKind::Subscription, name, ty, Qos::DEFAULT);
        self.token(key)
    }
}

/// The ROS 2 face of the bridge.
pub struct Ros2<'s> {
    opts: Ros2Options,
    graph: Graph<'s>,
    _node_token: LivelinessToken,
    points: Topic<'s>,
    tf: Topic<'s>,
    /// Per object (by id): its wrench topic.
    wrenches: Vec<Topic<'s>>,
    /// Per object: its ROS name token.
    object_names: Vec<String>,
    by_name: HashMap<String, u32>,
    command_tokens: Vec<LivelinessToken>,
    commands: Option<[Subscriber<FifoChannelHandler<Sample>>; 2]>,
    pending: VecDeque<(u64, PendingCommand)>,
    /// Per Gaussian (from the scene): packed rgb and opacity.
    colours: Vec<(f32, f32)>,
}

impl<'s> Ros2<'s> {
    /// Declares the node, the point cloud and the TF publishers, and with `allow_commands` the
    /// command subscriptions.
    ///
    /// # Errors
    /// Zenoh could not declare them.
    pub fn new(
        session: &'s zenoh::Session,
        opts: Ros2Options,
        allow_commands: bool,
    ) -> Result<Self, BridgeError> {
        let node = Node {
            domain: opts.domain,
            zid: session.zid().to_string(),
            id: 0,
            namespace: "/".into(),
            name: opts.node_name.clone(),
        };
        let ns = opts.namespace.trim_end_matches('/').to_string();
        let commands = if allow_commands {
            let sub = |leaf: &str, ty: &RosType| {
                session
                    .declare_subscriber(topic_key(opts.domain, &format!("{ns}/*/{leaf}"), ty))
                    .wait()
                    .map_err(zerr("ROS 2 command subscription"))
            };
            Some([
                sub("cmd_pose", &POSE_STAMPED)?,
                sub("cmd_twist", &TWIST_STAMPED)?,
            ])
        } else {
            None
        };
        let mut graph = Graph {
            session,
            domain: opts.domain,
            node,
            next_entity: 1,
        };
        let node_token = graph.token(graph.node.token())?;
        Ok(Self {
            points: graph.publisher(&format!("{ns}/gaussians"), &POINT_CLOUD2, Qos::SENSOR_DATA)?,
            tf: graph.publisher("/tf", &TF_MESSAGE, Qos::TF)?,
            graph,
            _node_token: node_token,
            wrenches: Vec::new(),
            object_names: Vec::new(),
            by_name: HashMap::new(),
            command_tokens: Vec::new(),
            commands,
            pending: VecDeque::new(),
            colours: Vec::new(),
            opts,
        })
    }

    fn namespace(&self) -> &str {
        self.opts.namespace.trim_end_matches('/')
    }

    /// A new scene: each Gaussian's colour (from its SH DC term) and opacity for the cloud.
    pub fn on_scene(&mut self, gaussians: &[SceneGaussian]) {
        self.colours = gaussians
            .iter()
            .map(|g| {
                let c = |k: usize| ((0.5 + SH_C0 * g.sh[k]).clamp(0.0, 1.0) * 255.0).round() as u32;
                let packed = (c(0) << 16) | (c(1) << 8) | c(2);
                (f32::from_bits(packed), g.opacity)
            })
            .collect();
    }

    /// Every object's name: a wrench publisher each and, with commands allowed, the command
    /// subscriptions in the graph.
    ///
    /// # Errors
    /// Zenoh could not declare them.
    pub fn on_object_names(&mut self, names: &[ObjectName]) -> Result<(), BridgeError> {
        let mut taken = HashMap::new();
        let tokens: Vec<String> = names
            .iter()
            .enumerate()
            .map(|(id, n)| {
                let mut t = ros_token(&n.text());
                if taken.contains_key(&t) {
                    t = format!("{t}_{id}");
                }
                taken.insert(t.clone(), id as u32);
                t
            })
            .collect();
        if tokens == self.object_names {
            return Ok(());
        }
        self.wrenches.clear();
        self.command_tokens.clear();
        let ns = self.namespace().to_string();
        for t in &tokens {
            let wrench = format!("{ns}/{t}/wrench");
            self.wrenches.push(
                self.graph
                    .publisher(&wrench, &WRENCH_STAMPED, Qos::DEFAULT)?,
            );
            if self.commands.is_some() {
                for (leaf, ty) in [("cmd_pose", &POSE_STAMPED), ("cmd_twist", &TWIST_STAMPED)] {
                    let token = self.graph.subscription(&format!("{ns}/{t}/{leaf}"), ty)?;
                    self.command_tokens.push(token);
                }
            }
        }
        self.by_name = taken;
        self.object_names = tokens;
        Ok(())
    }

    /// Publishes a frame as a point cloud.
    ///
    /// # Errors
    /// Zenoh could not publish.
    pub fn on_frame(
        &mut self,
        header: &FrameHeader,
        gaussians: &[FrameGaussian],
    ) -> Result<(), BridgeError> {
        let coloured = self.colours.len() == gaussians.len();
        let mut data = Vec::with_capacity(gaussians.len() * POINT_STEP as usize);
        for (i, g) in gaussians.iter().enumerate() {
            let (rgb, opacity) = if coloured {
                self.colours[i]
            } else {
                (f32::from_bits(0x00ff_ffff), 1.0)
            };
            for v in g.position_m.into_iter().chain([rgb, opacity]) {
                data.extend_from_slice(&v.to_le_bytes());
            }
        }
        let field = |name: &str, offset| PointField {
            name: name.into(),
            offset,
            datatype: FLOAT32,
            count: 1,
        };
        let cloud = PointCloud2 {
            header: self.header(header.publish_unix_ns),
            height: 1,
            width: gaussians.len() as u32,
            fields: vec![
                field("x", 0),
                field("y", 4),
                field("z", 8),
                field("rgb", 12),
                field("opacity", 16),
            ],
            is_bigendian: false,
            point_step: POINT_STEP,
            row_step: POINT_STEP * gaussians.len() as u32,
            data: Bytes(data),
            is_dense: true,
        };
        self.points.put(cdr(&cloud)?)
    }

    fn header(&self, unix_ns: u64) -> Header {
        Header {
            stamp: Time::from_unix_ns(unix_ns),
            frame_id: self.opts.frame_id.clone(),
        }
    }

    /// Publishes every object's transform and every solid's wrench.
    ///
    /// # Errors
    /// Zenoh could not publish.
    pub fn on_objects(
        &mut self,
        header: &FrameHeader,
        objects: &[ObjectState],
    ) -> Result<(), BridgeError> {
        let stamp = self.header(header.publish_unix_ns);
        let transforms = objects
            .iter()
            .filter_map(|o| {
                Some(TransformStamped {
                    header: stamp.clone(),
                    child_frame_id: self.object_names.get(o.id as usize)?.clone(),
                    transform: Transform {
                        translation: o.position_m.into(),
                        rotation: Quaternion::from_wxyz(o.orientation_wxyz),
                    },
                })
            })
            .collect();
        self.tf.put(cdr(&TfMessage { transforms })?)?;
        for o in objects {
            let Some(topic) = self.wrenches.get_mut(o.id as usize) else {
                continue;
            };
            let msg = WrenchStamped {
                header: stamp.clone(),
                wrench: Wrench {
                    force: o.contact_force_n.into(),
                    torque: o.contact_torque_n_m.into(),
                },
            };
            topic.put(cdr(&msg)?)?;
        }
        Ok(())
    }

    /// Sends what arrived on the command topics to the server (without waiting for replies),
    /// and reports refusals of earlier ones on stderr.
    ///
    /// # Errors
    /// The server went away.
    pub fn forward_commands(&mut self, conn: &mut Connection) -> Result<(), BridgeError> {
        while let Some((seq, p)) = self.pending.front() {
            match conn.poll_reply(p)? {
                Some(Reply::Rejected { reason, .. }) => {
                    eprintln!("splatphys-zenoh: ROS 2 command #{seq} refused: {reason}");
                }
                Some(Reply::Accepted { .. }) => {}
                None if self.pending.len() < MAX_PENDING => break,
                None => {}
            }
            self.pending.pop_front();
        }
        let Some(subs) = &self.commands else {
            return Ok(());
        };
        let mut received = Vec::new();
        for sub in subs {
            while let Ok(Some(sample)) = sub.try_recv() {
                received.push(sample);
            }
        }
        for sample in received {
            match self.command_of(&sample) {
                Ok(cmd) => match conn.send_command(&cmd) {
                    Ok(sent) => self.pending.push_back(sent),
                    Err(e) => eprintln!("splatphys-zenoh: ROS 2 command not sent: {e}"),
                },
                Err(why) => eprintln!("splatphys-zenoh: {}: {why}", sample.key_expr()),
            }
        }
        Ok(())
    }

    /// The command a ROS sample on `N/<object>/cmd_pose|cmd_twist` asks for.
    fn command_of(&self, sample: &Sample) -> Result<Command, String> {
        let key = sample.key_expr().as_str();
        let topic = key
            .strip_prefix(&format!("{}/", self.opts.domain))
            .and_then(|k| k.strip_prefix(self.namespace().trim_start_matches('/')))
            .ok_or("not a command topic")?;
        let mut parts = topic.trim_start_matches('/').split('/');
        let (Some(name), Some(leaf)) = (parts.next(), parts.next()) else {
            return Err("not a command topic".into());
        };
        let object = *self
            .by_name
            .get(name)
            .ok_or_else(|| format!("no object named `{name}`"))?;
        let bytes = sample.payload().to_bytes();
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        match leaf {
            "cmd_pose" => {
                let m: PoseStamped =
                    from_cdr(&bytes).map_err(|e| format!("not a PoseStamped: {e}"))?;
                let position_m: [f64; 3] = m.pose.position.into();
                let orientation_wxyz = m.pose.orientation.to_wxyz();
                if !finite(&position_m) || !finite(&orientation_wxyz) {
                    return Err("a pose with a NaN or infinite value".into());
                }
                Ok(Command::SetPose {
                    object,
                    position_m,
                    orientation_wxyz,
                    at_step: None,
                })
            }
            "cmd_twist" => {
                let m: TwistStamped =
                    from_cdr(&bytes).map_err(|e| format!("not a TwistStamped: {e}"))?;
                Ok(Command::SetVelocity {
                    object,
                    velocity_m_s: m.twist.linear.into(),
                    angular_velocity_rad_s: Some(m.twist.angular.into()),
                })
            }
            other => Err(format!("`{other}` is not a command topic")),
        }
    }
}

fn cdr<T: serde::Serialize>(msg: &T) -> Result<Vec<u8>, BridgeError> {
    to_cdr(msg).map_err(|e| BridgeError::Zenoh {
        what: "CDR encoding".into(),
        message: e.to_string(),
    })
}
