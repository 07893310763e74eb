"""airglyph from Python: the pipeline's wire types (`airglyph.wire`, standard library
only) and joining a running pipeline through iceoryx2's bindings (`airglyph.pipeline`)."""
