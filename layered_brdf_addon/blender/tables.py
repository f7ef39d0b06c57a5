"""A material's baked tables in the .blend: float images packed in the file, stamped as the add-on's,
read by its own copy of the node group (:mod:`..model.shading.tables`).

A group built for tables belongs to the materials whose values it was baked for (usually one): its
stamp :data:`DIGEST_KEY` is the :func:`~..model.table_bake.table_digest` of those values.  When a value
changes, the tables are rebaked in place if nothing else uses them (a slider drag), else the material
gets a copy of the group with tables of its own (a copied material keeps its original's untouched).
Each image records a checksum of its texels, so that a table whose pixels are not what was baked
(after an undo, say) is found and baked again.
"""
from __future__ import annotations

import hashlib
import inspect
import json
import zlib

import bpy
import numpy as np

from ..backends import node_group as node_group_builder
from ..model import ops_numpy, table_bake
from ..model.params import LayeredParams
from ..model.plan import EffectPlan
from ..model.table_bake import spline_coefficients, table_digest, table_layout
from ..model.table_check import checked_bake
from . import bake_jobs
from .stored_keys import settings_record

DIGEST_KEY = "layered_brdf_tables"  # on a group built for tables and on its images: the values they were baked for
IMAGE_SLOT_KEY = "layered_brdf_table_slot"  # on an image: which image of the tables it is
CHECKSUM_KEY = "layered_brdf_table_crc"  # on an image: checksum of the texels baked into it
SETTINGS_KEY = "layered_brdf_table_settings"  # on a group or OSL text holding tables: the settings baked (JSON)
IMAGE_PREFIX = ".Layered BRDF table"  # a leading "." keeps the images out of Blender's image menus


_BAKE_STAMP = None


def _bake_stamp() -> str:
    """Digest of the code that bakes (the bake and the numpy ops it runs the program on; the program itself
    is in the node group's stamp): a change to it makes every table stale."""
    global _BAKE_STAMP
    if _BAKE_STAMP is None:
        h = hashlib.sha1()
        for module in (table_bake, ops_numpy):
            h.update(node_group_builder.code_without_docs(inspect.getsource(module)).encode())
        _BAKE_STAMP = h.hexdigest()[:8]
    return _BAKE_STAMP


def wanted_digest(params: LayeredParams, plan: EffectPlan) -> str:
    """The stamp of tables baked for ``params`` and ``plan`` by this version of the program and of the bake."""
    return f"{node_group_builder.build_stamp()}:{_bake_stamp()}:{table_digest(params, plan)}"


def _checksum(texels: np.ndarray) -> str:
    return f"{zlib.crc32(np.ascontiguousarray(texels, dtype=np.float32).tobytes()):08x}"


def _pixels(image) -> np.ndarray:
    out = np.empty(image.size[0] * image.size[1] * 4, dtype=np.float32)
    image.pixels.foreach_get(out)
    return out.reshape(image.size[1], image.size[0], 4)


def image_intact(image, digest: str, slot: int, shape: tuple[int, int]) -> bool:
    """Whether ``image`` is the table ``slot`` of tables stamped ``digest``, of ``shape`` (H, W)."""
    return image is not None and image.get(DIGEST_KEY) == digest and image.get(IMAGE_SLOT_KEY) == slot and \
        tuple(image.size) == (shape[1], shape[0]) and image.is_float


def pixels_intact(image) -> bool:
    """Whether the texels of ``image`` are those its checksum records (read back: a few ms)."""
    return image.get(CHECKSUM_KEY) == _checksum(_pixels(image))


def _shared_image(readers):
    """The image every one of ``readers`` (a table's Image Texture nodes) reads, or None (no readers, no
    image, or readers that disagree)."""
    images = {n.image for n in readers}
    return images.pop() if len(images) == 1 else None


def tables_current(group, params: LayeredParams, plan: EffectPlan, check_pixels: bool = False) -> bool:
    """Whether ``group`` reads tables baked for ``params`` and ``plan``, each image in place and stamped
    (and, with ``check_pixels``, holding the texels baked into it)."""
    if group is None or group.get(DIGEST_KEY) != wanted_digest(params, plan):
        return False
    layout = table_layout(params, plan)
    if group.get(node_group_builder.TABLE_SHAPE_KEY) != node_group_builder.layout_record(layout):
        return False
    nodes = node_group_builder.table_nodes(group)
    digest = group[DIGEST_KEY]
    for k in range(layout.images):
        image = _shared_image(nodes.get(k, []))
        if not image_intact(image, digest, k, (layout.height, layout.image_width)):
            return False
        if check_pixels and not pixels_intact(image):
            return False
    return True


def _new_image(name: str, width: int, height: int):
    image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.alpha_mode = "CHANNEL_PACKED"  # the alpha channel holds a value of its own, not coverage
    image.file_format = "OPEN_EXR"  # packed losslessly, in full float
    return image


