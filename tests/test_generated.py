"""The generated files are current, and the OSL shader of every plan compiles (no render)."""
import itertools

from layered_brdf_addon.backends import generated
from layered_brdf_addon.backends.osl_shader import shader_source
from layered_brdf_addon.model.plan import EffectPlan

REGENERATE = "python -m layered_brdf_addon.backends.generated"


def test_committed_osl_shader_is_current():
    assert generated.OSL_FILE.read_text() == generated.osl_text(), f"stale: run {REGENERATE}"


def test_committed_node_group_description_is_current():
    from layered_brdf_addon.blender.scene import reset_blender

    reset_blender()
    path = generated.node_group_file(generated.default_plan())
    assert path.read_text() == generated.node_group_description(), f"stale: run {REGENERATE}"


def all_plans():
    """Every combination of the structural effects in RGB, and every spectral mode."""
    for spec, diff, thick, normals, disp, lobe in itertools.product(
            (True, False), (True, False), ("noise", "height", "constant"), ("parallel", "tilted", "correlated"),
            (True, False), ("beckmann", "phong")):
        yield EffectPlan(spec, diff, thick, normals, disp, lobe)
    for n, disp, interference, lobe in itertools.product((4, 8, 16, 32), (True, False), (True, False),
                                                         ("beckmann", "phong")):
        yield EffectPlan(True, True, "noise", "correlated", disp, lobe, n, interference)


def test_every_plan_compiles_with_blenders_osl_compiler(tmp_path):
    import addon_utils

    addon_utils.enable("cycles", default_set=False)
    import _cycles

    failures = []
    plans = list(all_plans())
    for plan in plans:
        src = tmp_path / f"{plan.key}.osl"
        src.write_text(shader_source(plan))
        if not _cycles.osl_compile(str(src), str(tmp_path / f"{plan.key}.oso")):
            failures.append(plan.key)
    assert not failures, failures
    assert len({p.key for p in plans}) == len(plans) == 176


def test_shader_reads_like_a_program_of_named_functions():
    src = shader_source(EffectPlan.full())
    for step in ("vector schlick(", "vector fresnel_f0(", "void channel_block(", "void fold_basis(", "void fold_weights(", "void lobe_geometry(",
                 "vector correlated_normal(", "float thickness_at("):
        assert step in src, step
    assert "#if" not in src and "#define" not in src  # specialised per plan, not by the preprocessor
    # Only what a plan needs: no noise call without a noise pattern, no tilt code without a tilt.
    plain = shader_source(EffectPlan(thickness="height", normals="parallel"))
    assert "thickness_noise(p" not in plain.split("shader layered_brdf")[1]
    assert "tilted_normal" not in plain and "correlated_normal" not in plain


def test_the_shader_names_its_variables_the_same_under_a_profiler():
    """The OSL's variable names come from the program's locals; a profiler (cProfile) running
    while it is written changes nothing."""
    import cProfile

    plan = generated.default_plan()
    expected = shader_source.__wrapped__(plan)
    profiler = cProfile.Profile()
    profiler.enable()
    try:
        profiled = shader_source.__wrapped__(plan)
    finally:
        profiler.disable()
    assert profiled == expected == generated.OSL_FILE.read_text()


def test_the_node_groups_stamp_follows_what_they_compute_not_their_docstrings(monkeypatch):
    """Editing a docstring or a comment leaves every saved group current; a change to the code
    does not."""
    from layered_brdf_addon.backends import node_group
    from layered_brdf_addon.model import program

    before = node_group._output_digest()
    monkeypatch.setattr(program.schlick.program_step, "__doc__", "Reworded: the OSL comment changes, not the maths.")
    shader_source.cache_clear()
    assert "Reworded" in shader_source(generated.default_plan())
    shader_source.cache_clear()
    try:
        assert node_group._output_digest() == before
    finally:
        shader_source.cache_clear()
    code = "def f(x):\n    '''Doc.'''\n    return x + 1  # one\n"
    reworded = "def f(x):\n    '''Another doc.'''\n    # a comment\n    return x + 1\n"
    assert node_group.code_without_docs(code) == node_group.code_without_docs(reworded)
    assert node_group.code_without_docs(code) != node_group.code_without_docs(code.replace("+ 1", "+ 2"))
    plans = node_group.stamp_plans()
    assert len({p.key for p in plans}) == len(plans)
