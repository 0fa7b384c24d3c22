"""Planning: Path -> per-block limits -> look-ahead feed law (Motion) -> samples."""
