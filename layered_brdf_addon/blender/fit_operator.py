"""*Fit to Render...*: the active object's layered material fitted to a target, in the panel.

The target is a reference-sphere render (its sidecar ``.json``, :mod:`.sidecar_views`)
or a Principled BSDF material of the file (rendered on the reference sphere under a few
suns, :mod:`.principled_target`).  Rendering happens on the main thread (Blender's data is
not to be touched from another); the fit (:func:`..fit.solve.fit`, seconds to a minute)
runs in a background thread while the operator is modal: Blender's progress indicator and
the status bar follow it, Esc or a right click stops it with nothing changed, and its result
is applied as loading a preset applies values (one undo step).  Without a window (a script,
the tests) the operator fits at once.

:func:`fit_material_to` is the whole job as one plain function: fit, then apply.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Callable, Sequence

import bpy
from bpy.props import EnumProperty, IntProperty, StringProperty
from bpy.types import Operator

from ..fit import solve, structures
from ..fit.environment import DEFAULT_HDRIS
from ..fit.free import default_vary
from ..fit.solve import FitCancelled
from ..fit.targets import SphereTarget, TargetError
from ..model.params import LayeredParams, ParameterError
from ..model.policy import check_backend, render_plan
from ..model.presets import ARTIST_PRESETS, PAPER_PRESETS, preset_label
from . import sync, user_presets
from .animation import animated_parameters
from .lookdev import hdri_path
from .material_values import is_layered, layered_material_of, params_of, settings
from .own_nodes import shader_node
from .principled_target import principled_materials, principled_views_of, start_for, surface_of, uniform_film
from .sidecar_views import sidecar_views
from .targets import object_problem, takes_layered_material

# The fit's options (:func:`..fit.solve.fit`): the start and three orders of the thickness
# scan, 40 optimiser steps from each.
FIT_OPTIONS = {"starts": 3, "steps_per_start": 40}
TIMER_SECONDS = 0.2
CURRENT = "CURRENT"  # start from the material's own values
CHOOSE = "CHOOSE"  # no start: the fit chooses the structure (fit/structures.py), as ``layered-brdf fit`` without --start
# The progress bar's share of each stage of a selection (fit/structures.py): screening the structures,
# fitting the finalists from their screened starts, from the scan's other orders, a noise thickness.
STAGE_SHARES = {"screen": 0.5, "fit": 0.2, "refine": 0.2, "noise": 0.1}
STAGE_WORDS = {"screen": "screening structure", "fit": "fitting finalist", "refine": "refining finalist",
               "noise": "trying a noise thickness"}
NO_MATERIAL = "__none__"  # the file holds no Principled material


def sphere_target(target_views, uniform_film: bool = False):
    """The views as a :class:`~..fit.targets.SphereTarget` (TargetError says why they cannot be one);
    ``uniform_film``: they show a film of one thickness (a Principled material's), fitted as one."""
    return SphereTarget(list(target_views), uniform_film=uniform_film)


def expected_evaluations(start: LayeredParams, starts: int = 3, steps_per_start: int = 40,
                         vary: Sequence[str] | None = None) -> int:
    """About how many model evaluations a fit makes at most: the thickness scan, then per start
    ``steps_per_start`` steps of one evaluation per free parameter and one more (for the
    progress bar; a fit that converges early ends sooner)."""
    free = len(default_vary(start) if vary is None else vary)
    scan = solve.THICKNESS_SCAN_STEPS * (len(getattr(solve, "SCAN_HALF_WIDTHS", ())) + 1)
    return scan + (starts + 1) * steps_per_start * (free + 1)


# ---------------------------------------------------------------------------
# applying the result
def layered_target(target):
    """``target`` checked as what a fit may change: a local layered material, or an object that
    takes one (the slot gets the layered material as *Apply* gives it); ParameterError else."""
    if isinstance(target, bpy.types.Object):
        problem = object_problem(target)
        if problem is not None:
            raise ParameterError("object", target.name, problem)
        return target
    if isinstance(target, bpy.types.Material):
        if not is_layered(target):
            raise ParameterError("material", target.name, "a layered material (or the object to give one)")
        sync.desired(target)  # local, and a shader node the values can go into
        return target
    raise ParameterError("material", repr(target), "a layered material or an object")


def apply_fitted(target, params: LayeredParams):
    """Give ``target`` (see :func:`layered_target`) the fitted ``params`` as loading a preset
    does (:func:`.sync.apply_to_object`): settings adopted and written, the backend
    kept, the effects of animated sockets kept, a look's preview refreshed.  Returns the material."""
    target = layered_target(target)
    if isinstance(target, bpy.types.Object):
        mat = sync.apply_to_object(target, params)
    else:
        sync.adopt(target)
        backend = settings(target).backend
        params = params.validate()
        check_backend(backend, params.lobe)
        plan = render_plan(params, animated_parameters(target), backend)
        mat = sync.apply(target, params, backend, plan, preview=True)
    settings(mat).preset = ""  # fitted values are no preset's
    return mat


def start_of(target) -> LayeredParams | None:
    """The values of ``target``'s layered material (an object's active one), or None."""
    mat = layered_material_of(target) if isinstance(target, bpy.types.Object) else target
    if is_layered(mat) and shader_node(mat) is not None:
        return params_of(mat)
    return None


# ---------------------------------------------------------------------------
def run_fit(target_views, start: LayeredParams, *, progress: Callable[[int], None] | None = None,
            should_stop: Callable[[], bool] | None = None, uniform_film: bool = False, **options):
    """Fit ``start`` to the views (``options``: :func:`..fit.solve.fit`'s, over
    :data:`FIT_OPTIONS`; ``uniform_film``: a film of one thickness, :func:`sphere_target`); the
    :class:`~..fit.solve.FitResult`.  Touches no Blender data: it may run in any thread."""
    return solve.fit(sphere_target(target_views, uniform_film), start.validate(), progress=progress,
                     should_stop=should_stop, **{**FIT_OPTIONS, **options})


def run_selection(target_views, *, progress: Callable[[str, int], None] | None = None,
                  should_stop: Callable[[], bool] | None = None, try_noise: bool = False,
                  surface: str | None = None, uniform_film: bool = False, **options):
    """The fit with no start: every structure screened, the best fitted in full
    (:func:`..fit.structures.select_and_fit`, the thickness by height as the command line's, or for a
    render a noise pattern where height stays far: ``try_noise``; for a Principled material the
    structures of its ``surface`` and of a ``uniform_film``, :func:`..fit.structures.for_material`); its
    :class:`~..fit.structures.Selection`.  Touches no Blender data: it may run in any thread."""
    options = {**FIT_OPTIONS, **options}
    pool = structures.structure_pool(surface=surface, uniform_film=uniform_film)
    return structures.select_and_fit(sphere_target(target_views, uniform_film), pool, options.pop("vary", None),
                                     progress=progress, should_stop=should_stop, try_noise=try_noise, **options)


def selection_share(stage: str) -> float:
    """How far a selection is at ``stage`` ("screen K/N", "fit K/N", "refine K/N", "noise 1/1"): each
    kind of stage fills its share of the bar (:data:`STAGE_SHARES`, in that order) in N equal steps."""
    kind, _, count = stage.partition(" ")
    done, _, total = count.partition("/")
    try:
        share = (int(done) - 1) / max(int(total), 1)
    except ValueError:
        return 0.0
    if kind not in STAGE_SHARES:
        return 0.0
    kinds = list(STAGE_SHARES)
    before = sum(STAGE_SHARES[k] for k in kinds[:kinds.index(kind)])
    return before + STAGE_SHARES[kind] * share


def stage_words(stage: str) -> str:
    """``stage`` in the status bar's words ("screen 3/45" -> "screening structure 3/45")."""
    kind, _, count = stage.partition(" ")
    return f"{STAGE_WORDS.get(kind, kind)} {count}".strip()


def fit_material_to(material, target_views: Sequence, start: LayeredParams | None = None, *,
                    progress: Callable[[int], None] | None = None, should_stop: Callable[[], bool] | None = None,
                    **options):
    """Fit ``material`` (a layered material, or an object whose slot gets one) to
    ``target_views`` (:class:`~..fit.targets.SphereView`) from ``start`` (default the
    material's own values) and apply the result; returns the
    :class:`~..fit.solve.FitResult`.

    ``progress(evaluations)`` and ``should_stop()`` are passed to the fit; a stop raises
    :class:`~..fit.solve.FitCancelled` with nothing changed, as does any error before the
    result is applied.  ``options``: the fit's ``vary``, ``starts`` and ``steps_per_start``.
    """
    target = layered_target(material)
    start = start if start is not None else start_of(target)
    if start is None:
        raise ParameterError("start", None, "parameters to start from (the object has no layered material yet)")
    result = run_fit(target_views, start, progress=progress, should_stop=should_stop, **options)
    apply_fitted(target, result.params)
    return result


def fit_report(result, name: str) -> str:
    return (f"'{name}' fitted: mean CIEDE2000 {result.mean_delta_e:.2f} "
            f"({result.evaluations} evaluations, {result.seconds:.0f} s)")


# ---------------------------------------------------------------------------
@dataclass
class FitJob:
    """A fit running in a background thread; the main thread reads its progress and may stop it."""

    target_views: list
    start: LayeredParams | None  # None: the fit chooses the structure
    options: dict = field(default_factory=dict)
    evaluations: int = 0
    stage: str = ""  # with no start: "screen K/N" or "fit K/N"
    try_noise: bool = False  # with no start: a noise thickness may be chosen (a render's target)
    surface: str | None = None  # with no start: what a Principled target's material says its surface is
    uniform_film: bool = False  # a Principled target's film has one thickness: fitted as one
    result: object = None
    error: BaseException | None = None

    def __post_init__(self):
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="Layered BRDF fit", daemon=True)

    def _count(self, evaluations: int) -> None:
        self.evaluations = evaluations

    def _hear(self, stage: str, evaluations: int) -> None:
        self.stage, self.evaluations = stage, evaluations

    def _run(self) -> None:
        try:
            if self.start is None:
                self.result = run_selection(self.target_views, progress=self._hear, should_stop=self._stop.is_set,
                                            try_noise=self.try_noise, surface=self.surface,
                                            uniform_film=self.uniform_film, **self.options).result
            else:
                self.result = run_fit(self.target_views, self.start, progress=self._count,
                                      should_stop=self._stop.is_set, uniform_film=self.uniform_film, **self.options)
        except BaseException as e:  # handed to the main thread, which reports it
            self.error = e

    def begin(self) -> "FitJob":
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()

    @property
    def stopping(self) -> bool:
        return self._stop.is_set()

    @property
    def done(self) -> bool:
        return not self._thread.is_alive()

    def wait(self) -> None:
        self._thread.join()


