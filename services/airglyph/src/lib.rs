//! The library half of the `airglyph` executable: the [`supervisor`] that `airglyph run`,
//! `demo` and `collect` start and keep the pipeline's stages with, apart from the
//! commands so that it has tests of its own and no command has to import another.
//!
//! It lives in the executable's package, not in a crate of its own: it starts the
//! stages from this very executable (`airglyph stage NAME`) and probes the viewer's
//! health through `airglyph-viewer`, and a crate of `services/` may not use another
//! service's crate (docs/architecture.md, "Crates and what each may depend on"); only
//! the executable uses them all.

#![warn(missing_docs)]

pub mod supervisor;
