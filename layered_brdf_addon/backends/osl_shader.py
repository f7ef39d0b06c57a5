"""The OSL backend: the shading program written out as a Cycles OSL shader, one per plan.

``shader_source(plan)`` runs :func:`~..model.program.layered_surface` on
:class:`~.osl_ops.OslOps`: every step of the program becomes an OSL function of the same
name, and the shader body is the program's top level.  The shader's parameters (names,
defaults, ranges, help) come from the parameter definitions.  Each plan gets its own
shader, with only the code its effects need.

A plan with tables (:mod:`..model.shading.tables`) reads its closures from a material's
baked tables: ``tabulated_shader_source(plan, layout, texels)`` writes them into the shader
as one constant array (OSL's ``texture()`` reads image files only, and a material's tables
are packed in its .blend), read with the Image Texture node's own interpolation.  Such a
shader is the material's own, like its tables.  bpy-free.
"""
from __future__ import annotations

from dataclasses import replace

import functools

import numpy as np

from ..model import program
from ..model.params import (BASE_COLOR_DESCRIPTION, THICKNESS_DESCRIPTION, THICKNESS_SOCKET, LayeredParams,
                            group_socket_name, iter_group_sockets, iter_sockets, socket_default, socket_limits,
                            socket_name)
from ..model.plan import EffectPlan
from ..model.policy import check_backend
from ..model.shading.surface_prelude import UNLINKED_THICKNESS
from ..model.shading.tables import TableLayout, tabulable
from .osl_ops import OslOps
from .osl_text import PREC_ATOM, FunctionBody, Val, literal, run_capturing_locals

OSL_VERSION = 3  # 3: the base colour one colour parameter (BaseColor), no tint
SHADER_NAME = "layered_brdf"

# Shader parameters and outputs besides the material's parameters (OSL names have no spaces;
# the node group's sockets are "Base Color", "Base Shader", "Lower Normal", "Upper Normal").
THICKNESS_INPUT = "ThicknessIn"  # the OSL name of the Thickness input (Thickness is the output's)
SOCKET_NAMES = {"Base Color": "BaseColor", "Base Shader": "Base", "Lower Normal": "LowerNormal",
                "Upper Normal": "UpperNormal", "Normal": "Normal", "BSDF": "BSDF", "Thickness": "Thickness",
                "Transmittance": "Transmittance"}

HEADER = """\
/* SPDX-License-Identifier: Apache-2.0
 *
 * Layered RGB BRDF (Granier & Heidrich, "A Simple Layered RGB BRDF Model",
 * Graphical Models 65, 2003) as a Cycles OSL shader, effect plan {key}.
 *
 * Written by layered_brdf_addon/backends/osl_shader.py from the shading program
 * (layered_brdf_addon/model/program.py): each function below is a step of the program,
 * under the same name.  An OSL shader never sees the light direction, so the specular
 * part is a weighted sum of built-in glossy closures whose weights depend on the view:
 *
 *   - a reflected lobe about the mirror of the view (closure normal n0), eq. 6;
 *   - transmitted lobes about l*, the light direction whose path through the layer
 *     leaves along the view, eq. 10;
 *   - interference lobes 2 cos(2 Phi) sqrt(R T), eqs. 3 and 5, folded into the other
 *     two (Cycles clamps negative closure weights to 0, and a closure fewer per channel
 *     costs less).
 *
 * Each lobe amplitude is the pixel value per unit irradiance at the lobe's centre; it
 * becomes a closure weight by dividing by the closure's own value there.  With thin-film
 * optics a lobe carries a reflectance instead, and its closure's weight is that
 * reflectance over the closure's own albedo: the closure returns, over the hemisphere,
 * what the film reflects at that angle (energy-keeping lobes).  The diffuse
 * part is eqs. 14-18 on a diffuse closure about n0.  Cycles' I points towards the viewer
 * (the program's v, named V here: v is an OSL global).  Thickness d is in nanometres.
 *
 * Plan: {plan}.
 */

#include "stdcycles.h"
#include "node_noise.h"
"""

