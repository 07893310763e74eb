//! The contracts between airglyph's processes. Every iceoryx2 service, its settings and
//! its message types are defined here once, so a publisher and a subscriber can never
//! disagree on a setting or a type name (iceoryx2 refuses to connect them if they do).
//!
//! ```text
//!  capture ──airglyph/depth──▶ pose ──airglyph/skeleton──▶ gesture ──airglyph/gesture──▶
//!                                                           └─airglyph/decision─▶ (each frame)
//!     └──────────── airglyph/stats/<stage>, once a second ──────────────▶ airglyph top
//! ```
//!
//! Each publish-subscribe service has an event service of the same name through which the
//! publisher wakes its subscribers, so a stage blocks in a [`Receiver`] with a deadline
//! instead of polling.

#![warn(missing_docs)]

pub mod clock;
pub mod config;
mod error;
pub mod json;
pub mod options;
pub mod ownership;
pub mod port;
pub mod process;
pub mod shutdown;
pub mod site;
pub mod stats;
pub mod wire;

pub use config::IpcConfig;
pub use error::IpcError;
pub use port::{DepthPublisher, Pipeline, Publisher, Received, Receiver, Stage};
pub use wire::{
    DecisionMsg, DepthHeader, GestureEventMsg, LatencyChain, PostureMsg, SkeletonMsg, StageStatsMsg,
};