# ---------------------------------------------------------------------------
# the operator
_enum_cache: dict[str, list] = {}  # Blender keeps no reference to a dynamic enum's strings


def _principled_items(self, context):
    items = [(m.name, m.name, f"Render '{m.name}' on the reference sphere and fit to it", "MATERIAL", k)
             for k, m in enumerate(principled_materials())]
    if not items:
        items = [(NO_MATERIAL, "No Principled BSDF material in this file", "", "ERROR", 0)]
    _enum_cache["principled"] = items
    return items


def _start_items(self, context):
    items = [(CHOOSE, "Choose the Structure", "Try every structure (optics, lower boundary, base, lower medium), "
                                              "each at its best thickness order, and keep the closest (minutes)")]
    obj = getattr(context, "object", None)
    if obj is not None and layered_material_of(obj) is not None:
        items.append((CURRENT, "Current Values", "Start from the layered material's own values"))
    names = list(ARTIST_PRESETS) + list(PAPER_PRESETS)
    items += [(n, preset_label(n), f"Start from the preset '{preset_label(n)}'") for n in names]
    items += [(user_presets.USER_PREFIX + n, n, f"Start from your preset '{n}'")
              for n in user_presets.user_preset_names()]
    items = [(ident, label, tip, k) for k, (ident, label, tip) in enumerate(items)]
    _enum_cache["start"] = items
    return items