LIBRARY = """\
/* ------------------------------------------------------------------ guarded maths */

/* sqrt of a value that rounding (or a failed refraction) may push below 0. */
float safe_sqrt(float x)
{
  return sqrt(max(x, 0.0));
}

vector safe_sqrt(vector x)
{
  return sqrt(max(x, vector(0.0)));
}

/* exp that cannot overflow: arguments come from products of exponents up to 1e5. */
float safe_exp(float x)
{
  return exp(min(x, 80.0));
}

vector safe_exp(vector x)
{
  return exp(min(x, vector(80.0)));
}

/* Per component, 1 where a > b (a < b), else 0: masks of the three channels. */
vector greater_than(vector a, vector b)
{
  return vector(a[0] > b[0], a[1] > b[1], a[2] > b[2]);
}

vector less_than(vector a, vector b)
{
  return vector(a[0] < b[0], a[1] < b[1], a[2] < b[2]);
}

/* Unit vector, or `fallback` for zero-length vectors (V + l* = 0, a degenerate Normal
 * input) and non-finite ones (inf or NaN from a broken texture). */
vector safe_normalize_or(vector a, vector fallback)
{
  float len2 = dot(a, a);
  if (!(len2 > 1e-20) || !isfinite(len2)) {
    return fallback;
  }
  return a / sqrt(len2);
}

/* An input that any texture or driver may feed, clamped to its parameter's range
 * (params.py); NaN falls to the lower bound. */
float clamp_input(float x, float lo, float hi)
{
  if (isnan(x)) {
    return lo;
  }
  return clamp(x, lo, hi);
}

/* x, or 0 where it is NaN. */
float nan_to_zero(float x)
{
  return isnan(x) ? 0.0 : x;
}

/* Blender's Noise Texture node, 4D fBm, lacunarity 2, distortion 0, normalised:
 * p and w scaled by `scale`, then noise_fbm (node_noise_texture.osl). */
float thickness_noise(vector p, float w, float scale, float detail, float roughness)
{
  vector ps = p * scale;
  return noise_fbm(vector4(ps[0], ps[1], ps[2], w * scale), detail, roughness, 2.0, 1);
}

/* Blender's Bump node, inverted (node_bump.osl): n tilted by `distance` times the surface
 * gradient of the height h, from h's screen-space derivatives; a height without derivatives
 * (a constant) leaves n as it is. */
vector bump_normal(vector n, float h, float distance)
{
  vector dPdx = Dx(P);
  vector dPdy = Dy(P);
  vector Rx = cross(dPdy, n);
  vector Ry = cross(n, dPdx);
  float det = dot(dPdx, Rx);
  vector surfgrad = Dx(h) * Rx + Dy(h) * Ry;
  return safe_normalize_or(fabs(det) * n + distance * sign(det) * surfgrad, n);
}
"""

TABLE_LIBRARY = """\
/* ------------------------------------------------------------------ baked tables */

/* The tables are held as running sums along d: image k's column i (the view's angle) at
 * knot j (0..h, the edges of the texels along d) holds the sum of its first j texels,
 * RGBA at t[((k * (h + 1) + j) * w + i) * 4].  At y (texel units along d) the sum is
 * linear between knots, and past the ends grows by the edge texel's value per unit. */
void table_sum(float t[], int w, int h, int k, int i, float y, output vector rgb, output float alpha)
{
  float yc = clamp(y, 0.0, (float)h);
  int j = min((int)floor(yc), h - 1);
  float f = yc - j;
  int lo = ((k * (h + 1) + j) * w + i) * 4;
  int hi = lo + w * 4;
  vector c0 = vector(t[lo], t[lo + 1], t[lo + 2]);
  vector c1 = vector(t[hi], t[hi + 1], t[hi + 2]);
  rgb = mix(c0, c1, f) + (y - yc) * (c1 - c0);
  alpha = mix(t[lo + 3], t[hi + 3], f) + (y - yc) * (t[hi + 3] - t[lo + 3]);
}

/* Image k of a material's baked tables at xy (0..1) averaged over `width` of y (the pixel's
 * footprint; at least one texel): linear between the texels' centres ((i + 0.5) / w) along
 * the view's angle and extended at the edges, as Blender's Image Texture node reads the
 * node group's tables, and a box of `width` along d, the difference of two running sums
 * (one texel wide it is linear interpolation between texel centres too). */
void baked_table(float t[], int w, int h, int k, vector xy, float width, output vector rgb,
                 output float alpha)
{
  float px = clamp(xy[0], -1.0, 2.0) * w - 0.5;
  float fx = px - floor(px);
  int x0 = clamp((int)floor(px), 0, w - 1);
  int x1 = clamp((int)floor(px) + 1, 0, w - 1);
  float y = clamp(xy[1], -1.0, 2.0) * h;
  float box = max(min(width, 3.0) * h, 1.0);
  vector s00, s01, s10, s11;
  float a00, a01, a10, a11;
  table_sum(t, w, h, k, x0, y - 0.5 * box, s00, a00);
  table_sum(t, w, h, k, x0, y + 0.5 * box, s01, a01);
  table_sum(t, w, h, k, x1, y - 0.5 * box, s10, a10);
  table_sum(t, w, h, k, x1, y + 0.5 * box, s11, a11);
  rgb = mix(s01 - s00, s11 - s10, fx) / box;
  alpha = mix(a01 - a00, a11 - a10, fx) / box;
}
"""

