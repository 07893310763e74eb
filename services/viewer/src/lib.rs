//! The viewer stage as a library: what the pipeline looks like, drawn for a person.
//!
//! ```text
//!  airglyph/depth, /skeleton, /decision, /gesture, /stats/* ──Feed──▶ Scene ──render──▶ picture
//!                                                                      └──state──▶ page panels (JSON)
//! ```
//!
//! [`feed`] subscribes like any stage and copies what arrives into a [`Scene`]; the scene
//! picks the frame to show with the skeleton estimated from it, keeps the drawing hand's
//! path as the gesture stage's recognizer took it (the hand point of each of its
//! decisions) with the last gestures' Bezier points, the last gestures and a minute of
//! telemetry. It computes none of these itself: the picture shows what the recognizer
//! saw. [`render()`] draws the picture, the same for the web page ([`server`],
//! answering through [`routes`] from [`pictures`]) and for `airglyph snapshot`.
//! [`push`] streams the pipeline's messages to the page and to scripts as server-sent
//! events. [`health`] tells a supervisor whether the page is still served.

#![warn(missing_docs)]

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
