"""Layered materials as Asset Browser assets: *looks*, one material per preset.

A look is a material carrying a preset's values (its node group embedded, as in any
material), marked as an asset with a name for people (``Anodised titanium``), a
description, the author, tags, a catalog (:data:`~.catalogs.CATALOGS`, written to the library's
``blender_assets.cats.txt`` by :mod:`.looks_library`) and a preview rendered on the
look-development shader ball (:mod:`.lookdev`).  Blender renders no previews in
background mode, so the preview is a small Cycles render whose pixels are written into
the material's preview image.

The node groups the add-on builds are never assets: older versions marked them (with a
fake user and the catalog :data:`LEGACY_CATALOG_ID`); :func:`release_node_groups` takes
that mark off the add-on's groups (recognised by their stamp) and leaves every other
data-block alone.
"""
from __future__ import annotations

import os
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ..backends import node_group as node_group_builder
from ..model.params import LayeredParams, ParameterError
from ..model.policy import plan_effects
from ..model.presets import ARTIST_PRESETS, PAPER_PRESETS, PRESETS, STACK_PRESETS, preset, preset_label
from . import lookdev, tempdirs, user_presets
from .catalogs import CATALOGS, ROOT_CATALOG
from .material_values import params_of, settings
from .own_nodes import shader_node
from .scene import render_to_file
from .stored_keys import LEGACY_PREVIEW_KEY, MATERIAL_KEY, SUBGROUP_KEY

AUTHOR = "Layered BRDF add-on (Granier & Heidrich 2003 model)"
LICENSE = "GPL-3.0-or-later"  # the add-on's licence and maintainer (blender_manifest.toml)
COPYRIGHT = "layered-brdf developers"
BASE_TAGS = ("Layered BRDF", "iridescent", "thin film")
PREVIEW_SIZE = 128  # pixels, the size of Blender's own asset previews
PREVIEW_SAMPLES = 8
PREVIEW_SIZE_RANGE = (8, 512)
PREVIEW_SAMPLES_RANGE = (1, 4096)


KIND_TAGS = {"artist": "artist look", "paper": "paper figure", "structural": "structural colour",
             "user": "user preset"}

# What versions before looks put on the add-on's node groups (taken off by release_node_groups).
LEGACY_CATALOG_ID = "4b0f3f52-5d0c-4c55-9d2e-6b8d1c1f7a21"
LEGACY_AUTHOR = "layered-brdf"

_queued: set[str] = set()
# The timer functions this module registered, kept across importlib.reload (which re-runs this
# file in the same module dict), so unregister() cancels a timer queued by an earlier import too.
_timers: list = globals().get("_timers", [])


# --- looks: names, catalogs, metadata ----------------------------------------------------------
def kind_of(identifier: str) -> str:
    """``"paper"``, ``"artist"``, ``"structural"`` (a film stack) or ``"user"``: the catalog of a preset
    identifier."""
    if identifier in PAPER_PRESETS:
        return "paper"
    if identifier in ARTIST_PRESETS:
        return "artist"
    if identifier in STACK_PRESETS:
        return "structural"
    if identifier.startswith(user_presets.USER_PREFIX):
        return "user"
    raise ParameterError("preset", identifier, "one of " + ", ".join(PRESETS) + " or 'user:<name>'")


def look_name(identifier: str) -> str:
    """The asset's name: the preset's name for people (a user preset's own name)."""
    if kind_of(identifier) == "user":
        return identifier[len(user_presets.USER_PREFIX):]
    return preset_label(identifier)


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def describe_look(name: str, params: LayeredParams, kind: str) -> str:
    """The asset description: what the look is, its main values and how to edit it."""
    plan = plan_effects(params)
    origin = {"paper": "a figure of Granier & Heidrich's layered RGB BRDF paper (2003)",
              "artist": "an artist preset of the Layered BRDF add-on",
              "structural": "a structural colour of the Layered BRDF add-on (a stack of films from the literature)",
              "user": "a Layered BRDF material"}[kind]
    indices = "/".join(_fmt(v) for v in (params.r1_r, params.r1_g, params.r1_b))
    layer = f"index {indices} (R/G/B)" if params.stack is None else params.stack.describe()
    return (f"{name}: {origin}. Layer {_fmt(params.d_min)}-{_fmt(params.d_max)} nm thick "
            f"({params.thickness_mode}), {layer}, ks {_fmt(params.ks)}, kd {_fmt(params.kd)}; "
            + "; ".join(plan.describe())
            + ". Drop it on an object, then edit it in Properties > Material > Layered BRDF.")


