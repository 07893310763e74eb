/// A failure of the shared-memory transport, with the service it concerns.
#[derive(Debug, thiserror::Error)]
pub enum IpcError {
    #[error("iceoryx2 configuration: {0}")]
    Config(String),
    #[error("cannot create the iceoryx2 node {node:?}: {reason}")]
    Node { node: String, reason: String },
    #[error("service {service}: {reason}")]
    Service { service: String, reason: String },
    /// A file or folder of the pipeline that another user could have made or could
    /// change (see [`crate::ownership`]).
    #[error("{}: {reason}", path.display())]
    Unsafe {
        path: std::path::PathBuf,
        reason: String,
    },
    /// A second publisher of a stream: two would interleave their messages.
    #[error("{service} already has a publisher: process {pid} (iceoryx2 node {node:?}) on this pipeline (prefix {prefix:?}); a second one would interleave two streams. Stop that one first, or give this one a pipeline of its own (AIRGLYPH_IPC_PREFIX)")]
    Taken {
        service: String,
        pid: i64,
        node: String,
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
