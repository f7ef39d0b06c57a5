"""The extension package: built and validated with Blender's own tool, installed into a
throw-away extensions repository, enabled, used, disabled.

Installing runs in a subprocess whose Blender user directories (BLENDER_USER_RESOURCES,
read when bpy is imported) point into the test's temporary folder.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXT_ID = "layered_brdf"
REPO = "user_default"  # the default local repository of a fresh user directory
PACKAGE = f"bl_ext.{REPO}.{EXT_ID}"
PRESET = "fig4_parallel"


@pytest.fixture(scope="module", autouse=True)
def fresh_blender():
    from layered_brdf_addon.blender.scene import reset_blender

    reset_blender()


def _manifest():
    import tomllib

    return tomllib.loads((ROOT / "blender_manifest.toml").read_text())


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    """The zip built by ``make extension`` (which also validates it)."""
    if shutil.which("make") is None:
        pytest.fail("make is needed to build the extension (make extension)")
    out = tmp_path_factory.mktemp("dist") / f"{EXT_ID}-{_manifest()['version']}.zip"
    proc = subprocess.run(["make", "--no-print-directory", "extension", "STAMP=", f"PY={sys.executable}",
                           f"EXT_ZIP={out}"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "Success parsing TOML" in proc.stdout  # blender_ext.py validate
    return out


def test_manifest():
    m = _manifest()
    assert m["schema_version"] == "1.0.0" and m["id"] == EXT_ID and m["type"] == "add-on"
    assert m["blender_version_min"] == "5.0.0"
    assert m["license"] == ["SPDX:GPL-3.0-or-later"]
    assert m["tags"] and len(m["tagline"]) <= 64 and not m["tagline"].endswith(".")
    assert "permissions" not in m  # presets go to the extension's own user directory


def test_package_holds_the_addon_and_nothing_else(package):
    tool = _blender_ext()
    proc = subprocess.run([sys.executable, str(tool), "validate", str(package), "--valid-tags", str(_tags())],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    names = zipfile.ZipFile(package).namelist()
    tops = {n.split("/")[0] for n in names}
    assert tops == {"__init__.py", "blender_manifest.toml", "layered_brdf_addon", "osl"}, tops
    assert "osl/layered_brdf.osl" in names
    for required in ("layered_brdf_addon/blender/registration.py", "layered_brdf_addon/model/params.py",
                     "layered_brdf_addon/backends/node_group.py"):
        assert required in names
    assert not [n for n in names if "__pycache__" in n or n.endswith((".pyc", ".blend1"))]
    in_tree = {str(p.relative_to(ROOT)) for d in ("layered_brdf_addon",)
               for p in (ROOT / d).rglob("*.py") if "__pycache__" not in p.parts}
    assert in_tree <= set(names)


def _blender_ext() -> Path:
    from layered_brdf_addon.blender.paths import extension_tool

    return extension_tool()


def _tags() -> Path:
    from layered_brdf_addon.blender.paths import extension_tags

    return extension_tags()


@pytest.mark.slow
def test_install_enable_use_and_disable_in_a_throwaway_repository(package, tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("BLENDER_")}
    env["BLENDER_USER_RESOURCES"] = str(user)
    out = tmp_path / "result.json"
    proc = subprocess.run([sys.executable, __file__, str(package), str(out)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    r = json.loads(out.read_text())
    assert r["user_extensions"].startswith(str(user))
    assert r["module_file"].startswith(str(user / "extensions" / REPO / EXT_ID))
    assert r["enabled"] and r["registered_while_enabled"]
    assert r["material_preset"] == PRESET and r["build"].startswith("nodes:")
    assert r["asset"]
    assert r["preset_file"].startswith(str(user / "extensions" / ".user" / REPO / EXT_ID / "presets"))
    assert r["finite"] and r["peak_over_median"] > 4.0
    assert r["peak_offset_px"] <= 2, r
    assert r["leftovers"] == [], r["leftovers"]


# Fit to Render in a Blender whose Python has none of the project's other dependencies: the
# installed extension must bring what the fit needs (it needs numpy alone).
NOT_IN_BLENDER = ("scipy", "colour", "OpenEXR", "OpenImageIO", "tmm", "tqdm", "matplotlib", "dask", "PIL",
                  "layered_brdf_reference", "layered_brdf_addon")
FIT_TRUTH = {"d_min": 260.0, "d_max": 430.0}


@pytest.mark.slow
def test_the_installed_extension_fits_to_a_render_without_scipy_or_colour_science(package, tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("BLENDER_")}
    env["BLENDER_USER_RESOURCES"] = str(user)
    out = tmp_path / "result.json"
    proc = subprocess.run([sys.executable, __file__, "fit", str(package), str(out)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    r = json.loads(out.read_text())
    assert r["blocked_importable"] == [], r
    assert r["result"] == ["FINISHED"], r
    assert r["module_file"].startswith(str(user / "extensions" / REPO / EXT_ID))
    assert r["layered"] and r["build"].startswith("nodes:")
    # One sun shows the film's mean thickness (its order), less so how far it spreads.
    assert r["fitted"]["d_min"] + r["fitted"]["d_max"] == pytest.approx(sum(FIT_TRUTH.values()), rel=0.1), r
    assert r["fitted"] != r["start"]
    assert r["loaded"] == [], r["loaded"]


def _fit_child(zip_path: str, out: str) -> None:
    """Installs the zip, renders a target with it (the files of ``layered-brdf render``), and fits the
    active sphere's material to it with *Fit to Render...*, in a Python that cannot import SciPy,
    colour-science, OpenEXR or the checkout's own packages."""
    for name in NOT_IN_BLENDER:
        sys.modules[name] = None  # import raises ImportError, as where it is not installed
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != ROOT]
    import importlib.util

    import bpy

    r = {"blocked_importable": [n for n in NOT_IN_BLENDER if sys.modules.get(n) is not None]}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo=REPO, enable_on_install=True)
    ext = sys.modules[PACKAGE]
    r["module_file"] = ext.__file__

    def own(name):
        return importlib.import_module(f"{PACKAGE}.layered_brdf_addon.{name}")

    scene, sidecar, model = own("blender.scene"), own("io.sidecar"), own("model")
    values, fit_operator = own("blender.material_values"), own("blender.fit_operator")
    sun = model.Sun(direction=(0.3, -0.55, 0.78), strength=3.0)
    camera = scene.camera_for(1, 48)
    [sphere] = scene.build_scene(scene.SceneSpec(camera=camera, sun=sun))
    bpy.context.view_layer.objects.active = sphere
    bpy.ops.layered_brdf.load_preset(preset="oil_slick")
    mat = sphere.active_material
    truth = values.params_of(mat).replace(thickness_mode="height", **FIT_TRUTH)
    own("blender.sync").apply_to_object(sphere, truth)
    stem = Path(out).with_name("target")
    scene.render_to_exr(stem.with_suffix(".exr"))
    sidecar.write_json(stem.with_suffix(".json"), {
        "format": sidecar.SIDECAR_FORMAT, "version": 1, "scene": "reference", "params": truth.to_dict(),
        "camera": sidecar.camera_to_dict(camera), "sun": sidecar.sun_to_dict(sun), "centers": [[0.0, 0.0, 0.0]],
        "outputs": {"exr": stem.with_suffix(".exr"), "json": stem.with_suffix(".json")}})

    start = truth.replace(d_min=150.0, d_max=600.0)
    own("blender.sync").apply_to_object(sphere, start)
    r["start"] = {"d_min": start.d_min, "d_max": start.d_max}
    fit_operator.FIT_OPTIONS = {"starts": 1, "steps_per_start": 15, "vary": ("d_min", "d_max")}
    r["result"] = sorted(bpy.ops.layered_brdf.fit_to_render(source="RENDER", filepath=str(stem.with_suffix(".json")),
                                                           start="CURRENT"))
    mat = sphere.active_material
    fitted = values.params_of(mat)
    r["fitted"] = {"d_min": fitted.d_min, "d_max": fitted.d_max}
    r["layered"] = values.is_layered(mat)
    r["build"] = mat["layered_brdf_build"]
    r["loaded"] = sorted(n for n in NOT_IN_BLENDER if sys.modules.get(n) is not None)
    Path(out).write_text(json.dumps(r))