def _find(collection, pointer: int):
    return next((block for block in collection if block.as_pointer() == pointer), None)


class LAYERED_BRDF_OT_fit_to_render(Operator):
    """Fit the layered material to a reference-sphere render (its sidecar .json) or to a Principled BSDF \
material of this file (Esc cancels)"""

    bl_idname = "layered_brdf.fit_to_render"
    bl_label = "Fit to Render..."
    bl_options = {"REGISTER", "UNDO"}

    source: EnumProperty(name="Target", items=(
        ("RENDER", "Render", "A reference-sphere render of layered-brdf (its sidecar .json, the EXR beside it)"),
        ("PRINCIPLED", "Principled Material", "A Principled BSDF material of this file, rendered on the "
                                              "reference sphere under three suns"),
    ), default="PRINCIPLED")
    filepath: StringProperty(name="Sidecar", subtype="FILE_PATH",
                             description="The render's sidecar STEM.json (STEM.exr beside it)")
    sphere: IntProperty(name="Sphere", default=0, min=0,
                        description="Which sphere of the render (a gallery holds several; 0 is the first)")
    principled: EnumProperty(name="Material", items=_principled_items,
                             description="The Principled BSDF material to match")
    start: EnumProperty(name="Start From", items=_start_items,
                        description="The values the fit starts from (it searches the film's thickness "
                                    "orders and every continuous parameter the start's modes use)")

    @classmethod
    def poll(cls, context):
        return takes_layered_material(getattr(context, "object", None))

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self, width=360)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.row().prop(self, "source", expand=True)
        if self.source == "RENDER":
            layout.prop(self, "filepath")
            layout.prop(self, "sphere")
        else:
            layout.prop(self, "principled")
        layout.prop(self, "start")

    # --- what to fit, from what -------------------------------------------
    def _target_views(self) -> list:
        if self.source == "RENDER":
            if not self.filepath:
                raise ParameterError("filepath", self.filepath, "the path of a render's sidecar .json")
            return sidecar_views(bpy.path.abspath(self.filepath), sphere=self.sphere)
        return principled_views_of(self._principled_material(), hdris=[hdri_path(h) for h in DEFAULT_HDRIS])

    def _principled_material(self):
        if self.principled == NO_MATERIAL:
            raise ParameterError("material", "", "a Principled BSDF material of this file (it holds none)")
        mat = bpy.data.materials.get(self.principled)
        if mat is None:
            raise ParameterError("material", self.principled, "a Principled BSDF material of this file")
        return mat

    def _start_params(self, obj) -> LayeredParams | None:
        if self.start == CHOOSE:
            return None
        if self.start == CURRENT:
            params = start_of(obj)
            if params is None:
                raise ParameterError("start", self.start, "a preset (the object has no layered material yet)")
        else:
            params = user_presets.preset_params(self.start)
        return start_for(params, self._principled_material()) if self.source == "PRINCIPLED" else params

    def _prepare(self, context):
        """(target, views, start): the material (or the object) to fit, the rendered target, the start."""
        obj = context.object
        mat = layered_material_of(obj)
        target = layered_target(mat if mat is not None else obj)
        start = self._start_params(obj)
        views = self._target_views()
        sphere_target(views)  # a target that cannot be fitted is refused now, not in the thread
        return target, views, start

    def _target_name_shown(self) -> str:
        return f"the render {bpy.path.basename(self.filepath)}" if self.source == "RENDER" \
            else f"the material '{self.principled}'"

    def execute(self, context):
        try:
            target, views, start = self._prepare(context)
        except (ParameterError, OSError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        except TargetError as e:
            self.report({"ERROR"}, f"Cannot fit to {self._target_name_shown()}: {e}")
            return {"CANCELLED"}
        except RuntimeError as e:  # Blender could not render the target (a render already running...)
            self.report({"ERROR"}, f"Cannot render {self._target_name_shown()}: {e}")
            return {"CANCELLED"}
        self._target_kind = "objects" if isinstance(target, bpy.types.Object) else "materials"
        self._target_pointer = target.as_pointer()
        self._target_name = target.name
        principled = self._principled_material() if self.source == "PRINCIPLED" else None
        self._job = FitJob(views, start, dict(FIT_OPTIONS), try_noise=principled is None,
                           surface=None if principled is None else surface_of(principled),
                           uniform_film=principled is not None and uniform_film(principled))
        if bpy.app.background or context.window is None:  # no event loop to wait in
            self._job.begin().wait()
            return self._finish(context)
        self._total = expected_evaluations(start, **FIT_OPTIONS) if start is not None else None
        wm = context.window_manager
        self._timer = wm.event_timer_add(TIMER_SECONDS, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 1)
        self._job.begin()
        self._status(context)
        return {"RUNNING_MODAL"}

    # --- while it runs ----------------------------------------------------
    def _status(self, context) -> None:
        if self._job.stopping:
            text = "Layered BRDF: stopping the fit..."
        elif self._total is None:  # choosing the structure
            share = min(selection_share(self._job.stage), 0.99)
            doing = stage_words(self._job.stage)
            text = (f"Layered BRDF: fitting '{self._target_name}', {doing or 'starting'} "
                    f"(about {100 * share:.0f}%). Esc or right click cancels")
        else:
            share = min(self._job.evaluations / max(self._total, 1), 0.99)
            text = (f"Layered BRDF: fitting '{self._target_name}', {self._job.evaluations} evaluations "
                    f"(about {100 * share:.0f}%). Esc or right click cancels")
        if not self._job.stopping:
            context.window_manager.progress_update(share)
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def _end_progress(self, context) -> None:
        wm = context.window_manager
        if getattr(self, "_timer", None) is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
            wm.progress_end()
            if context.workspace is not None:
                context.workspace.status_text_set(None)

    def modal(self, context, event):
        if event.type in {"ESC", "RIGHTMOUSE"} and event.value == "PRESS":
            self._job.stop()
            self._status(context)
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if not self._job.done:
            self._status(context)
            return {"PASS_THROUGH"}
        self._end_progress(context)
        return self._finish(context)

    def cancel(self, context):
        """Blender ends the operator (a file is loaded, the window closes): the fit stops too."""
        self._job.stop()
        self._end_progress(context)

    def _finish(self, context):
        job = self._job
        if isinstance(job.error, FitCancelled):
            self.report({"WARNING"}, f"Fit cancelled: '{self._target_name}' is unchanged")
            return {"CANCELLED"}
        if job.error is not None:
            e = job.error
            known = isinstance(e, (ParameterError, TargetError))
            self.report({"ERROR"}, f"The fit failed: {e}" if known else f"The fit failed: {type(e).__name__}: {e}")
            return {"CANCELLED"}
        target = _find(getattr(bpy.data, self._target_kind), self._target_pointer)
        if target is None:
            self.report({"ERROR"}, f"'{self._target_name}' was removed while the fit ran: nothing applied")
            return {"CANCELLED"}
        try:
            mat = apply_fitted(target, job.result.params)
        except ParameterError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, fit_report(job.result, mat.name))
        note = structures.far_fit_note(job.result.mean_delta_e, job.start is None, "with 'Choose the Structure'")
        if note is not None:
            self.report({"WARNING"}, f"'{mat.name}': {note}")
        return {"FINISHED"}
