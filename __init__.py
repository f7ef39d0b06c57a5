"""Extension entry point: the repository root is the extension's package."""
if __package__:
    from .layered_brdf_addon import register, unregister
else:  # imported as a plain module (pytest collecting a checkout whose folder is no valid package name)
    from layered_brdf_addon import register, unregister

__all__ = ["register", "unregister"]
