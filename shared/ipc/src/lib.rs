//! The contracts between airglyph's processes: iceoryx2 services, wire types, stage telemetry
