//! The `splatphys-zenoh` command line (clap), in the library so tests parse the commands the
//! docs show and `docs/reference/cli/` is generated from it.

use std::path::PathBuf;

use clap::Parser;

/// Bridge a splatphys server to Zenoh: frames, objects, status, scene and object names for
/// clients on other machines; commands as queries when allowed.
#[derive(Parser, Debug)]
#[command(
    version,
    about,
    after_help = "Examples:
  splatphys-zenoh --prefix splatphys/default                       # loopback only, tcp/127.0.0.1:7447
  splatphys-zenoh --prefix splatphys/default --listen tcp/0.0.0.0:7447 --allow-commands
  splatphys-zenoh --prefix splatphys/default --config zenoh-tls.json5   # TLS, access control
  splatphys-zenoh --prefix splatphys/default --ros2 --allow-commands     # ROS 2 via rmw_zenohd"
)]
pub struct Cli {
    /// Service prefix of the server (e.g. `splatphys/<scene>`).
    #[arg(long)]
    pub prefix: String,
    /// Zenoh key prefix of what the bridge publishes (default: the service prefix).
    #[arg(long)]
    pub key: Option<String>,
    /// Forward command queries to the server (refused with a reason otherwise).
    #[arg(long)]
    pub allow_commands: bool,
    /// Zenoh endpoint to listen on (repeat for several); default tcp/127.0.0.1:7447.
    #[arg(long)]
    pub listen: Vec<String>,
    /// Zenoh endpoint to connect to, e.g. a router (repeat for several).
    #[arg(long)]
    pub connect: Vec<String>,
    /// Zenoh configuration file (JSON5), applied before --listen and --connect: TLS, user and
    /// password authentication, access control, scouting.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Seconds to wait for the server.
    #[arg(long, default_value_t = 10.0)]
    pub connect_timeout_s: f64,
    /// Seconds a forwarded command waits for the server's reply.
    #[arg(long, default_value_t = 5.0)]
    pub command_timeout_s: f64,
    /// Also publish ROS 2 topics (rmw_zenoh, Jazzy): the Gaussians as a PointCloud2, every
    /// object on /tf, each object's contact wrench; with --allow-commands, cmd_pose and
    /// cmd_twist per object. Without --listen/--connect/--config, joins the rmw_zenohd router
    /// at tcp/localhost:7447.
    #[arg(long)]
    pub ros2: bool,
    /// ROS domain id.
    #[arg(long, env = "ROS_DOMAIN_ID", default_value_t = 0)]
    pub ros2_domain: u32,
    /// Namespace of the ROS 2 topics.
    #[arg(long, default_value = "/splatphys")]
    pub ros2_namespace: String,
    /// Frame of the ROS 2 point cloud and wrenches, parent of every object's transform.
    #[arg(long, default_value = "world")]
    pub ros2_frame: String,
}
