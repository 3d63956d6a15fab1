//! Where an arm's services are and how they are opened: names, the iceoryx2 domain and root, the
//! node, the publish-subscribe services' quality of service, and what can go wrong setting them up.

use iceoryx2::config::Config;
use iceoryx2::node::NodeCreationFailure;
use iceoryx2::service::service_name::ServiceNameError;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenOrCreateError;
use iceoryx2::service::builder::request_response::{RequestResponseOpenError, RequestResponseOpenOrCreateError};

use crate::access;

/// The service names of one arm.
///
/// ```
/// let n = jointctl_ipc::ServiceNames::for_arm("sherpa");
/// assert_eq!(n.joint_state, "sherpa/joint_state");
/// assert_eq!(n.raw, "sherpa/raw");
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ServiceNames {
    /// [`ArmState`] publish-subscribe service.
    pub joint_state: String,
    /// [`Diagnostics`] publish-subscribe service.
    pub diagnostics: String,
    /// [`raw::RawFrame`] publish-subscribe service.
    pub raw: String,
    /// [`raw::RawDescriptor`] publish-subscribe service (one sample, kept).
    pub raw_descriptor: String,
    /// [`raw::CommandRecord`] publish-subscribe service: the accepted commands.
    pub commands: String,
    /// [`JointsDescriptor`] publish-subscribe service (one sample, kept).
    pub joints: String,
    /// The latest observed [`ArmState`], a blackboard the loop thread writes itself
    /// ([`LatestStateWriter`]).
    pub latest_state: String,
}

impl ServiceNames {
    /// Names derived from the arm's name.
    pub fn for_arm(arm: &str) -> Self {
        ServiceNames {
            joint_state: format!("{arm}/joint_state"),
            diagnostics: format!("{arm}/diagnostics"),
            raw: format!("{arm}/raw"),
            raw_descriptor: format!("{arm}/raw_descriptor"),
            commands: format!("{arm}/commands"),
            joints: format!("{arm}/joints"),
            latest_state: format!("{arm}/latest_state"),
        }
    }
}

