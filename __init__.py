"""Extension entry point: the repository root is the extension's package."""
from .layered_brdf_addon import register, unregister

__all__ = ["register", "unregister"]
