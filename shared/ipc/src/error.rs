/// A failure of the shared-memory transport, with the service it concerns.
#[derive(Debug, thiserror::Error)]
pub enum IpcError {
    #[error("iceoryx2 configuration: {0}")]
    Config(String),
    #[error("cannot create the iceoryx2 node {node:?}: {reason}")]
    Node { node: String, reason: String },
    #[error("service {service}: {reason}")]
    Service { service: String, reason: String },
}

impl IpcError {
    pub(crate) fn service(service: &str, reason: impl std::fmt::Debug) -> Self {
        Self::Service {
            service: service.to_owned(),
            reason: format!("{reason:?}"),
        }
    }
}