TABLES_ARRAY = "baked_tables"
_TABLES_PLACEHOLDER = "\x03tables\x03"

GLOSSY = {
    "beckmann": """\
/* The glossy closure of a lobe about `Nc`: Beckmann microfacets, alpha_x along the
 * tangent `U` and alpha_y across it (OSL's microfacet() takes the alphas themselves, not
 * the Glossy node's Roughness and Anisotropy). */
closure color glossy_lobe(vector Nc, vector U, float e, float alpha_x, float alpha_y, color weight)
{
  return weight * microfacet("beckmann", normal(Nc), U, alpha_x, alpha_y, 0.0, 0);
}
""",
    "phong": """\
/* The glossy closure of a lobe about `Nc`: a normalised Phong lobe of exponent e about the
 * mirror of the view (phong_ramp with eight equal colours). */
closure color glossy_lobe(vector Nc, vector U, float e, float alpha_x, float alpha_y, color weight)
{
  color ramp[8] = {color(1.0), color(1.0), color(1.0), color(1.0),
                   color(1.0), color(1.0), color(1.0), color(1.0)};
  return weight * phong_ramp(normal(Nc), e, ramp);
}
""",
}


class ShaderOps(OslOps):
    """OSL ops in the shader body: the shader's parameters and globals."""

    SOCKETS = "osl"  # whose sockets the inputs are (params.socket_units)

    def input(self, name):
        if name == "Normal":
            return self.atom(name, "vector")
        if name == THICKNESS_SOCKET:
            return self.atom(THICKNESS_INPUT, "float")
        spec = LayeredParams.spec(name)
        if spec.component is not None:  # a channel of a colour parameter
            return self.atom(f"{SOCKET_NAMES[group_socket_name(spec)]}[{spec.component}]", "float")
        return self.atom(socket_name(spec), "float")

    def shading_normal(self):
        return self.atom("N", "vector")

    def incoming(self):
        return self.atom("I", "vector")

    def object_position(self):
        return self.emit("vector", 'transform("object", P)')

    def object_to_world(self, vec):
        return self.emit("vector", f'transform("object", "world", {self.use(vec)})')

    def world_to_object(self, vec):
        return self.emit("vector", f'transform("world", "object", {self.use(vec)})')

    def noise_fbm(self, p, w, scale, detail, roughness):
        return self.call_expr("thickness_noise", (p, w, scale, detail, roughness), "float")

    def bump_normal(self, n, height, distance):
        return self.call_expr("bump_normal", (n, height, distance), "vector")

    table_shape: tuple[int, int] | None = None  # (w, h) of the material's baked tables
    table_footprint: bool = False  # average the tables over the pixel's footprint along d
    _table_widths: dict | None = None

    def table(self, k, xy):
        """Image ``k`` of the material's baked tables at ``xy``: its colour and alpha (the tables are the
        shader body's constant array, :data:`TABLES_ARRAY`), averaged over the pixel's footprint along
        the thickness where the plan filters over it (``filterwidth``, as the computed shader does)."""
        w, h = self.table_shape
        widths = self._table_widths = self._table_widths or {}
        if xy.token not in widths:
            widths[xy.token] = self.emit("float", f"filterwidth({self.use(xy, PREC_ATOM)}[1])") \
                if self.table_footprint else 0.0
        width = widths[xy.token]
        outs = []
        for hint, kind in (("table_rgb", "vector"), ("table_alpha", "float")):
            out = self.emit(kind, None)
            self.body.by_token[out.token].hint = hint
            outs.append(out)
        self.raw(f"baked_table({TABLES_ARRAY}, {w}, {h}, {k}, {self.use(xy)}, {self.use(width)}, "
                 f"{self.use(outs[0])}, {self.use(outs[1])});")
        return tuple(outs)