def look_tags(params: LayeredParams, kind: str) -> list[str]:
    tags = [*BASE_TAGS, KIND_TAGS[kind], f"{params.thickness_mode} thickness", f"{params.normal_mode} boundary"]
    if params.kd == 0.0:
        tags.append("no diffuse")
    if params.base_layer != "none":
        tags.append(f"{params.base_layer} base")
    return tags


def is_look(mat) -> bool:
    """Whether ``mat`` is an asset in one of the add-on's catalogs."""
    data = getattr(mat, "asset_data", None)
    return data is not None and data.catalog_id in {c.uuid for c in CATALOGS.values()} | {ROOT_CATALOG.uuid}


def identifier_of(mat) -> str | None:
    """The preset ``mat`` shows: its last loaded preset while it still has that preset's values,
    else a built-in preset with its values, else None."""
    values = params_of(mat)
    current = settings(mat).preset
    if current:
        try:
            kind_of(current)
            if _same_values(values, user_presets.preset_params(current)):
                return current
        except ParameterError:
            pass
    return next((name for name in PRESETS if _same_values(values, preset(name))), None)


def _same_values(a: LayeredParams, b: LayeredParams) -> bool:
    da, db = a.to_dict(), b.to_dict()
    for key, value in db.items():
        other = da.get(key)
        if isinstance(value, float):
            if not isinstance(other, float) or abs(other - value) > 1e-5 * max(1.0, abs(value)):
                return False
        elif other != value:
            return False
    return True


def mark_look(mat, identifier: str | None = None):
    """Mark ``mat`` (a layered material) as an asset with description, author, tags and catalog.

    ``identifier`` is the preset the material carries (the catalog follows it); by default the
    material's own preset while it still has that preset's values (:func:`identifier_of`), else
    the *User presets* catalog.  Idempotent: the tags are replaced, the preview is kept."""
    if shader_node(mat) is None or not mat.get(MATERIAL_KEY):
        raise ParameterError("material", mat.name, "a layered material (apply the Layered BRDF first)")
    if mat.library is not None:
        raise ParameterError("material", mat.name, f"a local material (it is linked from {mat.library.filepath})")
    if identifier is None:
        identifier = identifier_of(mat)
    kind = kind_of(identifier) if identifier is not None else "user"
    params = params_of(mat)
    if mat.asset_data is None:
        mat.asset_mark()
    data = mat.asset_data
    data.description = describe_look(mat.name, params, kind)
    data.author = AUTHOR
    data.license = LICENSE
    data.copyright = COPYRIGHT
    data.catalog_id = CATALOGS[kind].uuid
    while len(data.tags):
        data.tags.remove(data.tags[0])
    for tag in dict.fromkeys(look_tags(params, kind)):
        data.tags.new(tag, skip_if_exists=True)
    return mat


# --- previews ------------------------------------------------------------------------------------
def check_preview_options(size, samples) -> tuple[int, int]:
    """``size`` and ``samples`` as integers in their ranges; ParameterError naming the parameter."""
    for name, value, (lo, hi) in (("preview_size", size, PREVIEW_SIZE_RANGE),
                                  ("samples", samples, PREVIEW_SAMPLES_RANGE)):
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise ParameterError(name, value, f"an integer in [{lo}, {hi}]")
    return size, samples


def _denoise(scene) -> None:
    """Few samples and Open Image Denoise (when this Blender has it): clean previews, quickly."""
    import _cycles

    if getattr(_cycles, "with_openimagedenoise", False):
        scene.cycles.use_denoising = True
        scene.cycles.denoiser = "OPENIMAGEDENOISE"
        scene.cycles.denoising_use_gpu = False


