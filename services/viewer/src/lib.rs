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
//! ([`server`], answering through [`routes`] from [`pictures`]) and for `airglyph
//! snapshot`. [`push`] streams the pipeline's messages to the page and to scripts as
//! server-sent events. [`health`] tells a supervisor whether the page is still served.

pub mod colormap;
mod connections;
pub mod draw;
pub mod feed;
pub mod health;
mod idle;
pub mod pictures;
pub mod push;
pub mod render;
pub mod routes;
pub mod scene;
pub mod server;

pub use feed::Feed;
pub use pictures::{ServeConfig, Shared};
pub use push::Push;
pub use render::{render, Overlay};
pub use scene::{Picture, Scene};
pub use server::{ServeError, Server};