def _parameter_lines() -> list[str]:
    lines = ["normal Normal = N",
             f"float {THICKNESS_INPUT} = {UNLINKED_THICKNESS:.1f}\n      [[ string label = \"Thickness\", "
             f"string help = \"{THICKNESS_DESCRIPTION}\" ]]"]
    for sock in iter_group_sockets():
        if sock.is_color:
            default = ", ".join(literal(spec.default) for spec in sock.specs)
            lines.append(f"color {SOCKET_NAMES[sock.name]} = color({default})\n"
                         f'      [[ string label = "{sock.name}", string help = "{BASE_COLOR_DESCRIPTION}" ]]')
            continue
        (spec,) = sock.specs
        lo, hi = socket_limits(spec, "osl")
        unit = f" ({spec.unit})" if spec.unit else ""
        help_text = spec.socket_description if spec.socket_units else f"{spec.description}{unit}"
        meta = [f'string label = "{sock.name}"', f'string help = "{help_text}"',
                f"float min = {literal(lo)}", f"float max = {literal(hi)}"]
        if spec.soft_min is not None and not spec.socket_units:
            meta += [f"float slidermin = {literal(spec.soft_min)}", f"float slidermax = {literal(spec.soft_max)}"]
        default = socket_default(spec, "osl")
        lines.append(f"float {socket_name(spec)} = {literal(default)}\n      [[ {', '.join(meta)} ]]")
    lines += [
        "closure color Base = 0",
        "output closure color BSDF = 0",
        "output float Thickness = 0",
        "output vector LowerNormal = 0",
        "output vector UpperNormal = 0",
        "output color Transmittance = 0",
    ]
    return lines


@functools.lru_cache(maxsize=64)
def shader_source(plan: EffectPlan) -> str:
    """The OSL source of the shader for ``plan``, computing its closures (a plan's tables are a
    material's own: :func:`tabulated_shader_source`)."""
    return _source(replace(plan, tables=False))


def tabulated_shader_source(plan: EffectPlan, layout: TableLayout, texels: np.ndarray) -> str:
    """The OSL source of the shader for ``plan`` (with tables) reading ``texels`` (float32, images x H x W x
    RGBA, :func:`~..model.table_bake.bake`), laid out as ``layout`` says."""
    if not plan.tables:
        raise ValueError(f"plan {plan.key} computes its closures: it reads no tables")
    if not tabulable(plan, "osl"):
        raise ValueError(f"plan {plan.key}: the OSL shader reads tables of parallel boundaries only")
    texels = np.ascontiguousarray(texels, dtype=np.float32)
    if texels.shape != (layout.images, layout.height, layout.width, 4):
        raise ValueError(f"texels of shape {texels.shape} for tables of {layout.images} images of "
                         f"{layout.width} x {layout.height}")
    src = _source(plan, layout)
    return src.replace(_TABLES_PLACEHOLDER, _array_text(running_sums(texels)))


def running_sums(texels: np.ndarray) -> np.ndarray:
    """The tables as the OSL shader holds them: along d, the sums of the first 0..H texels (images x (H + 1)
    x W x RGBA), summed in double precision."""
    sums = np.zeros((texels.shape[0], texels.shape[1] + 1, *texels.shape[2:]))
    sums[:, 1:] = np.cumsum(texels.astype(np.float64), axis=1)
    return sums.astype(np.float32)