def _write(group, params: LayeredParams, plan: EffectPlan) -> None:
    """Bake ``params``'s tables into ``group``'s images (made where missing or of another size, or used
    elsewhere), pack them and stamp images and group."""
    layout, texels, _ = checked_bake(params, plan)  # the bake its plan was checked with
    texels = spline_coefficients(texels, layout)  # what Cubic interpolation reads back as the baked values
    digest = wanted_digest(params, plan)
    nodes = node_group_builder.table_nodes(group)
    for k in range(layout.images):
        readers = nodes[k]
        image = _shared_image(readers)
        if image is None or image.library is not None or image.users > len(readers) or DIGEST_KEY not in image or \
                tuple(image.size) != (layout.image_width, layout.height) or not image.is_float:
            image = _new_image(f"{IMAGE_PREFIX} {digest[-8:]} {k}", layout.image_width, layout.height)
            for node in readers:
                node.image = image
        else:
            image.name = f"{IMAGE_PREFIX} {digest[-8:]} {k}"
            image.colorspace_settings.name = "Non-Color"
            image.alpha_mode = "CHANNEL_PACKED"
        image.pixels.foreach_set(texels[k].ravel())
        image.update()
        image.pack()
        image[DIGEST_KEY] = digest
        image[IMAGE_SLOT_KEY] = k
        image[CHECKSUM_KEY] = _checksum(texels[k])
    group[DIGEST_KEY] = digest
    group[SETTINGS_KEY] = settings_json(params)


def settings_json(params: LayeredParams) -> str:
    """What a group or an OSL text holding tables records of the settings they were baked with."""
    return json.dumps(settings_record(params), sort_keys=True)


def baked_settings(source) -> dict | None:
    """The settings (the parameters that are not sockets) the tables of ``source`` (a group or an OSL text)
    were baked with, or None."""
    try:
        record = json.loads(source.get(SETTINGS_KEY, ""))
    except (TypeError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def _shared(group) -> bool:
    """Whether another material (or a fake user) uses ``group`` besides the one node being updated, or it
    is linked from a library (not ours to change)."""
    return group.users - 1 > 0 or group.library is not None


def _existing(params: LayeredParams, plan: EffectPlan):
    """A local group already reading tables baked for these values, if any."""
    digest = wanted_digest(params, plan)
    for group in bpy.data.node_groups:
        if group.library is None and group.get(DIGEST_KEY) == digest and \
                node_group_builder.is_current(group, plan) and tables_current(group, params, plan):
            return group
    return None


def ensure_tables(node, params: LayeredParams, plan: EffectPlan, check_pixels: bool = False) -> bool:
    """Give the shader ``node`` (a group node running the group for ``plan``) tables baked for ``params``:
    kept when current, rebaked in place when only this node uses them, else another group (one already
    baked for these values, or a copy of this one with tables of its own).  A stack's tables are baked beside
    the interface (:mod:`.bake_jobs`), the node keeping what it had until they are done.  Returns True when
    something was baked or the node's group changed."""
    group = node.node_tree
    if tables_current(group, params, plan, check_pixels):
        return False
    if bake_jobs.deferring(plan) and bake_jobs.start(params, plan, str(node.as_pointer())):
        return False  # baked beside the interface: the node takes its tables when they are done
    layout = table_layout(params, plan)
    # A group whose Image Texture nodes are not all there (an artist deleted one) counts as of another shape.
    same_shape = group.get(node_group_builder.TABLE_SHAPE_KEY) == node_group_builder.layout_record(layout) and \
        node_group_builder.table_readers_intact(group, layout)
    if same_shape and not _shared(group):
        _write(group, params, plan)
        return True
    found = _existing(params, plan)
    if found is not None:
        node.node_tree = found
        return True
    fresh = group.copy() if same_shape else bpy.data.node_groups.new(group.name, "ShaderNodeTree")
    if not same_shape:
        node_group_builder.build_into(fresh, plan, layout)
    for readers in node_group_builder.table_nodes(fresh).values():
        for n in readers:
            n.image = None  # the copy's tables are its own
    name = group.name
    _write(fresh, params, plan)
    node.node_tree = fresh
    if group.users == 0 and group.library is None:
        # Nothing else used the group it replaces (another number of rows: a drag of Thickness Max):
        # the new one takes its name, and the old one's images go with the add-on's other unused data.
        bpy.data.node_groups.remove(group)
    fresh.name = name
    return True


def unused_tables(among=None) -> list:
    """The add-on's table images (stamped) that nothing uses any more, not even a fake user (``among``: only
    those whose pointers it holds)."""
    return [image for image in bpy.data.images if image.library is None and DIGEST_KEY in image
            and image.users == 0 and (among is None or image.as_pointer() in among)]
