//! The viewer stage as a library: what the pipeline looks like, drawn for a person.
//!
//! ```text
//!  airglyph/depth, /skeleton, /gesture, /stats/* ──Feed──▶ Scene ──render──▶ picture
//!                                                            └──state──▶ page panels (JSON)
//! ```
//!
//! [`feed`] subscribes like any stage and copies what arrives into a [`Scene`]; the scene
//! picks the frame to show with the skeleton estimated from it, follows the drawing hand
//! (airglyph-gesture's [`airglyph_gesture::HandTracker`]) and keeps the last gestures and
//! a minute of telemetry; [`render()`] draws the picture, the same for the web page
//! ([`server`]) and for `airglyph snapshot`.

pub mod colormap;
pub mod draw;
pub mod feed;
pub mod render;
pub mod scene;
pub mod server;

pub use feed::Feed;
pub use render::{render, Overlay};
pub use scene::{Picture, Scene};
pub use server::{ServeConfig, Server, Shared};
