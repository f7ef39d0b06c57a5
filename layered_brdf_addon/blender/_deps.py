"""The node-group builder lives in the repository's ``node_groups`` package."""
try:  # inside the installed extension: the repository root is the parent package
    from ...node_groups import layered as node_group_builder  # noqa: F401
except ImportError:  # a checkout on sys.path
    from node_groups import layered as node_group_builder  # noqa: F401
