/// A failure of the shared-memory transport, with the service it concerns.
#[derive(Debug, thiserror::Error)]
pub enum IpcError {
    /// iceoryx2's configuration could not be made from the pipeline's settings.
    #[error("iceoryx2 configuration: {0}")]
    Config(String),
    /// The process's iceoryx2 node could not be created.
    #[error("cannot create the iceoryx2 node {node:?}: {reason}")]
    Node {
        /// The node's name.
        node: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// A service or one of its ports failed.
    #[error("service {service}: {reason}")]
    Service {
        /// The service's name.
        service: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// A file or folder of the pipeline that another user could have made or could
    /// change (see [`crate::ownership`]).
    #[error("{}: {reason}", path.display())]
    Unsafe {
        /// The file or folder.
        path: std::path::PathBuf,
        /// What makes it unsafe.
        reason: String,
    },
    /// A second publisher of a stream: two would interleave their messages.
    #[error("{service} already has a publisher: process {pid} (iceoryx2 node {node:?}) on this pipeline (prefix {prefix:?}); a second one would interleave two streams. Stop that one first, or give this one a pipeline of its own (AIRGLYPH_IPC_PREFIX)")]
    Taken {
        /// The service.
        service: String,
        /// The publishing process's id.
        pid: i64,
        /// Its iceoryx2 node.
        node: String,
        /// The pipeline's file prefix.
        prefix: String,
    },
}

impl IpcError {
    pub(crate) fn service(service: &str, reason: impl std::fmt::Debug) -> Self {
        Self::Service {
            service: service.to_owned(),
            reason: format!("{reason:?}"),
        }
    }
}
