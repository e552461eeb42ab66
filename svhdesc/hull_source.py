"""Where a build's hulls come from (committed outputs, the cache, CoACD): see ``svhdesc.decompose.source``."""

from .decompose.source import HullSource, default_cache_dir, hull_bytes

__all__ = ["HullSource", "default_cache_dir", "hull_bytes"]