/// Failure to set up shared memory; iceoryx2's own error is kept as the source.
///
/// ```
/// let e = jointctl_ipc::create_node(Some("bad/domain"), "n").unwrap_err();
/// assert!(matches!(e, jointctl_ipc::IpcSetupError::Domain { .. }));
/// assert!(std::error::Error::source(&e).is_some());
/// ```
#[derive(Debug, thiserror::Error)]
pub enum IpcSetupError {
    /// The iceoryx2 domain name is not usable as a file prefix.
    #[error("iceoryx2 domain `{domain}` is not valid")]
    Domain {
        /// The domain.
        domain: String,
        /// iceoryx2's reason.
        source: SemanticStringError,
    },
    /// The node name is not valid.
    #[error("`{node}` is not a valid iceoryx2 node name")]
    NodeName {
        /// Node name.
        node: String,
        /// iceoryx2's reason.
        source: SemanticStringError,
    },
    /// The iceoryx2 node could not be created.
    #[error("cannot create the iceoryx2 node `{node}`{}", .segment.as_ref().map(|s| format!(" (the domain's management segment {s})")).unwrap_or_default())]
    Node {
        /// Node name.
        node: String,
        /// The domain's management segment with its owner and mode, when it exists (what a
        /// permission failure is about).
        segment: Option<String>,
        /// iceoryx2's reason.
        source: NodeCreationFailure,
    },
    /// The domain's files are not safe or not accessible to this user.
    #[error(transparent)]
    Access(#[from] access::AccessError),
    /// `ipc.root` is not a path iceoryx2 accepts.
    #[error("`{}` is not a usable shared-memory root (ipc.root)", .root.display())]
    Root {
        /// The root.
        root: std::path::PathBuf,
        /// iceoryx2's reason.
        source: iceoryx2::prelude::SemanticStringError,
    },
    /// The service name is not valid.
    #[error("`{service}` is not a valid iceoryx2 service name")]
    ServiceName {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: ServiceNameError,
    },
    /// A publish-subscribe service could not be created or opened.
    #[error("cannot open service `{service}`")]
    PublishSubscribe {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: PublishSubscribeOpenOrCreateError,
    },
    /// A published service could not be opened by a reader (usually: no runtime runs the arm).
    #[error("cannot open service `{service}` (is `jointctl run` running this arm in this domain?)")]
    OpenPublishSubscribe {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError,
    },
    /// The command service could not be created.
    #[error("cannot create service `{service}`")]
    CreateRequestResponse {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: RequestResponseOpenOrCreateError,
    },
    /// The command service could not be opened (usually: no runtime serves it).
    #[error("cannot open service `{service}`")]
    OpenRequestResponse {
        /// Service name.
        service: String,
        /// iceoryx2's reason.
        source: RequestResponseOpenError,
    },
    /// The latest-state blackboard could not be created, opened or given its port or entry.
    #[error("cannot {what} the latest-state blackboard `{service}`")]
    LatestState {
        /// Service name.
        service: String,
        /// What failed: "create", "open", "write to" (and why, where known) or "read".
        what: &'static str,
        /// iceoryx2's reason.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// Where an arm's shared memory lives: its iceoryx2 domain (file prefix), the root folder of
/// its files (`None`: iceoryx2's default, `/tmp/iceoryx2/`) and the group given that folder
/// when it is created. Every process of one arm must use the same (the YAML's `ipc` section).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IpcScope {
    /// iceoryx2 domain; `None`: iceoryx2's default prefix `iox2_`.
    pub domain: Option<String>,
    /// Root folder of the domain's files.
    pub root: Option<std::path::PathBuf>,
    /// Group given the root folder when it is created (mode 0750 instead of 0700).
    pub group: Option<String>,
}

impl IpcScope {
    /// The default root with this domain.
    pub fn domain(domain: Option<&str>) -> Self {
        IpcScope { domain: domain.map(str::to_string), ..Default::default() }
    }
}

/// The iceoryx2 configuration of a scope: iceoryx2's defaults, with the file prefix set to the
/// domain and the root path to the root when given. Built in code so that no process depends on
/// its working directory.
pub fn iceoryx2_config_in(scope: &IpcScope) -> Result<Config, IpcSetupError> {
    let mut config = Config::default();
    if let Some(d) = &scope.domain {
        config.global.prefix = d.as_str().try_into().map_err(|source| IpcSetupError::Domain { domain: d.to_string(), source })?;
    }
    if let Some(root) = &scope.root {
        let text = root.to_string_lossy();
        let path = iceoryx2::prelude::Path::new(text.as_bytes()).map_err(|source| IpcSetupError::Root { root: root.clone(), source })?;
        config.global.set_root_path(&path);
    }
    Ok(config)
}

/// Where the runtimes of a domain keep their single-runtime locks: `jointctl/<prefix>` under
/// the domain's iceoryx2 root.
///
/// ```
/// let dir = jointctl_ipc::lock_dir_in(&jointctl_ipc::IpcScope::domain(Some("lab"))).unwrap();
/// assert!(dir.ends_with("jointctl/lab"));
/// ```
pub fn lock_dir_in(scope: &IpcScope) -> Result<std::path::PathBuf, IpcSetupError> {
    let config = iceoryx2_config_in(scope)?;
    let prefix = config.global.prefix.to_string();
    Ok(std::path::PathBuf::from(config.global.root_path().to_string()).join("jointctl").join(prefix.trim_end_matches('_')))
}

/// Creates the scope's root folder closed to other users, or checks the one that exists (see
/// [`access::secure_root`]); returns it. The runtime calls it before anything else of the arm is
/// created; [`create_node_in`] calls it too.
pub fn prepare_root(scope: &IpcScope) -> Result<std::path::PathBuf, IpcSetupError> {
    let config = iceoryx2_config_in(scope)?;
    let root = std::path::PathBuf::from(config.global.root_path().to_string());
    access::secure_root(&root, scope.group.as_deref())?;
    Ok(root)
}

/// An iceoryx2 node in the arm's domain, with iceoryx2's own signal handling off (the runtime
/// owns its signals and timing). Dead nodes of crashed processes are cleaned up.
///
/// ```
/// let e = jointctl_ipc::create_node(Some("bad/domain"), "n").unwrap_err();
/// assert!(e.to_string().contains("bad/domain"));
/// ```
pub fn create_node(domain: Option<&str>, name: &str) -> Result<Node<ipc::Service>, IpcSetupError> {
    create_node_in(&IpcScope::domain(domain), name)
}

/// [`create_node`] in a whole scope. The root folder and the domain's management segment are
/// checked and closed to other users around iceoryx2 (see [`access`]).
pub fn create_node_in(scope: &IpcScope, name: &str) -> Result<Node<ipc::Service>, IpcSetupError> {
    create_node_of::<ipc::Service>(scope, name)
}

/// [`create_node_in`] of the iceoryx2 service kind `S`: `ipc_threadsafe::Service` for handles
/// that move between threads (the latest-state blackboard's writer, inside a runtime's
/// `ArmPublisher`).
pub fn create_node_of<S: iceoryx2::service::Service>(scope: &IpcScope, name: &str) -> Result<Node<S>, IpcSetupError> {
    // iceoryx2 warns that it found no config file, which is by design here (the config is built
    // in code); its own `IOX2_LOG_LEVEL` still overrides this.
    set_log_level_from_env_or(LogLevel::Error);
    let config = iceoryx2_config_in(scope)?;
    prepare_root(scope)?;
    let prefix = config.global.prefix.to_string();
    access::check_management_segment(&prefix)?;
    let node_name = NodeName::new(name).map_err(|source| IpcSetupError::NodeName { node: name.to_string(), source })?;
    let node = NodeBuilder::new()
        .name(&node_name)
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<S>()
        .map_err(|source| {
            // iceoryx2 says "InternalError" or "UnableToGenerateUniqueNodeId" without a path; the
            // management segment is the file a failing node creation could not use.
            let segment = access::management_segment(&prefix).map(|p| {
                use std::os::unix::fs::MetadataExt;
                let (owner, mode) = std::fs::metadata(&p).map(|m| (m.uid(), m.mode() & 0o7777)).unwrap_or((u32::MAX, 0));
                let me = access::effective_uid();
                let hint = if owner != me && me != 0 { ": permission denied, run as that user" } else { "" };
                format!("{} belongs to uid {owner} (mode {mode:04o}), this process is uid {me}{hint}", p.display())
            });
            IpcSetupError::Node { node: name.to_string(), segment, source }
        })?;
    access::close_management_segment(&prefix)?;
    let _ = node.try_cleanup_dead_nodes();
    Ok(node)
}

/// Subscriber buffer per inspector: a slow inspector loses the oldest samples, it never slows
/// the publisher.
pub const SUBSCRIBER_BUFFER: usize = 64;

pub(crate) fn service_name(name: &str) -> Result<ServiceName, IpcSetupError> {
    ServiceName::new(name).map_err(|source| IpcSetupError::ServiceName { service: name.to_string(), source })
}

/// How many ports the runtime's services admit (the YAML `ipc` section).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PortLimits {
    /// Subscribers of each published service.
    pub max_subscribers: usize,
    /// Clients of the command service.
    pub max_clients: usize,
}

impl Default for PortLimits {
    fn default() -> Self {
        PortLimits { max_subscribers: 16, max_clients: 16 }
    }
}
