"""What the add-on writes into a .blend file: custom-property keys, and the names it gives nodes.

Saved files hold these, so each is spelled here once and never changes (a file of any
version is read by them).  The per-parameter part is derived from the parameter table
(:data:`~..model.params.PARAM_SPECS`): the settings recorded on a material are the
parameters that are not shader inputs, and the base colour's channels are the parameters
of its colour socket, so a new parameter is recorded without an edit here.

Plain Python: imports no bpy.
"""
from __future__ import annotations

import json

from ..model.params import BASE_COLOR_SOCKET, PARAM_SPECS, LayeredParams, ParameterError, ParamSpec

# --- on materials ------------------------------------------------------------------------------
MATERIAL_KEY = "layered_brdf"  # marks the materials the add-on made (or adopted)
BUILD_KEY = "layered_brdf_build"  # "backend:plan key:base layer" of the tree's last build
BACKEND_KEY = "layered_brdf_backend"  # the backend of the last build
ENUMS_KEY = "layered_brdf_enums"  # the settings of the last build (:func:`settings_record`)
SYNC_KEY = "layered_brdf_synced"  # what the material was last synchronised to (sync.signature)
CHOSEN_PLAN_KEY = "layered_brdf_chosen_plan"  # the plan a caller chose for the build (JSON), kept by later syncs
SETTINGS = "layered_brdf_settings"  # the settings property group (a PointerProperty of Material)
DISPLACED_KEY = "layered_brdf_displaced"  # the artist's material the layered one replaced in its slot
SLOT_KEY = "layered_brdf_slot"  # how the slot got the layered material: "added", "filled" or "replaced"

# --- on nodes, node groups and texts -------------------------------------------------------------
ROLE_KEY = "layered_brdf_role"  # on the add-on's nodes: "shader", "aov" or "base" (never matched by name)
NAME_KEY = "layered_brdf_name"  # on the add-on's nodes: their name when stamped (a Shift+D copy differs)
TEXT_KEY = "layered_brdf_text"  # on the OSL texts the add-on writes
SUBGROUP_KEY = "layered_brdf_stamp"  # on the sub-groups the node groups use
LEGACY_PREVIEW_KEY = "layered_brdf_preview"  # what versions before looks put on node groups

# --- names -----------------------------------------------------------------------------------------
SHADER_NODE = "Layered BRDF"  # the name of a new shader node (the artist may rename it)
OWN_PREFIX = "Layered BRDF"  # the names of the other nodes the add-on creates
AOV_THICKNESS = "layer_thickness"
AOV_LOWER_NORMAL = "lower_normal"
AOV_UPPER_NORMAL = "upper_normal"  # Cycles' Normal pass averages closure normals: not n0 here
AOVS = (AOV_THICKNESS, AOV_LOWER_NORMAL, AOV_UPPER_NORMAL)


# --- per parameter, from the parameter table -------------------------------------------------------
def setting_specs() -> list[ParamSpec]:
    """The parameters that are not shader inputs (the enums): the material's settings, recorded
    under :data:`ENUMS_KEY` at each build."""
    return [s for s in PARAM_SPECS if not s.socket]


# The parameters of the base colour's socket in channel order; an older node had one float
# socket per channel, named after the parameter.
BASE_CHANNELS = tuple(s.name for s in sorted((s for s in PARAM_SPECS if s.socket_label == BASE_COLOR_SOCKET),
                                             key=lambda s: s.component))


def settings_record(params: LayeredParams) -> dict:
    """What a build records under :data:`ENUMS_KEY`: each setting's value."""
    return {s.name: _recordable(getattr(params, s.name)) for s in setting_specs()}


def _recordable(value):
    """A setting as an ID property holds it: a film stack as its JSON text ("" for none)."""
    if value is None:
        return ""
    return json.dumps(value.to_dict(), sort_keys=True) if hasattr(value, "to_dict") else value


def recorded_settings(mat) -> dict:
    """The settings ``mat`` was last built with (:func:`settings_record`), the valid entries only:
    a record that is not a mapping, or an entry that is not one of its setting's options, is read
    as absent."""
    stored = mat.get(ENUMS_KEY)
    record = stored.to_dict() if hasattr(stored, "to_dict") else stored
    if not isinstance(record, dict):
        return {}
    specs = {s.name: s for s in setting_specs()}
    valid = {}
    for name, value in record.items():
        if name in specs:
            try:
                valid[name] = specs[name].check(value)
            except (ParameterError, TypeError):
                continue
    return valid