# --- the subprocess --------------------------------------------------------------------------
def _child(zip_path: str, out: str) -> None:
    import importlib

    import bpy  # reads BLENDER_USER_RESOURCES
    import numpy as np

    r = {"user_extensions": bpy.utils.user_resource("EXTENSIONS")}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo=REPO, enable_on_install=True)
    r["enabled"] = PACKAGE in bpy.context.preferences.addons
    ext = sys.modules[PACKAGE]
    r["module_file"] = ext.__file__
    r["registered_while_enabled"] = hasattr(bpy.types, "LAYERED_BRDF_OT_apply") and \
        hasattr(bpy.types.Material, "layered_brdf_settings")

    # The installed package's own modules, not the checkout's.
    ext_scene = importlib.import_module(PACKAGE + ".layered_brdf_addon.blender.scene")
    model = importlib.import_module(PACKAGE + ".layered_brdf_addon.model")
    closures = importlib.import_module("layered_brdf_reference.closures")  # the test oracle is not shipped
    cam = ext_scene.camera_for(1, 64)
    sun = model.Sun(direction=(0.0, -np.cos(np.radians(40.0)), np.sin(np.radians(40.0))), strength=1.0)
    [sphere] = ext_scene.build_scene(ext_scene.SceneSpec(camera=cam, sun=sun))
    bpy.context.view_layer.objects.active = sphere
    bpy.ops.layered_brdf.load_preset(preset=PRESET)
    mat = sphere.active_material
    r["material_preset"] = mat.layered_brdf_settings.preset
    r["build"] = mat["layered_brdf_build"]
    group = mat.node_tree.nodes["Layered BRDF"].node_tree
    # A look is a material asset with its preview; the node group is never an asset.
    bpy.ops.layered_brdf.mark_asset()
    r["asset"] = mat.asset_data is not None and mat.preview is not None and group.asset_data is None
    bpy.ops.layered_brdf.save_preset(name="Extension test")
    presets_dir = bpy.utils.extension_path_user(PACKAGE, path="presets")
    r["preset_file"] = os.path.join(presets_dir, "Extension test.json")
    assert os.path.isfile(r["preset_file"])
    bpy.ops.layered_brdf.load_preset(preset="user:Extension test")

    passes = ext_scene.render_passes()
    beauty = passes.beauty
    r["finite"] = bool(np.all(np.isfinite(beauty)))
    expected, geo = model.render_spheres([model.preset(PRESET)], cam, sun, thickness=passes.thickness,
                                         shading=closures.closure_shading)
    lum, lum_expected = beauty.sum(-1), expected.sum(-1)
    peak = np.array(np.unravel_index(lum.argmax(), lum.shape))
    peak_expected = np.array(np.unravel_index(lum_expected.argmax(), lum_expected.shape))
    r["peak_offset_px"] = int(np.abs(peak - peak_expected).max())
    r["peak_over_median"] = float(lum.max() / np.median(lum[geo.mask]))

    bpy.ops.preferences.addon_disable(module=PACKAGE)
    left = []
    if PACKAGE in bpy.context.preferences.addons:
        left.append("still enabled")
    for name in ("LAYERED_BRDF_OT_apply", "LAYERED_BRDF_OT_load_preset", "LAYERED_BRDF_PT_material",
                 "LAYERED_BRDF_MT_presets", "LAYERED_BRDF_PT_params_layer"):
        if hasattr(bpy.types, name):
            left.append(name)
    if hasattr(bpy.types.Material, "layered_brdf_settings"):
        left.append("Material.layered_brdf_settings")
    for kind in ("depsgraph_update_post", "load_post", "frame_change_post", "save_pre"):
        for f in getattr(bpy.app.handlers, kind):
            if getattr(f, "__module__", "").startswith(PACKAGE):
                left.append(f"{kind}: {f.__qualname__}")
    left += [c.__name__ for c in bpy.types.PropertyGroup.__subclasses__() if c.__name__ == "LayeredBRDFSettings"
             and c.is_registered]
    r["leftovers"] = left
    Path(out).write_text(json.dumps(r))


if __name__ == "__main__":
    if sys.argv[1] == "fit":
        _fit_child(sys.argv[2], sys.argv[3])
    else:
        _child(sys.argv[1], sys.argv[2])
