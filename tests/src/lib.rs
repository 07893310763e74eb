//! System tests that start real airglyph processes
