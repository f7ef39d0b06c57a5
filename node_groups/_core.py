"""Access to the bpy-free core, from a checkout or from inside the installed extension."""
try:  # inside the extension package, the repository root is the parent package
    from ..layered_brdf_addon.model import params, plan, program, sphere  # noqa: F401
except ImportError:  # a checkout on sys.path
    from layered_brdf_addon.model import params, plan, program, sphere  # noqa: F401
