"""What a layered material holds now: its settings (the enums, the backend, the last preset: a
property group on every material) and its parameters (floats from the shader node's sockets, the
rest from the settings).

Blender stores a setting only once it is written, so a material built when a setting had
another default reads that default (:data:`LEGACY_DEFAULTS`), or what its last build recorded.
"""
from __future__ import annotations

from ..model.params import LayeredParams, ParameterError
from ..model.policy import BACKENDS
from .own_nodes import shader_node
from .sockets import read_inputs
from .stored_keys import BACKEND_KEY, BUILD_KEY, MATERIAL_KEY, SETTINGS, recorded_settings, setting_specs

# Settings whose default has changed, with the default a material built before the change
# had: Blender stores a setting only once it is written, so a material that kept the old
# default would otherwise read the new one and change its look on the next rebuild.
LEGACY_DEFAULTS = {"accuracy": "rgb"}


def is_layered(mat) -> bool:
    """Whether ``mat`` is a material the add-on made (or adopted)."""
    return mat is not None and bool(mat.get(MATERIAL_KEY))


def layered_material_of(obj):
    """The active material of ``obj`` when it is a layered one, else None."""
    mat = obj.active_material if obj is not None else None
    return mat if is_layered(mat) else None


class RecordedSettings:
    """A material's settings where the add-on is not registered (a script that only imports it): what
    its last build recorded, read-only in the file (a build records them again), else the defaults."""

    def __init__(self, mat):
        self._set = recorded_settings(mat)
        defaults = LayeredParams()
        for s in setting_specs():
            setattr(self, s.name, self._set.get(s.name, getattr(defaults, s.name)))
        backend = mat.get(BACKEND_KEY)
        self.backend = backend if backend in BACKENDS else BACKENDS[0]
        self.preset = ""
        self.adopted = True

    def is_property_set(self, name: str) -> bool:
        return name in self._set


def settings(mat):
    """The material's settings: the property group the add-on registers on materials, or, where it is
    not registered, what the material's last build recorded (:class:`RecordedSettings`)."""
    st = getattr(mat, SETTINGS, None)
    return st if st is not None else RecordedSettings(mat)


def legacy_values(mat) -> dict:
    """The values of :data:`LEGACY_DEFAULTS` settings that ``mat`` (built by the add-on) never
    wrote: what it was built with (its recorded settings), else the old default."""
    st = settings(mat)
    if mat.get(BUILD_KEY) is None:
        return {}
    recorded = recorded_settings(mat)
    return {name: recorded.get(name, old) for name, old in LEGACY_DEFAULTS.items() if not st.is_property_set(name)}


def _setting_values(mat) -> dict:
    st = settings(mat)
    return {**{s.name: getattr(st, s.name) for s in setting_specs()}, **legacy_values(mat)}


def check_local(mat) -> None:
    """ParameterError unless ``mat`` is local (edits to linked data are not saved)."""
    if mat.library is not None:
        raise ParameterError("material", mat.name, f"a local material: it is linked from "
                             f"{mat.library.filepath}; make it local to edit it")


def params_of(mat) -> LayeredParams:
    """The material's parameters: floats from the shader's sockets, the rest from its settings."""
    node = shader_node(mat)
    if node is None:
        raise ParameterError("material", mat.name, "a material holding the 'Layered BRDF' shader node "
                             "(apply the layered material first)")
    return read_inputs(node, base=LayeredParams.from_dict(_setting_values(mat)))