def _array_text(values: np.ndarray) -> str:
    """``values`` as an OSL initialiser list, eight significant digits (within a float's last bit or two),
    16 to a line."""
    words = list(map("{:.8g}".format, values.ravel().astype(np.float64).tolist()))
    rows = [", ".join(words[i:i + 16]) for i in range(0, len(words), 16)]
    return "\n      " + ",\n      ".join(rows) + "\n  "


def _source(plan: EffectPlan, layout: TableLayout | None = None) -> str:
    check_backend("osl", plan.lobe)
    ops = ShaderOps()
    body = FunctionBody(SHADER_NAME, code=program.layered_surface.__code__)
    ops._bodies.append(body)
    if plan.tables:
        ops.table_shape = (layout.width, layout.height)
        ops.table_footprint = plan.analytic and plan.footprint
        n = layout.images * (layout.height + 1) * layout.width * 4
        ops.raw(f"/* The material's baked tables: {layout.images} images of {layout.width} x {layout.height} "
                f"texels (the view's angle x d), RGBA, as running sums along d. */")
        ops.raw(f"float {TABLES_ARRAY}[{n}] = {{{_TABLES_PLACEHOLDER}}};")
    res, local_names = run_capturing_locals(program.layered_surface, ops, {}, {"plan": plan, "layout": layout})
    x = res.extras
    ops.raw("/* The artist's own shader under the layer receives what the layer passes on: 1 - F(v) with the "
            "paper's optics, with thin-film optics what the film passes in the channel where it passes least. */")
    ops.raw(f"BSDF = {ops.use(x['base_weight'], 14)} * Base;")
    if res.diffuse is not None:
        ops.raw("/* Eqs. 14-18: a Lambertian closure about n0 tinted by kd base rho_d. */")
        ops.raw(f"BSDF += {_colour(ops, res.diffuse)} * diffuse({ops.use(x['upper_normal'])});")
    for cl in res.glossy:
        # The alphas along the tangent and across it, as the Glossy BSDF node derives them
        # (an isotropic lobe gets two equal alphas, so its tangent, which may vanish, is
        # never used); Phong ignores them.
        a_x, a_y = (program.glossy_alphas(ops, cl.alpha, cl.anisotropy) if plan.lobe == "beckmann"
                    else (cl.alpha, cl.alpha))
        ops.raw(f"BSDF += glossy_lobe({ops.use(cl.normal)}, {ops.use(cl.tangent)}, {ops.use(_exponent(cl))}, "
                f"{ops.use(a_x)}, {ops.use(a_y)}, {_colour(ops, cl.weight)});  /* {cl.name} */")
    ops.raw(f"Thickness = {ops.use(x['thickness'])};")
    ops.raw(f"LowerNormal = {ops.use(x['lower_normal'])};")
    ops.raw(f"UpperNormal = {ops.use(x['upper_normal'])};")
    ops.raw(f"Transmittance = {ops.use(x['transmittance'])};")
    reserved = {socket_name(s) for s in iter_sockets()} | set(SOCKET_NAMES.values()) | {TABLES_ARRAY}
    main = ops.resolve(body, local_names, reserved=reserved)
    params = ",\n                    ".join(_parameter_lines())
    parts = [HEADER.format(key=plan.key, plan="; ".join(plan.describe())), LIBRARY,
             *((TABLE_LIBRARY,) if plan.tables else ()), GLOSSY[plan.lobe],
             "/* ------------------------------------------------------------------ the program's steps */\n",
             ops.source_of_functions(),
             "/* ------------------------------------------------------------------ the shader */\n",
             f"shader {SHADER_NAME}({params})\n{{\n{main}}}\n"]
    return "\n".join(parts)


def _colour(ops, rgb) -> str:
    if isinstance(rgb, Val):  # a colour read from the tables
        rgb = ops.components(rgb)
    if all(not isinstance(c, Val) for c in rgb) and len(set(rgb)) == 1:
        return f"color({literal(rgb[0])})"
    return f"color({', '.join(ops.use(c) for c in rgb)})"


def _exponent(cl):
    """A closure's Phong exponent, 0 where it has none (a tabulated closure has its width as an alpha: the
    Beckmann lobe, which ignores the exponent)."""
    return 0.0 if cl.exponent is None else cl.exponent