def render_previews(materials, size: int | None = None, samples: int | None = None,
                    hdri: str | None = None, done=None, guard=None) -> list[float]:
    """Render each of ``materials`` on the look-development shader ball (under a bundled HDRI,
    transparent background, denoised) and write the pixels into its preview.  One scene serves them all
    and is removed afterwards.  ``done(material)`` is called after each.  Returns the seconds
    each render took.

    The renders go to a folder of the add-on's own (``layered_brdf_preview_PID_*``, swept when
    its process died).  With an interrupt ``guard``
    (:class:`~layered_brdf_addon.io.staging.InterruptGuard`, the command line's), a signal
    stops the renders at once and the folder is removed."""
    size, samples = check_preview_options(PREVIEW_SIZE if size is None else size,
                                          PREVIEW_SAMPLES if samples is None else samples)
    materials = list(materials)
    if not materials:
        return []
    scene, ball = lookdev.build_lookdev_scene(size=size, samples=samples, hdri=hdri)
    seconds = []
    try:
        r = scene.render
        r.film_transparent = True  # the preview shows the ball (and its pedestal) on a clear background
        _denoise(scene)
        r.image_settings.file_format = "PNG"
        r.image_settings.color_mode = "RGBA"
        r.image_settings.color_depth = "8"
        slot = ball.material_slots[0]
        with tempdirs.owned_tempdir("preview", guard) as tmp:
            path = os.path.join(tmp, "preview.png")
            for mat in materials:
                if guard is not None:
                    guard.check()
                slot.material = mat
                node = shader_node(mat)
                # The OSL backend's materials need Cycles' OSL shading (on the CPU, as the scene renders).
                scene.cycles.shading_system = node is not None and node.bl_idname == "ShaderNodeScript"
                t0 = time.perf_counter()
                render_to_file(path, scene, guard)
                image = bpy.data.images.load(path, check_existing=False)
                try:
                    pixels = np.empty(size * size * 4, dtype=np.float32)
                    image.pixels.foreach_get(pixels)
                finally:
                    bpy.data.images.remove(image)
                preview = mat.preview_ensure()
                preview.image_size = (size, size)
                preview.image_pixels_float.foreach_set(pixels)
                seconds.append(time.perf_counter() - t0)
                if done is not None:
                    done(mat)
        slot.material = None
    finally:
        lookdev.remove_scene(scene)
    return seconds


def publish(mat, preview: bool = True, identifier: str | None = None, size: int | None = None,
            samples: int | None = None):
    """Mark ``mat`` as a look (:func:`mark_look`) and render its preview now (``preview``; when a
    render is running it is queued for when Blender is idle, interactive sessions only)."""
    if size is not None or samples is not None:
        check_preview_options(PREVIEW_SIZE if size is None else size, PREVIEW_SAMPLES if samples is None else samples)
    mark_look(mat, identifier)
    if preview and not bpy.app.is_job_running("RENDER"):
        render_previews([mat], size, samples)
    else:
        queue_preview(mat)
    return mat


def refresh(mat, preview: bool) -> None:
    """After ``mat`` was (re)built: its preview follows its new values when it is a look
    (rendered now with ``preview``, else queued), and older versions' asset marks come off
    the add-on's node groups."""
    release_node_groups()
    if is_look(mat) and mat.library is None:
        publish(mat, preview=preview, identifier=identifier_of(mat))


def queue_preview(mat) -> None:
    """Render ``mat``'s preview when Blender is idle (interactive sessions only)."""
    if bpy.app.background:
        return
    _queued.add(mat.name)
    if not bpy.app.timers.is_registered(_render_queued):
        bpy.app.timers.register(_render_queued, first_interval=0.5)
        if _render_queued not in _timers:
            _timers.append(_render_queued)


def _render_queued():
    if bpy.app.is_job_running("RENDER"):
        return 2.0
    mats = [bpy.data.materials.get(name) for name in sorted(_queued)]
    _queued.clear()
    mats = [m for m in mats if m is not None and m.library is None and is_look(m)]
    if mats:
        render_previews(mats)
    return None


def cancel_queued() -> None:
    """Forget the queued previews and cancel every timer this module (or an earlier import of it) queued."""
    _queued.clear()
    for fn in [*_timers, _render_queued]:
        if bpy.app.timers.is_registered(fn):
            bpy.app.timers.unregister(fn)
    _timers.clear()


# --- the add-on's node groups are not assets -----------------------------------------------------
def group_of(mat):
    """The node group behind ``mat``'s layered shader (None with the OSL backend)."""
    node = shader_node(mat)
    if node is None or node.bl_idname != "ShaderNodeGroup":
        return None
    return node.node_tree


def _own_group(group) -> bool:
    return group.library is None and (group.get(node_group_builder.STAMP_KEY) is not None
                                      or group.get(SUBGROUP_KEY) is not None)


def _legacy_mark(group) -> bool:
    data = group.asset_data
    return data is not None and (data.catalog_id == LEGACY_CATALOG_ID or data.author == LEGACY_AUTHOR)


def release_node_groups() -> list[str]:
    """Take the asset mark (and the fake user it brought) that older versions put on the
    add-on's node groups off them.  Only local groups stamped by the add-on and marked the way
    it marked them are changed; a mark the artist made is kept.  Returns the names released."""
    released = []
    for group in bpy.data.node_groups:
        if not _own_group(group):
            continue
        if _legacy_mark(group):
            group.asset_clear()
            group.use_fake_user = False
            released.append(group.name)
        if LEGACY_PREVIEW_KEY in group:
            del group[LEGACY_PREVIEW_KEY]
    return released


@persistent
def on_version_update(*_args):
    """A file just loaded: its add-on node groups marked as assets by an older version are released."""
    release_node_groups()

