//! Built-in stroke templates.
