"""A material's film stack as its settings hold it: the panel's stack editor (a list of films, the number
of periods, the disorder, the domains) and the stack of the parameters (:class:`~..model.stack.FilmStack`).

The settings property group (:mod:`.properties`) gets :func:`stack_annotations` and the ``stack``
property (:func:`stack_from_settings`, :func:`write_stack`), so that reading and writing a material's
settings treat the stack as every other setting.
"""
from __future__ import annotations

from bpy.props import BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty
from bpy.types import PropertyGroup

from ..model.media import MEDIA
from ..model.stack import MAX_DISORDER, MAX_DOMAINS, MAX_FILM_NM, MAX_FILMS, MAX_K, STACK_KINDS, FilmStack

INDEX_ITEM = "ior"  # a film given by its IOR, Dispersion and k instead of a named medium
MEDIUM_ITEMS = ((INDEX_ITEM, "IOR", "The film's index given by its IOR, Dispersion and extinction k"),) + tuple(
    (name, m.label, f"{m.label}: measured n and k over 380-780 nm ({m.source.dataset})") for name, m in MEDIA.items())
KIND_ITEMS = (("periodic", "Periodic", "A period of films repeated (a Bragg mirror, a beetle's cuticle, nacre)"),
              ("list", "List", "Each film given once (a coating)"))
assert tuple(k for k, _, _ in KIND_ITEMS) == STACK_KINDS


def film_item_class(update):
    """The property group of one film of the stack editor; ``update`` runs after an edit."""
    ann = {
        "medium": EnumProperty(name="Medium", items=MEDIUM_ITEMS, default="chitin", update=update,
                               description="The film's medium (measured n and k), or IOR to give its index"),
        "thickness_nm": FloatProperty(name="Thickness", description="The film's thickness at scale 1 (nm)",
                                      default=100.0, min=0.0, max=MAX_FILM_NM, soft_max=1000.0, update=update),
        "ior": FloatProperty(name="IOR", description="The film's index at 587.6 nm, with Medium 'IOR'",
                             default=1.5, min=1.0, max=5.0, soft_max=3.0, update=update),
        "dispersion": FloatProperty(name="Dispersion", description="20 / V_d (Abbe number), with Medium 'IOR'",
                                    default=0.0, min=0.0, max=10.0, soft_max=2.0, update=update),
        "k": FloatProperty(name="k", description="The film's extinction coefficient, with Medium 'IOR'",
                           default=0.0, min=0.0, max=MAX_K, soft_max=1.0, update=update),
    }
    return type("LayeredBRDFStackFilm", (PropertyGroup,), {"__annotations__": ann,
                                                           "__doc__": "One film of a Layered BRDF stack"})


def stack_annotations(update, film_class) -> dict:
    """The stack editor's properties of the settings group."""
    return {
        "use_stack": BoolProperty(name="Film Stack", update=update,
                                  description="The layer as a stack of films (structural colour) with thin-film "
                                  "optics; off: one film of the layer's index"),
        "stack_kind": EnumProperty(name="Kind", items=KIND_ITEMS, default="periodic", update=update,
                                   description="A period of films repeated, or a list of films"),
        "stack_periods": IntProperty(name="Periods", description="How many times the period is repeated",
                                     default=8, min=1, max=MAX_FILMS, update=update),
        "stack_disorder": FloatProperty(name="Disorder", subtype="FACTOR", update=update, default=0.0, min=0.0,
                                        max=MAX_DISORDER,
                                        description="Spread of the films' thicknesses across periods (standard "
                                        "deviation over mean): softer, broader colours"),
        "stack_domains": IntProperty(name="Domains", default=1, min=1, max=MAX_DOMAINS, soft_max=256, update=update,
                                     description="Tilted lamellae in a crystal: how many domains of the stack lie one "
                                     "under the other, their light adding as power (a stone's many lamellae); 1 "
                                     "with a parallel lower boundary"),
        "stack_films": CollectionProperty(type=film_class, name="Films"),
        "stack_index": IntProperty(name="Active Film", default=0, min=0),
    }


def _film_dict(item) -> dict:
    if item.medium == INDEX_ITEM:
        return {"ior": item.ior, "dispersion": item.dispersion, "k": item.k, "thickness_nm": item.thickness_nm}
    return {"medium": item.medium, "thickness_nm": item.thickness_nm}


def stack_from_settings(st) -> FilmStack | None:
    """The stack the editor of ``st`` (a material's settings) describes, or None where it is off;
    :class:`~..model.errors.ParameterError` names the film and field of a bad one."""
    if not st.use_stack:
        return None
    periods = st.stack_periods if st.stack_kind == "periodic" else 1
    return FilmStack.from_dict({"kind": st.stack_kind, "films": [_film_dict(f) for f in st.stack_films],
                                "periods": periods, "disorder": st.stack_disorder, "domains": st.stack_domains})


def write_stack(st, stack: FilmStack | None) -> None:
    """Set the editor of ``st`` to ``stack`` (None: off, the films kept for a later switch on)."""
    if stack is None:
        if st.use_stack:
            st.use_stack = False
        return
    st.stack_films.clear()
    for film in stack.films:
        item = st.stack_films.add()
        if film.medium:
            item.medium = film.medium
        else:
            item.medium = INDEX_ITEM
            item.ior, item.dispersion, item.k = film.ior, film.dispersion, film.k
        item.thickness_nm = film.thickness_nm
    st.stack_kind = stack.kind
    st.stack_periods = stack.periods
    st.stack_disorder = stack.disorder
    st.stack_domains = stack.domains
    st.stack_index = min(st.stack_index, len(stack.films) - 1)
    st.use_stack = True


def stack_property():
    """The settings group's ``stack``: read from and written to the editor."""
    return property(stack_from_settings, write_stack)
