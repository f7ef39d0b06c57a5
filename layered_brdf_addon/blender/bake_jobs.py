"""Slow bakes beside the interface: a film stack's tables (a disordered stack's take seconds) are baked on a
worker thread while the artist goes on, and the material takes them when they are done.

Where Blender runs with its interface (not ``bpy.app.background``), an edit of a stack's material whose
tables are not baked yet starts their bake (:func:`~..model.table_check.bake_later`) and returns: the
material keeps what it had (the viewport shows the look of before the edit, the panel says the tables are
baking) until a timer on the main thread finds the bake done and brings every layered material up to date
(:func:`.freshness.freshen_all`, which now finds the bake kept).  A drag of a slider bakes the value it is
at when the worker is free and the last one, not every value it passed.

A render must not show the look of before an edit: before a render (``render_init``) the add-on waits for
the bakes that run.  A render from the interface runs that handler on the render's thread, before the
render reads the scene: the handler holds the render there until the timer has given the materials their
tables on the main thread (at most :data:`RENDER_WAIT_S`).  Without an interface (a batch render, a
script run with ``--background``), and within :func:`waiting`, bakes run at once as before.
"""
from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager

import bpy

from ..model import table_check
from ..model.params import LayeredParams
from ..model.plan import EffectPlan

POLL_S = 0.1  # how often the main thread looks for finished bakes
RENDER_WAIT_S = 120.0  # the longest a render waits for the bakes that run

_state = {"defer": None, "waiting": 0, "refresh": None}  # defer: None follows the interface, True/False as
# chosen (deferred()); refresh: what brings the materials up to date once a bake is done (.freshness sets it)
_pending: list = []  # the bakes started beside the interface (futures), until the materials took them


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def deferred(on: bool = True):
    """Bakes beside the interface (``on``) or at once within the block, whether Blender has an interface or
    not (what a test of the interface's behaviour, or a script that wants it, asks for)."""
    before = _state["defer"]
    _state["defer"] = on
    try:
        yield
    finally:
        _state["defer"] = before


@contextmanager
def waiting():
    """Bakes at once within the block (a render's handlers)."""
    _state["waiting"] += 1
    try:
        yield
    finally:
        _state["waiting"] -= 1


def when_done(refresh) -> None:
    """What the timer runs once a bake is done: :func:`.freshness.freshen_all` (which imports this module)."""
    _state["refresh"] = refresh


def deferring(plan: EffectPlan) -> bool:
    """Whether a bake for ``plan`` asked for now runs beside the interface: a stack's (the bakes that take
    longer than a frame), with the interface (or :func:`deferred`), on the main thread, outside :func:`waiting`."""
    defer = _state["defer"] if _state["defer"] is not None else not bpy.app.background
    return bool(plan.stack) and defer and not _state["waiting"] and _main_thread()


def start(params: LayeredParams, plan: EffectPlan, owner: str) -> bool:
    """Start the bake of ``params`` for ``plan`` beside the interface for ``owner`` (a shader node's
    pointer) and look for it on a timer; False where it is kept already (bake now: it is instant)."""
    future = table_check.bake_later(params, plan, owner)
    if future is None:
        return False
    if all(f is not future for f in _pending):
        _pending.append(future)
    if not bpy.app.timers.is_registered(poll):
        bpy.app.timers.register(poll, first_interval=POLL_S)
    return True


def baking(params: LayeredParams, plan: EffectPlan) -> bool:
    """Whether the tables of ``params`` for ``plan`` are being baked beside the interface."""
    return table_check.bake_running(params, plan)


def baking_any() -> bool:
    return bool(_pending)


def poll():
    """The timer: once a bake is done, bring the layered materials up to date (each that waited finds its
    tables kept); again in :data:`POLL_S` while bakes run, else no more."""
    done = [f for f in _pending if f.done()]
    if done:
        for future in done:
            _pending.remove(future)
            if not future.cancelled() and future.exception() is not None:
                print(f"Layered BRDF: a stack's tables could not be baked: {future.exception()}", file=sys.stderr)
        refresh = _state["refresh"]
        if refresh is not None:
            refresh()
    return POLL_S if _pending else None


def finish(timeout: float = RENDER_WAIT_S) -> bool:
    """Wait for the bakes beside the interface and give the materials their tables: on the main thread by
    running the timer's work here, on another (a render's) by waiting for the timer to have done it.  False
    where they were not all given within ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    if _main_thread():
        while _pending and time.monotonic() < deadline:
            for future in list(_pending):
                try:
                    future.result(timeout=max(deadline - time.monotonic(), 0.0))
                except Exception:  # cancelled, failed (said by poll) or out of time
                    pass
            poll()
        return not _pending
    while _pending and time.monotonic() < deadline:
        time.sleep(POLL_S / 2)  # the main thread's timer applies them
    return not _pending


def stop() -> None:
    """No more looking for bakes (the add-on unregistered): the timer goes; the bakes that run finish and
    are kept, and a later edit or render takes them."""
    if bpy.app.timers.is_registered(poll):
        bpy.app.timers.unregister(poll)
    _pending.clear()
